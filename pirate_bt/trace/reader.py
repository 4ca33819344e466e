"""Read a trace back and rebuild the tree and robot at any tick.

A trace file stores only what changed in each tick (see
:mod:`pirate_bt.trace.writer`). :func:`read_trace` loads the records into a
:class:`Trace`; :meth:`Trace.frame_at` and :meth:`Trace.frames` replay the
changes to give the *whole* picture at a tick: every node's status and
feedback message, the blackboard, the robot state, link health and simulator
counters, plus the commands and events of that tick.

Readers are picked by file suffix from :data:`READERS`, like the writers
(:mod:`pirate_bt.trace.format_readers`, whose names this module re-exports);
:func:`register_reader` adds one (formats above this package register
themselves, see :mod:`pirate_bt.trace.formats`).
A reader tolerates a cut-off last line (a run killed mid-write): the complete
ticks before it are returned and :attr:`Trace.truncated` is set. Any other bad
line is an :class:`~pirate_bt.errors.LocatedError` naming the file and line. A line
is read at most :data:`MAX_LINE_BYTES` long, so a device such as ``/dev/zero`` named
``x.jsonl`` is refused at its first line, not read for ever.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import py_trees

from pirate_bt.errors import (
    InputError,
    LocatedError,
    PirateError,
    SourceLocation,
    file_argument,
    shown,
)
from pirate_bt.robot.state import RobotState
from pirate_bt.trace import record_values as values
from pirate_bt.trace.coverage import Coverage, NodeCoverage, name_paths
from pirate_bt.trace.coverage_counts import coverage_problem
from pirate_bt.trace.format_readers import (
    MAX_HEADER_BYTES,
    MAX_LINE_BYTES,
    READERS,
    GzipJsonLinesReader,
    JsonLinesReader,
    ReaderFactory,
    TickRecord,
    TraceFormatReader,
    open_reader,
    register_reader,
    tick_record,
)
from pirate_bt.trace.header_check import tree_problem, unchecked
from pirate_bt.trace.query import TraceQueries
from pirate_bt.trace.records import (
    CODE_STATUS,
    FORMAT_NAME,
    end_problem,
    state_from_flat,
)
from pirate_bt.trace.structure import TreeStructure

__all__ = [
    "MAX_HEADER_BYTES",
    "MAX_LINE_BYTES",
    "READERS",
    "GzipJsonLinesReader",
    "JsonLinesReader",
    "ReaderFactory",
    "TickFrame",
    "TickRecord",
    "Trace",
    "TraceFormatReader",
    "no_header",
    "open_reader",
    "read_trace",
    "register_reader",
]


@dataclass(frozen=True)
class TickFrame:
    """Everything known at the end of one tick, rebuilt from the changes.

    Attributes:
        n: Tick number (0 is before the first tick).
        t_s: Seconds since the trace started, at the last recorded change.
        status: Status code (``S``/``F``/``R``/``I``) of every node by id.
        feedback: Feedback message of every node by id.
        blackboard: Every blackboard key's value.
        state: Flat robot state values (see :func:`~pirate_bt.trace.records.flatten_state`).
        link: Link health fields.
        sim: Simulator counters.
        commands: Commands of this very tick (empty if the tick wrote no record).
        events: Events of this very tick.
    """

    n: int
    t_s: float
    status: Mapping[str, str]
    feedback: Mapping[str, str]
    blackboard: Mapping[str, Any]
    state: Mapping[str, Any]
    link: Mapping[str, Any]
    sim: Mapping[str, Any]
    commands: tuple[Mapping[str, Any], ...] = ()
    events: tuple[Mapping[str, Any], ...] = ()

    def statuses(self) -> dict[str, py_trees.common.Status]:
        """Every node's status as a py_trees ``Status``."""
        return {node_id: CODE_STATUS[code] for node_id, code in self.status.items()}

    def robot_state(self) -> RobotState | None:
        """The robot state as a :class:`RobotState` (``None`` before the first state)."""
        if not self.state:
            return None
        return state_from_flat(self.state, self.t_s)


