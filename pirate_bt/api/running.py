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

import dataclasses
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import py_trees

from pirate_bt.api.binding import unbinder
from pirate_bt.api.observing import attach_only, call_observer
from pirate_bt.api.options import (
    find,
    flag,
    kind_of,
    params_mapping,
    run_limits,
)
from pirate_bt.api.process_run import only_run
from pirate_bt.api.results import RunResult
from pirate_bt.api.run_trace import attach_run_trace, check_run_options, check_trace
from pirate_bt.clock import SimClock
from pirate_bt.errors import (
    InputError,
    LocatedError,
    SourceLocation,
    ValidationFailed,
    caller_location,
)
from pirate_bt.task.outcome import END_OF_RUN, explain_run, link_cause, unsafe_note

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription
    from pirate_bt.runner import Runner
    from pirate_bt.treefile import LoadedTree

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


def as_loaded(
    tree: Any, robot: RobotDescription | None, params: Mapping[str, Any] | None = None
) -> Any:
    """A tree as the runner takes it: a checked ``LoadedTree``, or the behaviour itself.

    Args:
        tree: A path or bundled name, a mapping, a ``LoadedTree``, a behaviour or a
            ``BehaviourTree``.
        robot: The robot description the tree is checked against.
        params: The tree's parameters (YAML trees only): strings are read as on the
            command line (``"90 deg"``), numbers are SI.

    Raises:
        ValidationFailed: the tree or a parameter does not validate.
        InputError: parameters for a tree that is not YAML, or an unknown kind of tree.
    """
    from pirate_bt.treefile import LoadedTree

    params_mapping(params)
    if isinstance(tree, LoadedTree | py_trees.behaviour.Behaviour | py_trees.trees.BehaviourTree):
        if params:
            raise InputError(
                f"params: given for an already built tree ({type(tree).__name__});"
                " give them to load_tree, or pass the tree's file"
            )
        return tree
    if isinstance(tree, Mapping):
        source: Any = tree
    elif isinstance(tree, str | Path):
        source = find_tree(tree)
    else:
        raise InputError(
            f"tree: cannot run {kind_of(tree)}: give a tree file, a mapping, a"
            " LoadedTree or a py_trees behaviour"
        )
    given = params_mapping(params)
    # text is read as on the command line, numbers and booleans as they are, each by itself
    from_text = any(isinstance(v, str) for v in given.values())
    return _at_callers_line(
        source,
        lambda: load_tree_source(source, robot=robot, params=given, params_from_text=from_text),
    )


def find_tree(tree: str | Path, option: str = "tree") -> Path:
    """The tree file ``tree`` names: the path if something is there, else the bundled
    tree of that name (``"bend"`` → ``trees/bend.yaml``). What ``simulate_tree``,
    ``load_tree`` and ``pirate-bt run`` look a tree up with.

    Raises:
        InputError: ``tree`` is not a file name (named by ``option``).
        ValidationFailed: neither a file nor a bundled tree: one line,
            ``nosuch:1:1: no such tree file; bundled trees: bend, bend-back, ...``.
    """
    from pirate_bt.resources import bundled_names, missing

    path = find("trees", tree, ".yaml", option)
    if not missing(path):  # a file, or what the loader says it is (a folder, a device)
        return path
    names = ", ".join(bundled_names("trees"))
    message = f"no such tree file; bundled trees: {names}"
    raise ValidationFailed([LocatedError(message, SourceLocation(str(path)))])


def load_tree_source(
    source: str | Path | Mapping[str, Any],
    *,
    robot: RobotDescription | None,
    params: Mapping[str, Any] | None = None,
    params_from_text: bool = False,
    **options: Any,
) -> LoadedTree:
    """Load and check a tree file or mapping for a run: a ``.xml`` file as a
    BehaviorTree.CPP v4 tree (Groot2's; :func:`pirate_bt.interop.load_xml_tree`, each
    problem at its XML element), anything else as a YAML tree
    (:func:`pirate_bt.treefile.load_tree`). ``options`` go to either (``params_origin``,
    ``use_examples``). What ``simulate_tree``, ``pirate-bt run`` and ``pirate-bt
    validate`` load a tree with.
    """
    if isinstance(source, str | Path) and Path(source).suffix.lower() == ".xml":
        from pirate_bt.interop.btcpp_import_file import load_xml_tree

        return load_xml_tree(
            source, robot=robot, params=params, params_from_text=params_from_text, **options
        )
    from pirate_bt.treefile import load_tree

    return load_tree(
        source, robot=robot, params=params, params_from_text=params_from_text, **options
    )


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


