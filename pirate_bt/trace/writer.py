"""Record a run as a trace: a header, what changed in each tick, an end record.

Two parts, as in python-can's ``io`` package:

- :class:`TraceRecorder` knows about trees. After each tick it compares every
  node's status and feedback message, the blackboard, the robot state, link
  health and simulator counters with what it recorded last, and hands one
  *record* (a JSON object) to a format writer. Attach it to a tree with
  :meth:`TraceRecorder.post_tick_handler` (plain py_trees) or
  :func:`pirate_bt.trace.attach_to_runner` (the pirate_bt runner).
- A format writer (:class:`JsonLinesWriter`, :class:`GzipJsonLinesWriter`)
  knows about bytes. :data:`WRITERS` maps file suffixes to writer classes;
  :func:`open_writer` picks one by the path's suffix, so another format is one
  class and one :func:`register_writer` call (formats above this package, such
  as MCAP, register themselves: see :mod:`pirate_bt.trace.formats`). These three
  live in :mod:`pirate_bt.trace.registry` and are re-exported here.

JSON Lines format (``.jsonl``; ``.jsonl.gz`` is the same, gzip-compressed).
One JSON object per line, UTF-8, ``\\n``-terminated. Every object has a
``type``:

``header`` (first line, exactly once)
    ``format`` ("pirate-bt-trace"), ``version`` (int), ``created_utc``,
    ``tree`` (``name`` and ``nodes``: ``id`` path id such as ``0.1.2``,
    ``name``, ``type`` class name, ``kind`` composite/decorator/guard/leaf,
    ``parent``, ``children``, optional ``params`` and ``step``),
    ``robot`` (``name``, ``digest`` SHA-256 of the description, or null),
    ``scenario``, ``seed``, ``software`` (package -> version),
    ``clock`` (``simulated``/``wall``), ``tick_period_s``, ``full_state``,
    ``readings`` (whether raw channels are recorded), ``meta`` (free-form).

``tick`` (one per tick in which anything changed; every tick with ``every_tick``)
    ``n`` tick number (the first tick is 1), ``t_s`` seconds since the header,
    and only the members that changed: ``status`` (node id -> ``S``/``F``/``R``/
    ``I`` for SUCCESS/FAILURE/RUNNING/INVALID), ``feedback`` (node id ->
    message), ``bb`` (blackboard key -> new value), ``bb_unset`` (keys removed),
    ``state`` (flat state name -> value, e.g. ``joint_angle_rad.bend_1``;
    every value when ``full`` is true), ``commands`` (list of ``command``
    short form, ``verdict`` pass/clip/refuse, ``reason``, ``detail``, ``sent``
    ``[motor, mode, value]`` triples, ``source``, ``node``), ``link`` (changed
    link-health fields), ``sim`` (changed simulator counters), ``events``
    (``kind``, ``message``, ``node``).

``end`` (last line, once, absent if the run was killed)
    ``n`` last tick, ``t_s``, ``outcome`` (success/failure/error/interrupted/
    running), ``reason``, ``error`` (``node``, ``exception``) for a crash.

Crash safety: each record is written as one line and flushed at once, so a
run killed with SIGKILL leaves every complete tick on disk and at most one cut
line, which the reader skips. ``sync=True`` also fsyncs each tick (power loss).
The plain ``.jsonl`` writer hands each line to the kernel with one ``os.write``
on an unbuffered file (no Python buffer to flush, no background thread that a
SIGKILL could stop with ticks still queued).
"""

from __future__ import annotations

import logging
import operator
import platform
from collections.abc import Callable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

import py_trees

from pirate_bt.clock import Clock, WallClock
from pirate_bt.trace.formats import suffix_of
from pirate_bt.trace.nodes import NodeReader
from pirate_bt.trace.recorder_args import (
    check_destination,
    check_options,
    check_tree,
    unwritable,
)
from pirate_bt.trace.records import (
    FORMAT_NAME,
    LINK_FIELDS,
    OUTCOMES,
    TRACE_VERSION,
    CommandRecord,
    TickExtras,
    link_health_raw,
    state_layout,
)
from pirate_bt.trace.registry import WRITERS, WriterFactory, open_writer, register_writer
from pirate_bt.trace.sink import (
    END,
    LINE,
    SETUP,
    TICK,
    WRITER_CLASSES,
    GzipJsonLinesWriter,
    JsonLinesWriter,
    SinkError,
    SinkProcess,
    TickEncoder,
    TraceFormatWriter,
    encode_json,
    encode_value,
)
from pirate_bt.trace.structure import TreeStructure, jsonable, recordable, tree_structure

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.port import LinkHealth
    from pirate_bt.robot.state import RobotState