class Trace(TraceQueries):
    """A trace read back: header, tick records and end record.

    Besides replaying ticks (:meth:`frame_at`, :meth:`statuses_at`), it answers
    questions about nodes by name (see :mod:`pirate_bt.trace.query`):
    :meth:`nodes`, :meth:`node`, :meth:`statuses`, :meth:`status_at`,
    :meth:`first_tick`, :meth:`feedback`, :meth:`failures`, :attr:`outcome` and
    :attr:`why`.

    Attributes:
        path: The file it was read from.
        header: The header record.
        structure: The tree's structure from the header.
        ticks: The tick records, in order.
        end: The end record, or ``None`` if the run did not finish writing.
        truncated: The last line was cut off (a killed run).
    """

    def __init__(
        self,
        path: Path,
        header: Mapping[str, Any],
        ticks: list[TickRecord],
        end: Mapping[str, Any] | None,
        truncated: bool,
    ) -> None:
        self.path = path
        self.header = header
        self.structure = TreeStructure.from_json(header["tree"])
        self.ticks = ticks
        self.end = end
        self.truncated = truncated
        # frame_at's last replay: of which ticks, and how many of them
        self._replayed: tuple[list[TickRecord], _Replay, int, TickRecord | None] | None = None

    def __repr__(self) -> str:
        """A short summary (what ``print(trace)`` shows): the file, the tree, the
        outcome and why, the ticks and seconds it covers (it showed the object's
        address); the records are in :attr:`ticks`."""
        cut = ", truncated" if self.truncated else ""
        return (
            f"{type(self).__name__}({str(self.path)!r}, tree={self.structure.name!r},"
            f" outcome={self.outcome!r}, why={self.why!r}, last_tick={self.last_tick},"
            f" duration_s={self.duration_s:.2f}, records={len(self.ticks)}{cut})"
        )

    @property
    def last_tick(self) -> int:
        """The number of the last tick the run reached."""
        if self.end is not None:
            return int(self.end.get("n", 0))
        return self.ticks[-1].n if self.ticks else 0

    @property
    def duration_s(self) -> float:
        """Seconds from the header to the last tick."""
        if self.end is not None:
            return float(self.end.get("t_s", 0.0))
        return self.ticks[-1].t_s if self.ticks else 0.0

    @property
    def outcome(self) -> str:
        """The run's outcome, or ``incomplete`` when there is no end record.

        One of ``success``, ``failure``, ``error``, ``interrupted``, ``running``
        (the end record's words) or ``incomplete``; :attr:`why` says why.

        Example::

            >>> read_trace("run.jsonl").outcome
            'success'
        """
        return str(self.end["outcome"]) if self.end is not None else "incomplete"

    @property
    def coverage(self) -> Coverage | None:
        """What each node did in the run (:class:`~pirate_bt.trace.coverage.Coverage`),
        from the end record; ``None`` for a trace without one (cut off, or older).

        Example::

            >>> [n.path for n in read_trace("run.jsonl").coverage.never_ran()]
            ['straight/recover']
        """
        # read_trace checked it (coverage_problem): an error naming the end record's line
        recorded = self.end.get("coverage") if self.end is not None else None
        if not isinstance(recorded, Mapping) or not isinstance(recorded.get("counts"), Mapping):
            return None
        counts = recorded["counts"]
        conditions = set(recorded.get("conditions") or ())
        nodes = list(self.structure)
        index = {n.id: i for i, n in enumerate(nodes)}
        parents = [index[n.parent] if n.parent is not None else -1 for n in nodes]
        paths = name_paths([n.name for n in nodes], parents)
        return Coverage(
            self.structure.name,
            tuple(
                NodeCoverage(
                    path,
                    n.id,
                    n.type,
                    "condition" if n.id in conditions else n.kind,
                    *map(int, counts.get(n.id, [0] * 6)),
                )
                for path, n in zip(paths, nodes, strict=True)
            ),
        )

    def frames(self) -> Iterator[TickFrame]:
        """The whole picture after every recorded tick, in order (tick 0 first)."""
        replay = _Replay(self.structure)
        yield replay.frame(0, 0.0)
        for tick in self.ticks:
            replay.apply(tick)
            yield replay.frame(tick.n, tick.t_s, tick.commands, tick.events)

    def frame_at(self, n: int) -> TickFrame:
        """The whole picture at the end of tick ``n`` (0 is before the first tick).

        A tick that wrote no record changed nothing, so it shows the frame of the
        last recorded tick before it, renumbered.

        Raises:
            InputError: ``n`` is not a whole number, negative or beyond the last tick.
        """
        n = self.tick_number(n, "n")
        # the changes replayed up to tick n, from where the last call stopped when that
        # was not after it: a loop over the ticks replayed the run from its start at
        # each one (with a picture of every tick on the way), quadratic in its length
        ticks, replay, done, last = self._replayed or (
            self.ticks,
            _Replay(self.structure),
            0,
            None,
        )
        if (
            ticks is not self.ticks
            or done > len(ticks)
            or (done and (ticks[done - 1] is not last or last.n > n))
        ):
            # earlier, or other ticks given (a list put in its place, or its last
            # replayed tick replaced in it)
            replay, done = _Replay(self.structure), 0
        while done < len(self.ticks) and self.ticks[done].n <= n:
            replay.apply(self.ticks[done])
            done += 1
        self._replayed = (self.ticks, replay, done, self.ticks[done - 1] if done else None)
        found = self.ticks[done - 1] if done else None
        if found is None:
            return replay.frame(n, 0.0)
        if found.n != n:
            return replay.frame(n, found.t_s)
        return replay.frame(n, found.t_s, found.commands, found.events)

    def statuses_at(self, n: int) -> dict[str, py_trees.common.Status]:
        """Every node's status at the end of tick ``n``."""
        return self.frame_at(n).statuses()

    def robot_state_at(self, n: int) -> RobotState | None:
        """The robot state at the end of tick ``n`` (``None`` if none was recorded yet)."""
        return self.frame_at(n).robot_state()


