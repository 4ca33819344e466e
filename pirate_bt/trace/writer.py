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
  class and one row.

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

import gzip
import json
import logging
import operator
import os
import platform
import zlib
from collections.abc import Callable, Mapping
from datetime import UTC, datetime
from itertools import compress, repeat
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Any, ClassVar, cast

import py_trees

from pirate_bt.clock import Clock, WallClock
from pirate_bt.errors import InputError
from pirate_bt.trace.records import (
    FORMAT_NAME,
    LINK_FIELDS,
    OUTCOMES,
    STATUS_CODE,
    TRACE_VERSION,
    FieldChanges,
    StateChanges,
    TickExtras,
    encode_value,
    flatten_state,
    link_health_raw,
)
from pirate_bt.trace.structure import TreeStructure, iter_with_ids, jsonable, tree_structure

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.robot.port import LinkHealth
    from pirate_bt.robot.state import RobotState

__all__ = [
    "WRITERS",
    "GzipJsonLinesWriter",
    "JsonLinesWriter",
    "TraceFormatWriter",
    "TraceRecorder",
    "open_writer",
    "suffix_of",
]

logger = logging.getLogger(__name__)

_MISSING: Any = object()

# One encoder built once: json.dumps with keyword arguments builds a new JSONEncoder
# on every call. Records hold fresh plain data (no cycles), so the check is skipped.
_encode_json = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, check_circular=False
).encode
_PLAIN_TYPES = frozenset({str, int, bool, type(None)})
"""Blackboard value types that :func:`jsonable` returns unchanged."""
_get_status = operator.attrgetter("status")
_get_feedback = operator.attrgetter("feedback_message")
_is_not = operator.is_not
_ne = operator.ne

TreeLike = py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour


class TraceFormatWriter:
    """Writes trace records to a file in one format; subclasses implement ``_open``.

    Args:
        path: Where to write (created or truncated).
        sync: Also ``fsync`` after every record, for power loss (slower).
    """

    suffixes: ClassVar[tuple[str, ...]] = ()

    def __init__(self, path: str | Path, sync: bool = False) -> None:
        self.path = Path(path)
        self.sync = sync
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self._open()

    def _open(self) -> IO[bytes]:
        raise NotImplementedError

    def _flush(self) -> None:
        self._file.flush()

    def write(self, record: Mapping[str, Any]) -> None:
        """Write one record as one line and flush it to the operating system."""
        self._file.write((_encode_json(record) + "\n").encode("utf-8"))
        self._flush()
        if self.sync:
            os.fsync(self._file.fileno())

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if not self._file.closed:
            self._file.close()


class JsonLinesWriter(TraceFormatWriter):
    """Plain JSON Lines (``.jsonl``); the record layout is in the module docstring."""

    suffixes = (".jsonl", ".ndjson")

    def _open(self) -> IO[bytes]:
        # Unbuffered: each record goes to the kernel in write(), nothing waits in Python.
        return open(self.path, "wb", buffering=0)

    def write(self, record: Mapping[str, Any]) -> None:
        """Write one record as one line with one ``os.write`` (the kernel has it on return)."""
        data = (_encode_json(record) + "\n").encode("utf-8")
        fd = self._file.fileno()
        written = os.write(fd, data)
        while written < len(data):  # a regular file takes it all; a pipe or a full disk may not
            written += os.write(fd, data[written:])
        if self.sync:
            os.fsync(fd)


class GzipJsonLinesWriter(TraceFormatWriter):
    """Gzip-compressed JSON Lines (``.jsonl.gz``), sync-flushed per record.

    A sync flush ends each record on a byte boundary of the deflate stream, so a
    killed run still decompresses up to its last complete tick.
    """

    suffixes = (".jsonl.gz",)

    def _open(self) -> IO[bytes]:
        self._raw = open(self.path, "wb")  # noqa: SIM115 - closed by close()
        return cast(IO[bytes], gzip.GzipFile(fileobj=self._raw, mode="wb", compresslevel=6))

    def _flush(self) -> None:
        assert isinstance(self._file, gzip.GzipFile)
        self._file.flush(zlib.Z_SYNC_FLUSH)
        self._raw.flush()

    def close(self) -> None:
        super().close()
        if not self._raw.closed:
            self._raw.close()


