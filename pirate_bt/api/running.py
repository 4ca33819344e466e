"""Load a tree for a run, bind it to a connection, run it and explain how it ended.

The machinery under :func:`pirate_bt.simulate_tree`, :func:`pirate_bt.run_tree` and
:meth:`pirate_bt.Connection.run`. A tree is a YAML file (or a bundled name such as
``"bend"``), a mapping of the same structure, a :class:`~pirate_bt.treefile.LoadedTree`,
or a ``py_trees`` behaviour built in Python. A YAML tree is checked against the
robot before anything connects (:class:`~pirate_bt.errors.ValidationFailed`, every
error at ``file:line:column``), then built on the connection's clock and
supervisor. A behaviour built in Python without a supervisor
(``BuildContext(robot=robot)``) is bound to the connection when it runs: every node
whose context has no supervisor gets the connection's robot, clock and supervisor.

Each run is supervised exactly like ``pirate-bt run``: the supervisor ticks before
the tree; an operator's MANUAL mode pauses it; any end but success stops running
nodes and leaves the robot in its safe state, keeping the first cause; the result
says why (:class:`~pirate_bt.api.results.RunResult`).
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import py_trees

from pirate_bt.api.binding import unbinder
from pirate_bt.api.loading import as_loaded as as_loaded
from pirate_bt.api.loading import find_tree as find_tree
from pirate_bt.api.loading import load_tree as load_tree
from pirate_bt.api.loading import load_tree_source as load_tree_source
from pirate_bt.api.observing import attach_only, call_observer
from pirate_bt.api.options import (
    run_limits,
)
from pirate_bt.api.process_run import only_run
from pirate_bt.api.results import RunResult
from pirate_bt.api.run_trace import attach_run_trace, check_run_options, check_trace
from pirate_bt.clock import SimClock
from pirate_bt.errors import (
    InputError,
)
from pirate_bt.task.outcome import END_OF_RUN, explain_run, link_cause, unsafe_note

if TYPE_CHECKING:
    from pirate_bt.runner import Runner

__all__ = [
    "Observer",
    "as_loaded",
    "check_run_options",
    "check_trace",
    "find_tree",
    "load_tree",
    "load_tree_source",
    "needs_robot",
    "run_on",
    "supervised_runner",
]

Observer = Callable[[Any, Any], None]
"""``observe(runner, connection)``: called before a run starts, to attach more hooks
(``connection`` is ``None`` for a tree that needs no robot)."""


def _unconfirmed(loop: Any, supervisor: Any) -> str:
    """For a supervised run that ran into its time limit with a step still waiting for
    an operator's confirmation: a clause saying so (``""`` otherwise), else the why
    names only the time limit and the node that was still running."""
    from pirate_bt.runner import StopReason
    from pirate_bt.safety import Mode

    if loop.reason is not StopReason.TIME_LIMIT or supervisor.mode is not Mode.SUPERVISED:
        return ""
    pending = supervisor.pending_confirmations()
    if not pending:
        return ""
    nobody = (
        ""
        if supervisor.operator_attached
        else "; no operator input is attached: confirm from your code with"
        " supervisor.confirm(), or run in autonomous mode"
    )
    return f"; it waited for an operator to confirm {pending[0]!r} (supervised mode{nobody})"


def _root(tree: Any) -> py_trees.behaviour.Behaviour:
    if isinstance(tree, py_trees.trees.BehaviourTree):
        root: py_trees.behaviour.Behaviour = tree.root
        return root
    if isinstance(tree, py_trees.behaviour.Behaviour):
        return tree
    root = tree.root
    return root


def needs_robot(tree: Any) -> bool:
    """True when some node of ``tree`` talks to the robot."""
    if hasattr(tree, "needs_robot") and not isinstance(tree, py_trees.behaviour.Behaviour):
        return bool(tree.needs_robot)
    return any(getattr(n, "needs_robot", False) for n in _root(tree).iterate())


def _name(tree: Any) -> str:
    name = getattr(tree, "name", None)
    if isinstance(tree, py_trees.trees.BehaviourTree):
        name = tree.root.name
    return str(name or "tree")


def _bind(root: py_trees.behaviour.Behaviour, connection: Any, clock: Any) -> None:
    """Give nodes built without a supervisor the connection's robot, clock and supervisor."""
    from pirate_bt.behaviours.base import BuildContext

    for node in root.iterate():
        context = getattr(node, "context", None)
        if not isinstance(context, BuildContext) or context.supervisor is not None:
            continue
        node.context = dataclasses.replace(  # type: ignore[attr-defined]
            context,
            robot=context.robot if connection is None else connection.robot,
            clock=clock,
            supervisor=None if connection is None else connection.supervisor,
        )