class _Replay:
    """The values of a trace as its tick records change them, from before tick 1."""

    def __init__(self, structure: TreeStructure) -> None:
        self.status = {n.id: "I" for n in structure}
        self.feedback = {n.id: "" for n in structure}
        self.bb: dict[str, Any] = {}
        self.state: dict[str, Any] = {}
        self.link: dict[str, Any] = {}
        self.sim: dict[str, Any] = {}

    def apply(self, tick: TickRecord) -> None:
        self.status.update(tick.status)
        self.feedback.update(tick.feedback)
        self.bb.update(tick.bb)
        for key in tick.bb_unset:
            self.bb.pop(key, None)
        if tick.full:
            self.state = dict(tick.state)
        else:
            self.state.update(tick.state)
        self.link.update(tick.link)
        self.sim.update(tick.sim)

    def frame(
        self,
        n: int,
        t_s: float,
        commands: tuple[Mapping[str, Any], ...] = (),
        events: tuple[Mapping[str, Any], ...] = (),
    ) -> TickFrame:
        """The picture now, as tick ``n`` at ``t_s`` (copies: the replay goes on)."""
        return TickFrame(
            n,
            t_s,
            dict(self.status),
            dict(self.feedback),
            dict(self.bb),
            dict(self.state),
            dict(self.link),
            dict(self.sim),
            commands,
            events,
        )


def no_header(where: str | Path, truncated: bool) -> InputError:
    """The error for a trace with no header record: its only line cut off (``truncated``:
    a reader's), or nothing in it. The exports say it as :func:`read_trace` does (they
    called a file whose header was cut off an *empty trace*)."""
    if truncated:
        return LocatedError(
            "the header record is cut off (the run was cut off before it was written,"
            " or this is not a trace)",
            SourceLocation(str(where), 1),
        )
    return InputError(f"{where}: empty trace (no header)")