#: File suffix -> format writer class; the longest matching suffix wins.
WRITERS: dict[str, type[TraceFormatWriter]] = {
    suffix: cls for cls in (JsonLinesWriter, GzipJsonLinesWriter) for suffix in cls.suffixes
}


def suffix_of(path: str | Path, table: Mapping[str, object]) -> str:
    """The longest suffix in ``table`` that ``path`` ends with.

    Raises:
        InputError: no suffix in the table matches.
    """
    name = Path(path).name.lower()
    for suffix in sorted(table, key=len, reverse=True):
        if name.endswith(suffix):
            return suffix
    known = ", ".join(sorted(table))
    raise InputError(f"{path}: unknown trace format; name it with one of: {known}")


def open_writer(path: str | Path, sync: bool = False) -> TraceFormatWriter:
    """A format writer for ``path``, chosen by its suffix (see :data:`WRITERS`).

    Raises:
        InputError: unknown suffix.
    """
    return WRITERS[suffix_of(path, WRITERS)](path, sync=sync)


def _software() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    from pirate_bt import __version__

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

    Args:
        destination: A path (the format is chosen by suffix) or an open
            :class:`TraceFormatWriter`.
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
    ) -> None:
        self._out = (
            destination
            if isinstance(destination, TraceFormatWriter)
            else open_writer(destination, sync=sync)
        )
        self.path = self._out.path
        self.clock: Clock = clock or WallClock()
        self.structure: TreeStructure = tree_structure(tree)
        self.full_state = full_state
        self.readings = readings
        self.every_tick = every_tick
        self.blackboard = blackboard
        self._nodes = [node for _, node in iter_with_ids(tree)]
        self._ids = [node_id for node_id, _ in iter_with_ids(tree)]
        self._status = [py_trees.common.Status.INVALID] * len(self._nodes)
        self._feedback = [""] * len(self._nodes)
        self._bb: dict[str, Any] = {}
        self._state_changes = StateChanges(readings=readings)
        self._link = FieldChanges(LINK_FIELDS)
        self._sim: dict[str, Any] = {}
        self._sim_raw: dict[str, Any] = {}
        self._last_link: LinkHealth | None = None
        self._last_state: RobotState | None = None
        self._tick = 0
        self._t_s = 0.0
        self._closed = False
        self._start_s = self.clock.now()
        self._root = self._nodes[0]
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
        self._out.write(header)

    @property
    def ticks(self) -> int:
        """Ticks recorded so far."""
        return self._tick

    def record_tick(self, extras: TickExtras | None = None, time_s: float | None = None) -> None:
        """Record the tick that has just run.

        Args:
            extras: State, commands, link health, counters and events of the tick.
            time_s: The tick's clock time; defaults to ``clock.now()``.
        """
        if self._closed:
            raise RuntimeError(f"trace {self.path} is closed")
        self._tick += 1
        now = self.clock.now() if time_s is None else time_s
        self._t_s = round(now - self._start_s, 6)
        record: dict[str, Any] = {"type": "tick", "n": self._tick, "t_s": self._t_s}
        # Every node is read every tick (a node that was not ticked can still change, when
        # its parent stops it), but through map + attrgetter and one C-level list
        # comparison. When something differs, map(is_not/ne) marks the changed nodes and
        # compress picks their ids and values, all in C: py_trees' Timeout rewrites its
        # feedback every tick, so this path runs every tick too, not only at step ends.
        statuses = list(map(_get_status, self._nodes))
        if statuses != self._status:
            flags = list(map(_is_not, statuses, self._status))
            record["status"] = dict(
                zip(
                    compress(self._ids, flags),
                    map(STATUS_CODE.__getitem__, compress(statuses, flags)),
                    strict=True,
                )
            )
            self._status = statuses
        messages = list(map(_get_feedback, self._nodes))
        if messages != self._feedback:
            flags = list(map(_ne, messages, self._feedback))
            record["feedback"] = dict(
                zip(compress(self._ids, flags), compress(messages, flags), strict=True)
            )
            self._feedback = messages
        if self.blackboard:
            self._blackboard_changes(record)
        if extras is not None:
            self._extras(extras, record)
        if self.every_tick or len(record) > 3:
            self._out.write(record)

    def _blackboard_changes(self, record: dict[str, Any]) -> None:
        storage = py_trees.blackboard.Blackboard.storage
        if not storage and not self._bb:
            return
        changed: dict[str, Any] = {}
        for key, value in storage.items():
            encoded = value if type(value) in _PLAIN_TYPES else jsonable(value)
            if key not in self._bb or self._bb[key] != encoded:
                self._bb[key] = encoded
                changed[key] = encoded
        unset = [key for key in self._bb if key not in storage]
        for key in unset:
            del self._bb[key]
        if changed:
            record["bb"] = changed
        if unset:
            record["bb_unset"] = unset

    def _sim_changes(self, sim: Mapping[str, Any]) -> dict[str, Any]:
        # Names may come and go (a localiser adds its own), so this is a dict diff, not a
        # FieldChanges tuple. An unchanged mapping costs one C-level dict comparison;
        # otherwise map(ne) over the values and the last raw values (looked up in C)
        # marks what moved, and only those are rounded and compared with the record.
        raw = self._sim_raw
        if sim == raw:
            return {}
        changed: dict[str, Any] = {}
        values = self._sim
        moved = map(_ne, sim.values(), map(raw.get, sim, repeat(_MISSING)))
        for key in compress(list(sim), moved):
            value = raw[key] = sim[key]
            name = key if type(key) is str else str(key)
            encoded = encode_value(value)
            if values.get(name, _MISSING) != encoded:
                values[name] = encoded
                changed[name] = encoded
        return changed

    def _extras(self, extras: TickExtras, record: dict[str, Any]) -> None:
        state = extras.state
        if state is not None and (self.full_state or state is not self._last_state):
            self._last_state = state
            if self.full_state:
                flat = flatten_state(state, readings=self.readings)
                record["state"] = flat
                record["full"] = True
            else:
                changed = self._state_changes.changes(state)
                if changed:
                    record["state"] = changed
        if extras.commands:
            record["commands"] = [c.to_json() for c in extras.commands]
        link = extras.link
        if link is not None and link is not self._last_link:
            # Link health is a fresh object every tick whose rtt may be nan (nan != nan makes
            # dataclass == useless); its fields as one tuple compare cheaply instead.
            self._last_link = link
            changed = self._link.changes(link_health_raw(link))
            if changed:
                record["link"] = changed
        if extras.sim is not None:
            changed = self._sim_changes(extras.sim)
            if changed:
                record["sim"] = changed
        if extras.events:
            record["events"] = [e.to_json() for e in extras.events]

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
    ) -> None:
        """Write the end record and close the file (idempotent).

        Args:
            outcome: success/failure/error/interrupted/running; by default the
                root's status (``error`` if ``exception`` is given).
            reason: Why the run ended, in words.
            error_node: Path id of the node that raised, for a crash.
            exception: The exception that ended the run, for a crash.
        """
        if self._closed:
            return
        self._closed = True
        if outcome is None:
            outcome = "error" if exception is not None else _outcome_of(self._root.status)
        if outcome not in OUTCOMES:
            raise ValueError(f"outcome must be one of {OUTCOMES}, not {outcome!r}")
        record: dict[str, Any] = {
            "type": "end",
            "n": self._tick,
            "t_s": self._t_s,
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
        try:
            self._out.write(record)
        finally:
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