def _build_on(tree: Any, connection: Any, clock: Any, robot: Any) -> Any:
    """The tree built (a ``LoadedTree``) or bound (a behaviour) on the run's clock; a
    planner's own behaviours in it held to the run's contract (``hold_to_contract``)."""
    from pirate_bt.behaviours.foreign import contain_handlers, hold_to_contract
    from pirate_bt.treefile import LoadedTree

    if isinstance(tree, LoadedTree):
        from pirate_bt.behaviours.base import BuildContext
        from pirate_bt.treefile import build

        context = BuildContext(
            robot=robot,
            clock=clock,
            supervisor=None if connection is None else connection.supervisor,
        )
        root = build(tree.spec, context)
        hold_to_contract(root)
        return dataclasses.replace(tree, root=root)
    _bind(_root(tree), connection, clock)
    hold_to_contract(_root(tree))
    if isinstance(tree, py_trees.trees.BehaviourTree):
        contain_handlers(tree)
    return tree


def supervised_runner(
    connection: Any,
    tree: Any,
    *,
    clock: Any = None,
    robot: Any = None,
    period_s: float = 0.05,
    max_time_s: float | None = None,
    realtime: bool = False,
    setup_timeout_s: float = 15.0,
) -> Runner:
    """A :class:`~pirate_bt.runner.Runner` for ``tree`` wired to ``connection`` as every
    run is, not yet run: built (or bound) on the connection's clock and supervisor, the
    supervisor ticked before the tree, the tree paused while an operator holds the robot
    (MANUAL or ESTOP), and any end but success leaving the robot in its safe state with
    the first cause kept. For loops of your own (an operator console, a custom runner).

    Args:
        connection: An open :class:`~pirate_bt.api.connection.Connection` (``None``: a
            tree that needs no robot).
        tree: A checked tree (:func:`as_loaded`) or a behaviour.
        clock: The clock without a connection (default: a new simulated one).
        robot: The robot description without a connection.
        period_s: Tick period.
        max_time_s: Time limit (``None``: none).
        realtime: Pace a simulated run to wall time.
        setup_timeout_s: py_trees' setup timeout (``sys.float_info.max`` skips its
            signal, which only the main thread may set).
    """
    from pirate_bt.runner import Runner, link_lost_note

    if connection is not None:
        clock, robot = connection.clock, connection.robot
    clock = clock if clock is not None else SimClock()
    give_back = unbinder(tree)
    built = _build_on(tree, connection, clock, robot)
    supervisor = connection.supervisor if connection is not None else None

    def safe_state() -> None:
        # keep the cause a PAB or the supervisor gave first; else the run's own (an
        # exception, a time limit), so the next run's refusal names it
        assert supervisor is not None
        from pirate_bt.behaviours.cause import failure_cause

        # a tree that failed: the failure that explains it ("tree failed after 102
        # ticks" names no cause, and the next run's refusal would repeat it)
        cause = (
            failure_cause(runner.tree.root)
            if runner.tree.root.status == py_trees.common.Status.FAILURE
            else None
        )
        # whole: the supervisor cuts the reason it keeps once (a cut here was cut again)
        stopped = cause.reason if cause is not None else runner.stop_message
        own = f"{END_OF_RUN}: {stopped}" if stopped else END_OF_RUN
        supervisor.end_safe(supervisor.safe_state_reason or own)

    runner = Runner(
        built,
        clock=clock,
        period_s=period_s,
        max_time_s=max_time_s,
        realtime=realtime,
        safe_state=safe_state if supervisor is not None else None,
        # an e-stop or a safe state nobody attached can release ends the run (halted,
        # asked first); one an operator can release pauses the tree until they do
        paused=(lambda: supervisor.tree_paused) if supervisor is not None else None,
        halted=(lambda: supervisor.run_halted) if supervisor is not None else None,
        settle=supervisor.come_to_rest if supervisor is not None else None,
        rest_unknown=(lambda: link_lost_note(supervisor)) if supervisor is not None else None,
        setup_timeout_s=setup_timeout_s,
    )
    if supervisor is not None:
        runner.add_pre_tick(lambda _info: supervisor.tick())
    from pirate_bt.behaviours.foreign import let_go

    runner.add_finish(lambda _result: let_go(_root(built)))
    runner.add_finish(give_back)
    return runner