__all__ = [
    "WRITERS",
    "GzipJsonLinesWriter",
    "JsonLinesWriter",
    "SinkError",
    "TraceFormatWriter",
    "TraceRecorder",
    "WriterFactory",
    "open_writer",
    "register_writer",
    "suffix_of",
]

logger = logging.getLogger(__name__)

_PLAIN_TYPES = frozenset({str, int, bool, type(None)})
"""Blackboard value types that :func:`jsonable` returns unchanged."""
_IMMUTABLE_TYPES = _PLAIN_TYPES | {float}
"""Blackboard value types that cannot change without a new write."""
_command_fields = operator.attrgetter(*CommandRecord.__dataclass_fields__)
_Blackboard = py_trees.blackboard.Blackboard
_COMMANDS_MAX = 4096
"""Most distinct command records whose JSON text a recorder keeps."""

TreeLike = py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour


def _plain(value: Any) -> Any:
    """``value`` with only what ``marshal`` carries (a float subclass becomes a float...)."""
    if type(value) in _IMMUTABLE_TYPES:
        return value
    if isinstance(value, tuple):
        return tuple(map(_plain, value))
    if isinstance(value, list):
        return list(map(_plain, value))
    if isinstance(value, Mapping):
        return {_plain(k): _plain(v) for k, v in value.items()}
    if isinstance(value, float):
        return float(value)
    return encode_value(value)


def _software() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    from pirate_bt._version import __version__

    out = {"pirate_bt": __version__, "python": platform.python_version()}
    try:
        out["py_trees"] = version("py_trees")
    except PackageNotFoundError:  # pragma: no cover - py_trees is a dependency
        out["py_trees"] = "unknown"
    return out


def _outcome_of(status: py_trees.common.Status) -> str:
    return {
        py_trees.common.Status.SUCCESS: "success",
        py_trees.common.Status.FAILURE: "failure",
        py_trees.common.Status.RUNNING: "running",
    }.get(status, "interrupted")