def read_trace(path: str | Path) -> Trace:
    """Read a trace file; its format is chosen by suffix (see :data:`READERS`).

    Returns:
        Trace: The trace, with its queries (see :class:`Trace`).

    Raises:
        InputError: ``path`` is no file name (:func:`~pirate_bt.errors.file_argument`:
            a number, bytes, empty, too long), an unknown suffix or an unreadable
            file (a directory, a line longer than :data:`MAX_LINE_BYTES`).
        ConfigurationError: the suffix needs an optional part that is not installed.
        LocatedError: a record that is not valid, with file and line.

    Example::

        pirate_bt.simulate_tree("bend", network="bend-right", params={"roll": "90 deg"},
                                faults="motor_stall:bend_3_drive@5s+20s", trace="bend.jsonl")
        trace = pirate_bt.read_trace("bend.jsonl")
        first = trace.failures()[0]              # where the run first went wrong
        print(first.tick, first.path, first.feedback)
        print(trace.first_tick("front into turn", "RUNNING"))
    """
    where = file_argument(path, "path")
    reader = open_reader(where)
    reader.readable = True  # exports keep text as written; a Trace is shown
    try:
        header, ticks, end, end_line = _records(reader, where)
    except PirateError:
        raise
    except Exception as exc:  # a format reader (MCAP, a plugin) stumbling on a bad file
        raise InputError(
            f"{where}: cannot read this trace: {type(exc).__name__}: {shown(str(exc), 200)}"
        ) from exc
    if header is None:
        raise no_header(where, reader.truncated)
    try:
        trace = Trace(where, header, ticks, end, reader.truncated)
    except (KeyError, TypeError, ValueError) as exc:
        raise LocatedError(f"bad tree in header: {exc}", SourceLocation(str(where), 1)) from None
    if end is not None and "coverage" in end:
        problem = coverage_problem(end["coverage"], (n.id for n in trace.structure))
        if problem is not None:
            raise LocatedError(f"bad end record: {problem}", SourceLocation(str(where), end_line))
    return trace


def _records(
    reader: TraceFormatReader, where: Path
) -> tuple[dict[str, Any] | None, list[TickRecord], dict[str, Any] | None, int]:
    """The header, the ticks, the end record and its line of a trace, checked in order."""
    header: dict[str, Any] | None = None
    ticks: list[TickRecord] = []
    end: dict[str, Any] | None = None
    end_line = 0
    for line, record in unchecked(reader):  # checked here, once
        kind = record["type"]
        loc = SourceLocation(str(where), line)
        if header is None:
            if kind != "header" or record.get("format") != FORMAT_NAME:
                steps = " (a navigation's record: its steps' traces are step-NNN.jsonl)"
                raise LocatedError(
                    f"not a {FORMAT_NAME} file: the first record is no header"
                    + (steps if kind == "navigation" else ""),
                    loc,
                )
            if (problem := values.version_problem(record.get("version"))) is not None:
                raise LocatedError(problem, loc)
            if not isinstance(record.get("tree"), dict) or not record["tree"].get("nodes"):
                raise LocatedError("the header has no tree", loc)
            problem = tree_problem(record["tree"])
            if problem is not None:
                raise LocatedError(f"bad tree in header: {problem}", loc)
            header = record
        elif kind == "tick":
            tick = tick_record(record, line, where)
            if problem := values.order_problem(tick.n, ticks[-1].n if ticks else 0, end_line):
                raise LocatedError(problem, loc)
            ticks.append(tick)
        elif kind == "end":
            last = ticks[-1].n if ticks else 0
            problem = end_problem(record) or values.end_values_problem(record, last, end_line)
            if problem:
                raise LocatedError(problem, loc)
            end, end_line = record, line
        else:
            raise LocatedError(values.stray_record(kind), loc)
    return header, ticks, end, end_line