def _closed_by_observe(_runner: Any, connection: Any) -> None:
    """Refuse a run whose ``observe`` closed its connection as it attached its hooks (it
    went on, failed as *link lost: session closed*, exit 3: the link was fine)."""
    raise InputError(
        f"observe: it closed the connection ({connection.description}) before the run;"
        " close it once the run has ended (or use with pirate_bt.connect() as robot:)"
    )


def run_on(
    connection: Any,
    tree: Any,
    *,
    params: Mapping[str, Any] | None = None,
    max_time: str | float = "600 s",
    rate: str | float = "20 Hz",
    trace: str | Path | None = None,
    realtime: bool = False,
    live: bool = False,
    observe: Observer | None = None,
    robot: Any = None,
    trace_meta: Mapping[str, Any] | None = None,
    count_from_open: bool = False,
) -> RunResult:
    """Run ``tree`` on an open connection (``None``: a tree that needs no robot, on a
    simulated clock); see :func:`simulate_tree` for the arguments.

    The result's counters count this run only, unless ``count_from_open``: then they
    count from the moment the connection opened (its handshake's retries included),
    for a connection opened for this one run.

    The connection is held for the run (:meth:`Connection.one_run`): a run asked for on
    it meanwhile, by ``simulate_tree``'s ``observe`` or a hook, another thread or a
    runner of ``connection.runner()``, is refused (until the twenty-third session only
    ``Connection.run`` held it, and the two trees ticked one robot: each failed on the
    other's *motor_conflict*, the robot left in its safe state)."""
    period_s, max_time_s = run_limits(max_time, rate)
    check_run_options(trace=trace, realtime=realtime, live=live, observe=observe)
    if trace is not None:
        check_trace(trace, inputs={"tree": tree})
    with contextlib.ExitStack() as held:
        if connection is not None:
            connection.check_open()
            held.enter_context(connection.one_run())
        held.enter_context(only_run("a run" if connection is None else "Connection.run"))
        return _run_held(
            connection,
            tree,
            params=params,
            period_s=period_s,
            max_time_s=max_time_s,
            trace=trace,
            realtime=realtime,
            live=live,
            observe=observe,
            robot=robot if connection is None else connection.robot,
            trace_meta=trace_meta,
            count_from_open=count_from_open,
        )


