"""Attach a trace and a live view to a :class:`pirate_bt.runner.Runner`.

The runner calls post-tick hooks with a ``TickInfo`` and finish hooks with a
``RunResult``. :func:`attach_trace` opens a :class:`TraceRecorder` on the
runner's tree and clock, records each tick from a post-tick hook (asking an
optional ``extras`` callable for the state, verdicts, link health and
simulator counters of the tick), and writes the end record from a finish hook,
mapping the runner's stop reason onto the trace's outcome. The runner is
duck-typed (``tree``, ``clock``, ``period_s``, ``add_post_tick``,
``add_finish``), so this module does not import it.

What ``pirate-bt run`` does::

    runner = Runner(loaded, clock=clock, period_s=0.01)
    attach_trace(runner, "run.jsonl", extras=lambda info: TickExtras(state=port.state()))
    attach_live_view(runner, quiet=args.quiet)
    result = runner.run()
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from operator import attrgetter
from pathlib import Path
from typing import Any, TextIO

from pirate_bt.trace.live import LiveView, live_view_hook
from pirate_bt.trace.records import TickExtras, TraceEvent
from pirate_bt.trace.structure import TreeStructure
from pirate_bt.trace.writer import TraceFormatWriter, TraceRecorder

_log = logging.getLogger(__name__)

__all__ = [
    "attach_live_view",
    "attach_trace",
    "call_observer",
    "counter_values",
    "node_id_for_path",
    "outcome_of_result",
    "supervised_extras",
]

_REASON_OUTCOME = {
    "success": "success",
    "failure": "failure",
    "time_limit": "failure",
    "exception": "error",
    "interrupted": "interrupted",
}


def node_id_for_path(structure: TreeStructure, name_path: str) -> str | None:
    """The path id of the node at a name path (``root/approach/clamp front``), if unique."""
    paths: dict[str, list[str]] = {}
    names: dict[str, str] = {}
    for node in structure:
        names[node.id] = node.name if node.parent is None else f"{names[node.parent]}/{node.name}"
        paths.setdefault(names[node.id], []).append(node.id)
    found = paths.get(name_path, [])
    return found[0] if len(found) == 1 else None


def outcome_of_result(result: Any) -> str:
    """The trace outcome for a runner's ``RunResult``."""
    reason = str(getattr(result, "reason", ""))
    return _REASON_OUTCOME.get(reason, "success" if result.outcome == "success" else "failure")


def attach_trace(
    runner: Any,
    destination: str | Path | TraceFormatWriter,
    *,
    extras: Callable[[Any], TickExtras | None] | None = None,
    why: Callable[[Any], str | None] | None = None,
    **options: Any,
) -> TraceRecorder:
    """Record every tick of ``runner`` into a trace.

    The header is written now; ticks from the runner's post-tick hook; the end
    record from its finish hook (also when the run raised or was interrupted),
    with the run's coverage (:func:`~pirate_bt.trace.coverage.attach_coverage`).

    Args:
        runner: A :class:`pirate_bt.runner.Runner` (not yet run).
        destination: The trace file (format by suffix) or a format writer.
        extras: Called with the runner's ``TickInfo`` after each tick; returns
            what else happened in it (state, verdicts, link health, counters).
        why: Called with the runner's result at the end; its answer is the end
            record's ``reason`` (the first cause, where the caller knows it better
            than the runner's ``tree failed after N ticks``).
        **options: Passed to :class:`TraceRecorder` (``robot``, ``scenario``,
            ``seed``, ``full_state``, ``readings``, ``every_tick``, ``meta``...).

    Returns:
        The recorder (already closed when ``runner.run()`` returns).
    """
    from pirate_bt.trace.coverage import attach_coverage

    options.setdefault("tick_period_s", runner.period_s)
    coverage = attach_coverage(runner)
    recorder = TraceRecorder(destination, runner.tree, clock=runner.clock, **options)

    def post_tick(info: Any) -> None:
        recorder.record_tick(extras(info) if extras is not None else None)

    def finish(result: Any) -> None:
        failing = getattr(result, "failing_node", None)
        node = node_id_for_path(recorder.structure, failing) if failing else None
        if getattr(result, "ticks", 0) > recorder.ticks:
            # The last tick raised before the post-tick hooks: record how it left the tree.
            kind = "exception" if getattr(result, "error", None) is not None else "note"
            message = str(getattr(result, "message", "the tick did not complete"))
            recorder.record_tick(TickExtras(events=(TraceEvent(kind, message, node),)))
        final: tuple[Any, ...] = ()
        if extras is not None:
            # What the run's end sent after its last tick (the running nodes' stops, the
            # safe state): no tick records it, so the end record does.
            try:
                last = extras(None)
                final = tuple(last.commands) if last is not None else ()
            except Exception:  # a courtesy: the end record must be written
                _log.exception("reading the verdicts after the last tick failed")
        reason = getattr(result, "message", None)
        if why is not None:
            try:
                reason = why(result) or reason
            except Exception:  # the cause is a courtesy; the end record must be written
                _log.exception("explaining the run's end failed")
        counts: dict[str, Any] | None = None
        try:
            coverage.finish(result)
            seen = coverage.coverage()
            counts = {
                "counts": {n.id: n.counts() for n in seen},
                "conditions": [n.id for n in seen if n.kind == "condition"],
            }
        except Exception:  # coverage is a courtesy too
            _log.exception("counting the run's coverage failed")
        recorder.close(
            outcome_of_result(result),
            reason=reason,
            error_node=node,
            exception=getattr(result, "error", None) if failing or node else None,
            coverage=counts,
            commands=final,
        )

    runner.add_post_tick(post_tick)
    runner.add_finish(finish)
    return recorder