def _at_callers_line(source: Any, load: Callable[[], LoadedTree]) -> LoadedTree:
    """``load()``; for a tree given as a mapping, its problems at the planner's line.

    The loader places them at ``<dict>:1:1`` (a mapping has no lines); the planner's
    own call is where the mapping was written (``planner.py:17:1: clamp: torque: ...``),
    as for parameters and nodes built in Python.
    """
    try:
        return load()
    except ValidationFailed as exc:
        if not isinstance(source, Mapping):
            raise
        package = Path(__file__).parent.parent
        where = caller_location(skip=(package / "treefile", package / "api"))
        if where is None:  # pirate_bt's own code gave it
            raise
        moved = [
            LocatedError(e.message, where) if e.location.file == "<dict>" else e for e in exc.errors
        ]
        raise ValidationFailed(moved) from None


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
    if connection is not None:
        connection.check_open()
        with connection.one_run(), only_run("Connection.run"):
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
                robot=connection.robot,
                trace_meta=trace_meta,
                count_from_open=count_from_open,
            )
    with only_run("a run"):
        return _run_held(
            None,
            tree,
            params=params,
            period_s=period_s,
            max_time_s=max_time_s,
            trace=trace,
            realtime=realtime,
            live=live,
            observe=observe,
            robot=robot,
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
    )


LOAD_OPTIONS = ("registry", "use_examples", "clock", "supervisor")
"""The options :func:`load_tree` passes on to :func:`pirate_bt.treefile.load_tree`."""


def _load_options(options: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`load_tree`'s ``**options``, each checked: one it does not pass on, or a
    value of another type, was taken on to a traceback from inside the loader (a
    ``registry`` of text), read as true (``use_examples="no"``) or kept unused.

    Raises:
        ArgumentTypeError: the first that is wrong, named.
    """
    from pirate_bt.errors import ArgumentTypeError, shown
    from pirate_bt.safety import Supervisor
    from pirate_bt.treefile import Registry

    for name, value in options.items():
        if name not in LOAD_OPTIONS:
            raise ArgumentTypeError(
                f"load_tree: no option {name!r}"[:100]
                + f"; it takes params, robot, check_robot, {', '.join(LOAD_OPTIONS)}"
            )
        if name == "use_examples":
            flag(value, name)
        elif value is None:
            continue
        elif name == "registry" and not isinstance(value, Registry):
            raise ArgumentTypeError(
                "registry: give a Registry (pirate_bt.treefile.default_registry(), with"
                f" your node types added) or None, not {shown(value)}"
            )
        elif name == "clock" and not callable(getattr(value, "now", None)):
            raise ArgumentTypeError(
                f"clock: give a clock (pirate_bt.clock.SimClock(), WallClock()) or None, not"
                f" {shown(value)}"
            )
        elif name == "supervisor" and not isinstance(value, Supervisor):
            raise ArgumentTypeError(
                "supervisor: give a Supervisor (a connection's robot.supervisor) or None,"
                f" not {shown(value)}"
            )
    return dict(options)


def load_tree(
    tree: Any,
    *,
    robot: Any = None,
    params: Mapping[str, Any] | None = None,
    check_robot: bool = True,
    **options: Any,
) -> LoadedTree:
    """Load and check a tree: a YAML tree (a file, a bundled name such as ``"bend"``, or
    a mapping) or a BehaviorTree.CPP v4 XML file (``.xml``, as
    :func:`pirate_bt.load_xml_tree` reads it, each problem at its XML element).

    Unlike :func:`pirate_bt.treefile.load_tree`, the tree is checked against the
    bundled robot when no ``robot`` is given (``check_robot=False`` skips the limit
    checks, for a tree of generic leaves drawn offline). Parameters are read as on
    the command line when they are strings (``{"roll": "90 deg"}``); numbers are SI.
    Build it on a robot with :meth:`Connection.run` or :func:`simulate_tree`.

    Args:
        tree: The tree.
        robot: The robot description (a loaded one, a file; default: bundled).
        params: The tree's parameters.
        check_robot: Check against the robot's limits.
        **options: Passed to :func:`pirate_bt.treefile.load_tree`: ``registry`` (a
            ``Registry``), ``use_examples`` (``True``/``False``), ``clock`` (a clock),
            ``supervisor`` (a ``Supervisor``), each or ``None``; no other.

    Returns:
        pirate_bt.treefile.LoadedTree: The checked tree (``root``, ``params``,
            ``needs_robot``, ``warnings``...).

    Raises:
        ValidationFailed: every problem, each at ``file:line:column``.
        ArgumentTypeError: an option it does not take, or one of another type.

    Example::

        tree = pirate_bt.load_tree("bend", params={"roll": "90 deg"})
        print(tree.name, tree.needs_robot)
    """
    from pirate_bt.api.options import load_robot_like

    description = load_robot_like(robot) if flag(check_robot, "check_robot") else None
    options = _load_options(options)
    if isinstance(tree, Mapping):
        source: Any = tree
    elif isinstance(tree, str | Path):
        source = find_tree(tree)
    else:
        raise InputError(
            f"tree: give a tree file, a bundled name or a mapping, not {kind_of(tree)}"
        )
    given = params_mapping(params)
    # text is read as on the command line, numbers and booleans as they are, each by itself
    from_text = any(isinstance(v, str) for v in given.values())
    return _at_callers_line(
        source,
        lambda: load_tree_source(
            source, robot=description, params=given, params_from_text=from_text, **options
        ),
    )