def _run_held(
    connection: Any,
    tree: Any,
    *,
    params: Mapping[str, Any] | None,
    period_s: float,
    max_time_s: float,
    trace: str | Path | None,
    realtime: bool,
    live: bool,
    observe: Observer | None,
    robot: Any,
    trace_meta: Mapping[str, Any] | None,
    count_from_open: bool,
) -> RunResult:
    """:func:`run_on` once its arguments are checked and its connection held."""
    from pirate_bt.behaviours.foreign import as_text, blocked_ticks, contain_hooks, one_line
    from pirate_bt.runner import halted_by
    from pirate_bt.safety.tally import Counters, VerdictTally

    checked = as_loaded(tree, robot, params)
    clock = connection.clock if connection is not None else SimClock()
    supervisor = connection.supervisor if connection is not None else None
    runner = supervised_runner(
        connection,
        checked,
        clock=clock,
        robot=robot,
        period_s=period_s,
        max_time_s=max_time_s,
        realtime=realtime,
    )
    if supervisor is not None:
        # a step nobody attached could confirm ends the run (robot.runner(...) leaves it
        # to its caller: the console confirms through the supervisor, attaching no input)
        runner.halted = lambda: halted_by(supervisor, runner.tree.root)
    from pirate_bt.trace.coverage import attach_coverage

    coverage = attach_coverage(runner, _name(checked))
    tally = VerdictTally(supervisor) if supervisor is not None else None
    counting = tally
    if count_from_open and connection is not None:
        counting = connection.tally
    if live:
        from pirate_bt.trace import attach_live_view

        attach_live_view(runner)
    trace_path = Path(trace) if trace is not None else None
    recorder = None
    if trace_path is not None:

        def end_reason(loop: Any) -> str:
            first = tally.first_safe_state if tally is not None else None
            return as_text(explain_run(loop, runner.tree.root, first)[0])

        recorder = attach_run_trace(runner, trace_path, connection, robot, trace_meta, end_reason)
    if observe is not None:
        call_observer(attach_only(observe), runner, connection, recorder, trace_path)
        contain_hooks(runner)
        if connection is not None and connection.closed:  # (its trace removed as unrun)
            call_observer(_closed_by_observe, runner, connection, recorder, trace_path)
    held = supervisor.safe_state_reason if supervisor is not None else None
    try:
        loop = runner.run()
    finally:
        if tally is not None:
            tally.detach()
    first_stop = tally.first_safe_state if tally is not None else None
    why, failing = explain_run(loop, runner.tree.root, first_stop)
    why = as_text(why)  # a planner's feedback message may be no text (42)
    if connection is not None and connection.closed and not loop.succeeded:
        # by planner code, from another thread or a hook: its first cause, not the link's
        why = f"the connection ({connection.description}) was closed during the run: {why}"
    never_left = supervisor is not None and supervisor.safe_state_reason == held
    if held is not None and never_left and not loop.succeeded:
        # held in the safe state a run before this one left it in, all along: this run
        # could do nothing, and that first cause is its why (not a fresh failure)
        why = f"the robot is in its safe state: {held}"
    counters = (
        counting.counters(overruns=loop.overrun_count)
        if counting is not None
        else Counters(overruns=loop.overrun_count)
    )
    if loop.succeeded:
        why += unsafe_note(counters)
    elif loop.paused_ticks and supervisor is not None:
        # a tree held by an operator all along ran into its time limit: say so, else
        # "time limit of 5 s reached after 101 ticks" hides why nothing moved
        still = f" ({supervisor.mode.name.lower()} mode)" if supervisor.tree_paused else ""
        why += (
            f"; the tree was paused for {loop.paused_ticks} of its ticks while an operator"
            f" held the robot{still}"
        )
    elif supervisor is not None and (waiting := _unconfirmed(loop, supervisor)):
        why += waiting
    why += blocked_ticks(loop)
    after_stop = None
    if supervisor is not None and not loop.succeeded:
        # a PAB stopped half-way may leave one half free in a riser: clamp it, as a
        # mission and a navigation do (task.secure), or say plainly that it could not be
        from pirate_bt.task.secure import hold_both

        after_stop = hold_both(robot, supervisor, clock, period_s=period_s)
    return RunResult(
        tree=_name(checked),
        status=loop.outcome,
        stop=loop.reason,
        why=one_line(why),
        failing_node=failing,
        sim_time_s=loop.sim_time_s,
        wall_s=loop.wall_time_s,
        ticks=loop.ticks,
        counters=counters,
        safe_state=bool(supervisor is not None and supervisor.in_safe_state),
        target=connection.description if connection is not None else "no robot",
        trace_path=trace_path,
        error=loop.error or link_cause(loop, supervisor),
        traceback=loop.traceback,
        loop=loop,
        coverage=coverage.coverage(),
        after_stop=after_stop,
    )