def attach_live_view(
    runner: Any,
    stream: TextIO | None = None,
    *,
    quiet: bool = False,
    **options: Any,
) -> LiveView | None:
    """Show ``runner``'s tree live on ``stream`` (standard error by default).

    Args:
        runner: A :class:`pirate_bt.runner.Runner`.
        stream: Where to draw.
        quiet: Attach nothing (``--quiet``).
        **options: Passed to :class:`LiveView` (``interval_s``, ``redraw``, ``ascii_only``).

    Returns:
        The live view, or ``None`` when ``quiet``.
    """
    if quiet:
        return None
    view = live_view_hook(runner.tree, stream, clock=runner.clock, **options)
    assert isinstance(view, LiveView)
    runner.add_post_tick(view)
    return view


#: Trace name -> attribute of a ``SimCounters``.
_COUNTER_FIELDS = {
    "distance_m": "distance_m",
    "stuck_events": "stuck_events",
    "slip_events": "slip_events",
    "violations": "violation_count",
    "damage": "damage_count",
    "frames_dropped": "frames_dropped",
    "frames_rejected": "frames_rejected",
    "watchdog_trips": "watchdog_trips",
}
_counter_raw = attrgetter(*_COUNTER_FIELDS.values())
_COUNTER_KEYS = tuple(_COUNTER_FIELDS)
_NUMBER_TYPES = frozenset({int, float, bool})


def counter_values(counters: Any) -> dict[str, float]:
    """Simulator counters (a ``SimCounters`` or anything with those attributes) as numbers.

    Missing attributes are left out, so a counters object from another simulator
    version still gives what it has.
    """
    if counters is None:
        return {}
    try:
        raw = _counter_raw(counters)
    except AttributeError:
        raw = None
    if raw is not None and _NUMBER_TYPES.issuperset(map(type, raw)):
        return dict(zip(_COUNTER_KEYS, map(float, raw), strict=True))  # all there, in C
    out: dict[str, float] = {}
    for key, attr in _COUNTER_FIELDS.items():
        value = getattr(counters, attr, None)
        if isinstance(value, int | float):
            out[key] = float(value)
    return out


def _immutable(kind: type) -> bool:
    params = getattr(kind, "__dataclass_params__", None)
    return bool(getattr(params, "frozen", False))


class _CounterCache:
    """:func:`counter_values`, rebuilt only when a counter moved.

    Read every tick, but most ticks change one counter (distance while driving) or
    none. A frozen snapshot handed out again (``Simulator.counters`` returns the same
    one while nothing changed) is recognised by identity alone; otherwise one C-level
    ``attrgetter`` call and a tuple comparison decide, and the dict is rebuilt only
    when the tuple differs. The same dict is handed out while nothing changes; callers
    must not mutate it.
    """

    def __init__(self) -> None:
        self._raw: tuple[Any, ...] | None = None
        self._values: dict[str, float] = {}
        self._last: Any = None
        self._frozen: dict[type, bool] = {}

    def __call__(self, counters: Any) -> dict[str, float]:
        if counters is None:
            return {}
        if counters is self._last:
            return self._values
        try:
            raw = _counter_raw(counters)
        except AttributeError:  # a simulator without some counters: the slow, tolerant way
            self._raw = self._last = None
            return counter_values(counters)
        if raw != self._raw:
            self._raw = raw
            self._values = counter_values(counters)
        # Identity stands for "unchanged" only for objects that cannot change.
        kind = type(counters)
        frozen = self._frozen.get(kind)
        if frozen is None:
            frozen = self._frozen[kind] = _immutable(kind)
        self._last = counters if frozen else None
        return self._values


def supervised_extras(
    supervisor: Any,
    *,
    counters: Callable[[], Any] | None = None,
    more: Callable[[], dict[str, float]] | None = None,
) -> Callable[[Any], TickExtras]:
    """An ``extras`` callable for :func:`attach_trace` that reads a supervisor.

    Each tick it records the supervisor's latest state, every verdict given since
    the last tick (the supervisor's listener API, so none is missed or repeated),
    link health, and — when ``counters`` is given — the simulator's counters plus
    any values from ``more`` (e.g. a localiser's belief). The supervisor is
    duck-typed (``state()``, ``health()``, ``add_listener(fn)``), so this module
    does not import the protective layer.
    """
    from pirate_bt.trace.records import CommandRecord

    verdicts: list[Any] = []
    supervisor.add_listener(verdicts.append)
    from_verdict = CommandRecord.from_verdict
    sim_values = _CounterCache()
    state, health = supervisor.state, supervisor.health

    def extras(_info: Any) -> TickExtras:
        # Runs every tick: no list is built for a tick without verdicts, and the
        # counters dict is reused while no counter moved (see _CounterCache).
        records: tuple[CommandRecord, ...] = ()
        if verdicts:
            records = tuple(map(from_verdict, verdicts))
            verdicts.clear()
        sim: dict[str, float] | None = None
        if counters is not None:
            sim = sim_values(counters())
        if more is not None:
            sim = {**sim, **more()} if sim else more()
        return TickExtras(state=state(), commands=records, link=health(), sim=sim or None)

    return extras


def call_observer(
    observe: Any, runner: Any, connection: Any, recorder: Any, trace_path: Path | None
) -> None:
    """Call ``observe(runner, connection)`` (a mission's: ``observe(runner, values)``);
    when it raises (the planner's own error,
    before anything moved), close the trace attached for the run and remove its file
    before the exception goes on: no trace of a run that never ran. It was left empty
    with its file open, one file descriptor lost a call.
    """
    try:
        observe(runner, connection)
    except BaseException:
        if recorder is not None and trace_path is not None:
            with contextlib.suppress(Exception):
                recorder.close("error", reason="the run did not start")
            with contextlib.suppress(OSError):
                trace_path.unlink()
        raise