class TraceRecorder:
    """Writes the trace of one run of one tree.

    The header is written at construction; call :meth:`record_tick` after every
    tick (or attach :meth:`post_tick_handler`), then :meth:`close`. Used as a
    context manager it closes with outcome ``error`` if the block raises.

    Each tick is *captured* in the caller's thread (what changed, as plain values)
    and *encoded and written* by a writer process (``background``, the default
    for the built-in formats) or in-process; see :mod:`pirate_bt.trace.sink`.
    Either way the file holds the same bytes, and every tick handed over before a
    crash (even SIGKILL) is written. :meth:`close` returns once everything is on
    disk.

    Args:
        destination: A path (the format is chosen by suffix) or an open
            :class:`TraceFormatWriter` (always written in-process).
        tree: The tree (a ``BehaviourTree`` or its root behaviour). Its shape
            must not change during the run.
        robot: The robot description, for its name and digest.
        robot_digest: The digest, when no description is at hand.
        scenario: Name or path of the scenario (pipe network), if any.
        seed: Random seed of the run, if any.
        clock: The run's clock; tick times are read from it.
        tick_period_s: The runner's tick period, for the header.
        full_state: Record every state value every tick, not only changes.
        readings: Also record every raw channel (``readings.<channel>``).
        every_tick: Write a record for every tick, even one where nothing changed.
        blackboard: Record blackboard writes.
        sync: fsync every record (see :class:`TraceFormatWriter`).
        meta: Free-form JSON values for the header.
        background: Encode and write in a writer process: ``None`` (default) when
            the format allows it, falling back to in-process if the process cannot
            start; ``True`` to insist; ``False`` for in-process.
        track_nodes: Read only the nodes that moved in a tick instead of every
            node: ``None`` (default) and ``True`` when ``tree`` is a
            ``BehaviourTree`` (the recorder adds a
            :class:`~pirate_bt.trace.nodes.TickedNodes` visitor to its ``visitors``,
            taken off by :meth:`close`), ``False`` to read every
            node every tick. What is read: the nodes ticked, and under each of them
            the children that were live (not INVALID) and are not any more -- the
            nodes a parent stopped -- down to where nothing changed; and the root,
            so that a stop from outside the tick (an interrupt, the runner's safe
            stop) is seen. A status or feedback message written into a node from
            outside its own tick and stop (by another node, say) shows when that
            node next moves. After 20 ticks in a row in which most nodes ticked (a
            big parallel), the recorder reads every node instead, which is cheaper.

    Raises:
        InputError: unknown file suffix.
        OSError: the file cannot be created.
        SinkError: ``background=True`` and the writer process cannot start.
    """

    def __init__(
        self,
        destination: str | Path | TraceFormatWriter,
        tree: TreeLike,
        *,
        robot: RobotDescription | None = None,
        robot_digest: str | None = None,
        scenario: str | None = None,
        seed: int | None = None,
        clock: Clock | None = None,
        tick_period_s: float | None = None,
        full_state: bool = False,
        readings: bool = False,
        every_tick: bool = False,
        blackboard: bool = True,
        sync: bool = False,
        meta: Mapping[str, Any] | None = None,
        background: bool | None = None,
        track_nodes: bool | None = None,
    ) -> None:
        self._out: TraceFormatWriter | None = None
        self._sink: SinkProcess | None = None
        self._encoder: TickEncoder | None = None
        check_tree(tree)  # before a file or a writer process exists
        check_options(locals())
        self.structure: TreeStructure = tree_structure(tree)
        if isinstance(destination, TraceFormatWriter):
            if background:
                raise ValueError("an open format writer is written in-process (background=False)")
            self._out = destination
        else:
            check_destination(destination)
            writer = WRITERS[suffix_of(destination, WRITERS)]
            name = getattr(writer, "__name__", type(writer).__name__)
            try:
                if background is not False and WRITER_CLASSES.get(name) is writer:
                    try:
                        self._sink = SinkProcess(destination, name, sync=sync)
                    except SinkError as exc:
                        if background:
                            raise
                        logger.warning("%s; writing the trace in-process", exc)
                elif background:
                    raise ValueError(f"{name} has no writer process; use background=False")
                if self._sink is None:
                    self._out = writer(destination, sync=sync)
            except OSError as exc:
                raise unwritable(destination, exc) from None
        self.path = self._out.path if self._out is not None else Path(cast(str | Path, destination))
        self.background = self._sink is not None
        """Whether a writer process encodes and writes this trace."""
        self.clock: Clock = clock or WallClock()
        self.full_state = full_state
        self.readings = readings
        self.every_tick = every_tick
        self.blackboard = blackboard
        self._reader = NodeReader(tree, track_nodes)
        self._bb: dict[str, Any] = {}
        self._bb_raw: dict[str, Any] = {}
        self._bb_immutable = True
        self._layout: tuple[str | None, ...] | None = None
        self._state_raw: tuple[Any, ...] | None = None
        self._last_state: RobotState | None = None
        self._last_link: LinkHealth | None = None
        self._link_raw: tuple[Any, ...] | None = None
        self._sim_raw: dict[Any, Any] | None = None
        self._commands: dict[tuple[Any, ...], str] = {}
        self._tick = 0
        self._t_s = 0.0
        self._closed = False
        self._start_s = self.clock.now()
        self._root = self._reader.root
        setup = (SETUP, self._reader.ids, every_tick, full_state, readings, list(LINK_FIELDS))
        self._send_tick: Callable[[tuple[Any, ...]], None] | None = None
        if self._sink is not None:
            self._sink.send(setup)
            self._send_tick = self._sink.send_tick
        else:
            self._encoder = TickEncoder(
                self._reader.ids,
                every_tick=every_tick,
                full_state=full_state,
                readings=readings,
                link_fields=LINK_FIELDS,
            )
        header: dict[str, Any] = {
            "type": "header",
            "format": FORMAT_NAME,
            "version": TRACE_VERSION,
            "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
            "tree": self.structure.to_json(),
            "robot": {
                "name": robot.name if robot is not None else None,
                "digest": robot.digest() if robot is not None else robot_digest,
            },
            "scenario": scenario,
            "seed": seed,
            "software": _software(),
            "clock": "simulated" if self.clock.is_simulated else "wall",
            "tick_period_s": tick_period_s,
            "full_state": full_state,
            "readings": readings,
            "meta": jsonable(dict(meta or {})),
        }
        self._write_line(encode_json(header) + "\n")

    @property
    def ticks(self) -> int:
        """Ticks recorded so far."""
        return self._tick

    @property
    def node_ids(self) -> list[str]:
        """The traced nodes' path ids, depth first (the node order of the messages)."""
        return list(self._reader.ids)

    def hand_over(self, sink: SinkProcess) -> None:
        """From now on hand each tick's captured message to ``sink``, not encode it here.

        For an output whose own process encodes (the Foxglove live view): the recorder
        was made in-process (``background=False``) and what it wrote so far stays where
        it went; ``sink`` (a :class:`SinkProcess` or a stand-in with ``send`` and
        ``close``) gets every message from here on, the end record included.

        Raises:
            ValueError: the recorder already hands its messages to a writer process.
        """
        if self._sink is not None:
            raise ValueError("the recorder already hands its ticks to a writer process")
        self._sink, self._encoder, self._out = sink, None, None
        # SinkProcess.send_tick is its send() for ticks: a sink with a send() of its own
        # (a stand-in, or a subclass such as the Foxglove live view's) gets every message
        # through that.
        own_send = type(sink).send is not SinkProcess.send
        self._send_tick = sink.send if own_send else sink.send_tick
        self.background = True

    def record_tick(self, extras: TickExtras | None = None, time_s: float | None = None) -> None:
        """Record the tick that has just run.

        Args:
            extras: State, commands, link health, counters and events of the tick.
            time_s: The tick's clock time; defaults to ``clock.now()``.

        Raises:
            RuntimeError: the trace is closed.
            SinkError: the writer process has failed (its reason is in the message).
        """
        if self._closed:
            raise RuntimeError(f"trace {self.path} is closed")
        # Runs after every tick, so it is written for speed: one pass, C-level
        # comparisons, nothing built for what did not move (see docs/performance.md).
        tick = self._tick = self._tick + 1
        now = self.clock.now() if time_s is None else time_s
        t_s = self._t_s = now - self._start_s  # rounded by the encoder
        # Capture only: what moved since the last tick, as plain values (the writer
        # compares with what it recorded, rounds and encodes; see sink.TickEncoder).
        # The tree is read where it moved (see track_nodes and NodeReader), or whole
        # when the recorder cannot follow the ticks.
        status, feedback = self._reader.changes(tick == 1)
        bb = None
        if self.blackboard and not (self._bb_immutable and _Blackboard.storage == self._bb_raw):
            bb = self._blackboard_changes()
        keys = raw = commands = link = sim = events = None
        if extras is not None:
            state = extras.state
            if state is not None and (state is not self._last_state or self.full_state):
                self._last_state = state
                # The row its builder made (RobotState.row), or the same made here.
                row = state.row
                if row is None or self.readings:
                    row = state_layout(state, self.readings)
                layout, values = row
                if layout is not self._layout:
                    if layout != self._layout:
                        keys = layout
                    self._layout = layout
                if values != self._state_raw or keys is not None or self.full_state:
                    self._state_raw = raw = values
            records = extras.commands
            if records:
                # One record is the common tick's (a behaviour re-sending its setpoint):
                # its cached text looked up here; otherwise, or on a miss, the general way.
                text = None
                if len(records) == 1:
                    try:
                        text = self._commands.get(_command_fields(records[0]))
                    except TypeError:  # a hand-made record holding something unhashable
                        text = None
                commands = [text] if text is not None else self._command_texts(records)
            health = extras.link
            if health is not None and health is not self._last_link:
                # A fresh object every tick whose rtt may be nan (nan != nan makes dataclass
                # == useless): its fields as one tuple compare cheaply instead.
                self._last_link = health
                values = link_health_raw(health)
                if values != self._link_raw:
                    self._link_raw = link = values
            if extras.sim is not None and extras.sim != self._sim_raw:
                self._sim_raw = sim = dict(extras.sim)  # a copy: the caller may mutate its own
            if extras.events:
                events = ',"events":' + encode_json([e.to_json() for e in extras.events])
        message = (TICK, tick, t_s, status, feedback, bb, keys, raw, commands, link, sim, events)
        send = self._send_tick
        if send is not None:
            try:
                send(message)
            except ValueError:  # something marshal cannot carry, such as a numpy float
                send(_plain(message))
        else:
            assert self._encoder is not None and self._out is not None
            line = self._encoder.encode(message)
            if line is not None:
                self._out.write_line(line)

    def _write_line(self, line: str) -> None:
        if self._sink is not None:
            self._sink.send((LINE, line))
        else:
            assert self._out is not None
            self._out.write_line(line)

    def _command_texts(self, records: Sequence[CommandRecord]) -> list[str]:
        """The records' JSON texts: looked up by their fields (one tuple, hashed in C),
        encoded on a miss. A plain loop: a tick has one or a few records."""
        texts: list[str] = []
        cached = self._commands.get
        try:
            for record in records:
                text = cached(_command_fields(record))
                if text is None:
                    return list(map(self._command_json, records))
                texts.append(text)
        except TypeError:  # a hand-made record holding something unhashable
            return list(map(self._command_json, records))
        return texts

    def _command_json(self, command: CommandRecord) -> str:
        # A behaviour re-sends the same setpoint tick after tick, each time as a new but
        # equal record: its text is looked up by its fields (read, hashed and compared
        # as one tuple, in C), not re-encoded.
        cache = self._commands
        key = _command_fields(command)
        try:
            text = cache.get(key)
        except TypeError:  # a hand-made record holding something unhashable
            return encode_json(command.to_json())
        if text is None:
            if len(cache) >= _COMMANDS_MAX:
                cache.clear()
            text = cache[key] = encode_json(command.to_json())
        return text

    def _blackboard_changes(self) -> str | None:
        storage = py_trees.blackboard.Blackboard.storage
        if self._bb_immutable and storage == self._bb_raw:
            return None  # nothing written since the last tick, and no value could change in place
        changed: dict[str, Any] = {}
        for key, value in storage.items():
            encoded = value if type(value) in _PLAIN_TYPES else recordable(value)
            if key not in self._bb or self._bb[key] != encoded:
                self._bb[key] = encoded
                changed[key] = encoded
        unset = [key for key in self._bb if key not in storage]
        for key in unset:
            del self._bb[key]
        self._bb_raw = dict(storage)
        self._bb_immutable = all(map(_IMMUTABLE_TYPES.__contains__, map(type, storage.values())))
        text = ""
        if changed:
            text += ',"bb":' + encode_json(changed)
        if unset:
            text += ',"bb_unset":' + encode_json(unset)
        return text or None

    def post_tick_handler(
        self, extras: Callable[[], TickExtras | None] | None = None
    ) -> Callable[[py_trees.trees.BehaviourTree], None]:
        """A handler for ``BehaviourTree.add_post_tick_handler``.

        Args:
            extras: Called once per tick for what else happened in it.
        """

        def handler(_tree: py_trees.trees.BehaviourTree) -> None:
            self.record_tick(extras() if extras is not None else None)

        return handler

    def close(
        self,
        outcome: str | None = None,
        reason: str | None = None,
        error_node: str | None = None,
        exception: BaseException | str | None = None,
        coverage: Mapping[str, Any] | None = None,
        commands: Sequence[CommandRecord] = (),
    ) -> None:
        """Write the end record and close the file (idempotent).

        Args:
            outcome: success/failure/error/interrupted/running; by default the
                root's status (``error`` if ``exception`` is given).
            reason: Why the run ended, in words.
            error_node: Path id of the node that raised, for a crash.
            exception: The exception that ended the run, for a crash.
            coverage: ``{"counts": {node id: [ticks, transitions, successes,
                failures, halts, skips]}, "conditions": [node ids]}`` (see
                :mod:`pirate_bt.trace.coverage`).
            commands: Verdicts given after the last tick: the stops of the run's end
                (the running nodes stopped, the safe state), which no tick records.
        """
        if self._closed:
            return
        self._closed = True
        self._reader.close()
        if outcome is None:
            outcome = "error" if exception is not None else _outcome_of(self._root.status)
        if outcome not in OUTCOMES:
            raise ValueError(f"outcome must be one of {OUTCOMES}, not {outcome!r}")
        record: dict[str, Any] = {
            "type": "end",
            "n": self._tick,
            "t_s": round(self._t_s, 6),
            "outcome": outcome,
        }
        if reason:
            record["reason"] = reason
        if exception is not None or error_node is not None:
            text = (
                f"{type(exception).__name__}: {exception}"
                if isinstance(exception, BaseException)
                else exception
            )
            record["error"] = {"node": error_node, "exception": text}
        if coverage:
            record["coverage"] = dict(coverage)
        if commands:
            record["commands"] = [command.to_json() for command in commands]
        try:
            if self._sink is not None:
                self._sink.send((END, encode_json(record) + "\n"))
            else:
                self._write_line(encode_json(record) + "\n")
        finally:
            if self._sink is not None:
                self._sink.close()  # waits until the writer process has written everything
            if self._out is not None:
                self._out.close()
        logger.debug("trace %s closed after %d ticks (%s)", self.path, self._tick, outcome)

    def __enter__(self) -> TraceRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc is None:
            self.close()
        elif isinstance(exc, KeyboardInterrupt):
            self.close("interrupted", reason="interrupted")
        else:
            self.close("error", exception=exc)
