"""Plan and run missions: :func:`plan_route`, :func:`simulate_mission`, :func:`run_mission`.

A route (``scenarios/lab.route``: plain words an operator writes) is planned on a
map into one chain of partial autonomous behaviours (PABs) and run as one tree,
with the localiser beside it. On the simulator, the pipe the robot really runs in
(``truth``) may differ from the map: an as-built variant
(:func:`pirate_bt.pipes.asbuilt.perturb_network`). The result lists every PAB
with its outcome and cause, and names the first cause of a stop
(:class:`~pirate_bt.task.mission.MissionResult`).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pirate_bt.api.connection import Connection, check_fault_targets, connect
from pirate_bt.api.live import (
    FoxgloveOption,
    Groot2Option,
    Ros2Option,
    chain,
    check_live_options,
    foxglove_server,
    groot2_mission_observer,
    groot2_server,
    mission_observer,
    ros2_mission_observer,
    ros2_node,
)
from pirate_bt.api.mission_outputs import (
    OutputsNotWritten,
    outputs_not_inputs,
    write_mission_outputs,
)
from pirate_bt.api.observing import attach_only, check_observer
from pirate_bt.api.options import (
    fault_list,
    file_name,
    flag,
    fraction,
    kind_of,
    load_robot_like,
    output_folder,
    port_url,
    positive_time_s,
    seed_value,
    split_faults,
    tick_period_s,
    writable_folder,
)
from pirate_bt.api.process_run import one_run_in_process
from pirate_bt.api.results import closing_why
from pirate_bt.atomic import new_folders_undone
from pirate_bt.errors import InputError
from pirate_bt.task.localise import MAP_FRACTION

if TYPE_CHECKING:
    from pirate_bt.pipes import Network
    from pirate_bt.task.mission import MissionResult
    from pirate_bt.task.plan import MissionPlan
    from pirate_bt.task.route import Route

__all__ = [
    "load_network",
    "load_route",
    "plan_route",
    "run_mission",
    "simulate_mission",
    "write_mission_outputs",
]

MissionObserver = Callable[[Any, Callable[[], dict[str, float]]], None]


def load_network(network: Any, *, base: str | Path | None = None) -> Network:
    """A pipe network: a bundled name (``"lab"``), a file, a ``NetworkSpec`` or a ``Network``.

    Args:
        network: What to load.
        base: The folder a relative name is looked up in first (a route's folder).

    Returns:
        pirate_bt.pipes.Network: The network.

    Raises:
        InputError: no such network (the error lists the bundled names).
        ValidationFailed: the file does not validate, each error at ``file:line:column``.

    Example::

        network = pirate_bt.load_network("bend-right")
        print(network)   # Network('bend-right', 3 segments, 0 tees)
    """
    return _load_network(network, base, "network")


def _load_network(network: Any, base: str | Path | None, option: str) -> Network:
    """:func:`load_network` for the argument ``option`` (``network``, ``truth``)."""
    from pirate_bt.pipes import Network, NetworkSpec
    from pirate_bt.pipes import load_network as load_file
    from pirate_bt.task.networks import resolve_network_path

    if isinstance(network, Network):
        return network
    if isinstance(network, NetworkSpec):
        return Network(network, f"<{network.name}>")
    if not isinstance(network, str | Path):
        raise InputError(
            f"{option}: give a bundled name, a file, a NetworkSpec or a Network, not"
            f" {kind_of(network)}"
        )
    name = file_name(network, option)
    folder = output_folder(base, "base") if base is not None else None
    try:
        path = resolve_network_path(str(name), folder)
    except FileNotFoundError as exc:
        raise InputError(f"{option}: {exc}") from None
    except OSError as exc:  # a name the system refuses (a part too long)
        raise InputError(f"{option}: no network {str(name)[:80]!r}: {exc.strerror}") from None
    return load_file(path)


def load_route(route: Any) -> Route:
    """A route: a file, a bundled name (``"lab"`` or ``"lab.route"``), or a ``Route``.

    Raises:
        ValidationFailed: the file cannot be read or a line is malformed, each
            error at ``file:line:column``.

    Example::

        route = pirate_bt.load_route("lab")
        print(route.network, [step.text for step in route.steps][:2])
    """
    from pirate_bt.task.route import Route
    from pirate_bt.task.route import load_route as load_file

    if isinstance(route, Route):
        return route
    from pirate_bt.api.options import find

    if not isinstance(route, str | Path):
        raise InputError(
            f"route: give a route file, a bundled name or a Route, not {kind_of(route)}"
        )
    return load_file(find("scenarios", route, ".route", "route"))


_route = load_route


def _base(route: Any) -> Path | None:
    return Path(route.source).parent if not route.source.startswith("<") else None


def plan_route(route: Any, *, network: Any = None, robot: Any = None) -> MissionPlan:
    """Plan a route on a map into a chain of PABs.

    Args:
        route: A route file (``"scenarios/lab.route"``, or a bundled name ``"lab"``)
            or a parsed :class:`~pirate_bt.task.route.Route`.
        network: The map (default: the route's ``network`` line).
        robot: The robot description (default: bundled).

    Returns:
        pirate_bt.task.plan.MissionPlan: The plan (``plan.describe()`` lists it).

    Raises:
        LocatedError: the route does not fit the map, at the route's line.
        ValidationFailed: a malformed route or network.

    Example::

        plan = pirate_bt.plan_route("lab.route")
        print("\\n".join(plan.describe()))
    """
    from pirate_bt.task.networks import load_network_for
    from pirate_bt.task.planner import plan_route as plan

    parsed = _route(route)
    description = load_robot_like(robot)
    if network is None:
        the_map = load_network_for(parsed, None, option="network")  # network=, not --sim
    else:
        the_map = load_network(network, base=_base(parsed))
    return plan(parsed, the_map, description)


def _plan(plan_or_route: Any, network: Any, robot: Any) -> MissionPlan:
    from pirate_bt.task.plan import MissionPlan

    if isinstance(plan_or_route, MissionPlan):
        if network is not None:
            from pirate_bt.errors import InputError

            raise InputError("network: a plan is already planned on its map; give a route")
        return plan_or_route
    return plan_route(plan_or_route, network=network, robot=robot)


def _mission(
    connection: Connection,
    plan: Any,
    *,
    trace: str | Path | None,
    period_s: float,
    max_time_s: float | None,
    map_tolerance: float,
    live: bool,
    realtime: bool,
    observe: MissionObserver | None,
    return_on_stop: bool,
) -> MissionResult:
    """Run a plan on an open connection, re-plan where it may, come back if asked."""
    from pirate_bt.task.mission import run_mission as run_plan
    from pirate_bt.task.mission import truth_of
    from pirate_bt.task.outcome import unsafe_note
    from pirate_bt.task.replan import carry_on, return_to_start
    from pirate_bt.task.secure import hold_both

    sim = connection.simulator

    def truth_for(p: Any) -> Any:
        return truth_of(p, sim) if sim is not None else None

    started_s = connection.clock.now()
    result = run_plan(
        plan,
        connection.robot,
        connection.supervisor,
        connection.clock,
        truth=truth_for(plan),
        counters=sim.counters if sim is not None else None,
        trace_path=Path(trace) if trace is not None else None,
        scenario=connection.target,
        seed=connection.seed,
        live=live,
        period_s=period_s,
        max_time_s=max_time_s,
        realtime=realtime,
        map_tolerance=map_tolerance,
        observe=observe,
        count_from_open=True,  # as a tree run: a slide as the robot was put in counts
    )
    result = carry_on(
        result,
        connection.robot,
        connection.supervisor,
        connection.clock,
        truth_for=truth_for,
        counters=sim.counters if sim is not None else None,
        period_s=period_s,
        map_tolerance=map_tolerance,
        observe=observe,
        max_time_s=max_time_s,
        started_s=started_s,
    )
    if result.succeeded:
        result.why += unsafe_note(result.counters)
    else:  # a PAB stopped half-way through may leave one half free in a riser
        held = hold_both(connection.robot, connection.supervisor, connection.clock)
        if held is not None:
            result.replans.append(f"after the stop, {held}")
    if return_on_stop and not result.succeeded and sim is not None:
        result.returned = return_to_start(
            result, connection.robot, connection.supervisor, connection.clock, sim, observe=observe
        )
    return result


def _options(
    rate: str | float,
    max_time: str | float | None,
    map_tolerance: float,
    plan: MissionPlan,
    robot: Any,
    checks: dict[str, Any],
) -> tuple[float, float | None]:
    """``(tick period, time limit or None: the plan's)``, every option checked first.

    ``max_time`` ``nan`` or ``inf`` is refused; ``None`` is the plan's own limit
    (:func:`~pirate_bt.task.mission.estimate_time_s`), which a tick must come within.
    ``checks`` are the other options by name (``seed``, ``trace``, ``observe``...).
    """
    from pirate_bt.api.options import NO_LIMIT
    from pirate_bt.api.running import check_trace
    from pirate_bt.task.mission import estimate_time_s

    max_time_s = (
        positive_time_s(max_time, "max_time", instead=f"{NO_LIMIT}, or None for the plan's")
        if max_time is not None
        else None
    )
    limit_s = max_time_s or estimate_time_s(plan, robot.motion.nominal_speed)
    period_s = tick_period_s(
        rate, limit_s, limit_option="max_time" if max_time_s else "the plan's time limit"
    )
    fraction(map_tolerance, "map_tolerance")
    for name in ("live", "realtime", "return_on_stop", "firmware"):
        flag(checks.get(name, False), name)
    seed_value(checks.get("seed", 0))
    split_faults(checks.get("faults"))
    check_observer(checks.get("observe"), "observe(runner, values)")
    inputs: dict[str, Any] = {
        k: v for k, v in checks.get("inputs", {}).items() if isinstance(v, str | Path)
    }
    inputs |= {"route": plan.route.source, "network": getattr(plan.network, "source", None)}
    if checks.get("trace") is not None:
        check_trace(checks["trace"], inputs=inputs)
    if checks.get("output") is not None:
        output_folder(checks["output"])
        there = checks.get("trace") is None  # the trace goes into the output folder
        outputs_not_inputs(checks["output"], "output", inputs, trace_there=there)
    check_live_options(*checks.get("views", (None,) * 5))
    return period_s, max_time_s


@one_run_in_process("simulate_mission")
def simulate_mission(
    plan_or_route: Any,
    *,
    network: Any = None,
    truth: Any = None,
    seed: int = 0,
    faults: str | Iterable[str] | None = None,
    trace: str | Path | None = None,
    output: str | Path | None = None,
    robot: Any = None,
    max_time: str | float | None = None,
    rate: str | float = "20 Hz",
    map_tolerance: float = MAP_FRACTION,
    return_on_stop: bool = False,
    live: bool = False,
    realtime: bool = False,
    foxglove: FoxgloveOption = None,
    observe: MissionObserver | None = None,
    ros2: Ros2Option = None,
    ros_domain_id: int | None = None,
    ros_namespace: str | None = None,
    groot2: Groot2Option = None,
    firmware: bool = False,
) -> MissionResult:
    """Plan a route on a map (unless given a plan) and run it on the simulator.

    The planner and the localiser know only the map; the simulator runs ``truth``.

    Args:
        plan_or_route: A route (file, bundled name or ``Route``) or a ``MissionPlan``
            from :func:`plan_route` (not planned again).
        network: The map (default: the route's ``network`` line). Not with a plan.
        truth: The network the simulator runs (default: the map): an as-built variant.
        seed: The simulator's seed (and the link faults').
        faults: As ``pirate-bt mission --faults``: ``"motor_stall:bend_1_drive@30s+5s"``,
            ``"drop=0.05,corrupt=0.01"``.
        trace: Write the trace here (default: ``output/trace.jsonl`` with ``output``).
        output: Write the trace, plots, tree diagram and ``report.md``/``.html`` here.
        robot: The robot description (default: bundled).
        max_time: Time limit (default: generous, from the plan).
        rate: Tick rate.
        map_tolerance: How far the map's lengths may be off per metre from the last
            feature (0.1 = 10 %; 0 for a map known to be exact).
        return_on_stop: After a stop, leave the safe state and drive back to the start
            (``result.returned``).
        live: Draw the tree live on standard error.
        realtime: Pace the simulated run to wall time.
        foxglove: Serve the run live to Foxglove (``"HOST:PORT"``, ``True`` or a server).
        observe: ``observe(runner, localiser_values)`` for each runner the mission makes.
        ros2: Show the run on a ROS 2 graph over Zenoh (``"tcp/HOST:PORT"``, ``True``
            or an open ``Ros2Node``; docs/ros2.md), with ``ros_domain_id`` and
            ``ros_namespace``; its ``estop`` topic e-stops through the supervisor.
        groot2: Serve the run live to Groot2 (``"HOST:PORT"``, a port, ``True`` for
            127.0.0.1:1667, or an open ``Groot2Server``; docs/interop-groot2.md):
            each runner of the mission (a re-plan, the way back) is a new tree there.
        firmware: Run the physics behind the real firmwares in simavr (the bridge
            and a reference PICO per board, in virtual time) instead of the Python
            bridge; link faults only. Needs ``make firmware`` (docs/firmware-sim.md).

    Returns:
        pirate_bt.task.mission.MissionResult: ``status``, ``why``, ``failing_node``,
            ``pabs`` (one :class:`~pirate_bt.task.outcome.PabOutcome` per step),
            ``counters``, belief and truth. A failed mission is a result.

    Raises:
        LocatedError: the route does not fit the map.
        ValidationFailed: a malformed route or network.
        InputError: a malformed option or fault.
        LinkError: the simulator cannot be reached.

    Example::

        result = pirate_bt.simulate_mission("lab.route", seed=3)
        for pab in result.pabs:
            print(pab.label, pab.outcome, pab.why)
    """
    description = load_robot_like(robot)
    plan = _plan(plan_or_route, network, description)
    faults = fault_list(faults)  # a generator: read once, checked and then run
    checks: dict[str, Any] = {
        "seed": seed,
        "faults": faults,
        "trace": trace,
        "output": output,
        "live": live,
    }
    checks |= {"realtime": realtime, "return_on_stop": return_on_stop, "firmware": firmware}
    checks |= {"observe": observe, "views": (foxglove, ros2, ros_domain_id, ros_namespace, groot2)}
    checks["inputs"] = {"route": plan_or_route, "truth": truth, "robot": robot}
    period_s, max_time_s = _options(rate, max_time, map_tolerance, plan, description, checks)
    world = plan.network if truth is None else _load_network(truth, _base(plan.route), "truth")
    if not firmware:  # a motor the robot lacks, before the output folder is made
        check_fault_targets(split_faults(faults)[0], description)
    return _watched_mission(
        lambda: connect(world, robot=description, seed=seed, faults=faults, firmware=firmware),
        plan,
        description,
        views=(foxglove, ros2, ros_domain_id, ros_namespace, groot2, observe),
        output=output,
        trace=trace,
        period_s=period_s,
        max_time_s=max_time_s,
        map_tolerance=map_tolerance,
        live=live,
        realtime=realtime,
        return_on_stop=return_on_stop,
    )


@contextlib.contextmanager
def _folders_undone(out: Path | None, trace_path: Path | None, option: str) -> Iterator[None]:
    """Make the output and trace folders (before anything connects or moves); when
    the block raises, take away again those it made that are still empty."""
    trace_folder = trace_path.parent if trace_path is not None else None
    with contextlib.ExitStack() as stack:
        for folder in (out, trace_folder):
            if folder is not None:
                stack.enter_context(new_folders_undone(folder))
        if out is not None:
            writable_folder(out, "output")
        if trace_folder is not None:
            writable_folder(trace_folder, option)
        yield


def _watched_mission(
    open_connection: Callable[[], Any],
    plan: Any,
    description: Any,
    *,
    views: tuple[FoxgloveOption, Ros2Option, int | None, str | None, Groot2Option, Any],
    output: str | Path | None,
    trace: str | Path | None,
    period_s: float,
    max_time_s: float | None,
    map_tolerance: float,
    live: bool,
    realtime: bool,
    return_on_stop: bool,
) -> MissionResult:
    """Run ``plan`` on a connection with the live views asked for, then write the outputs.

    ``views`` are the Foxglove, ROS 2 (option, domain id, namespace) and Groot2
    options and the caller's observer; the rest are :func:`_mission`'s.
    """
    foxglove, ros2, ros_domain_id, ros_namespace, groot2, observe = views
    out = Path(output) if output is not None else None
    trace_path = Path(trace) if trace is not None else (out / "trace.jsonl" if out else None)
    started = time.perf_counter()
    with (
        # a mission refused before it runs (a port that does not answer, a live view's
        # port taken) leaves no empty folder made for its outputs
        _folders_undone(out, trace_path, "trace" if trace is not None else "output"),
        foxglove_server(foxglove) as server,
        ros2_node(ros2, domain_id=ros_domain_id, namespace=ros_namespace) as node,
        groot2_server(groot2) as groot2_view,
        open_connection() as connection,
    ):
        live_view = mission_observer(server, connection, description) if server else None
        ros2_view = ros2_mission_observer(node, connection, description) if node else None
        groot2_live = groot2_mission_observer(groot2_view, connection) if groot2_view else None
        result = _mission(
            connection,
            plan,
            trace=trace_path,
            period_s=period_s,
            max_time_s=max_time_s,
            map_tolerance=map_tolerance,
            live=live,
            realtime=realtime,
            observe=chain(live_view, ros2_view, groot2_live, attach_only(observe)),
            return_on_stop=return_on_stop,
        )
    if connection.close_error is not None:  # the robot stopped? (api.results.after_close)
        result.why = closing_why(result.succeeded, result.why, connection.close_error)
        result.close_error = connection.close_error
    if out is not None:
        try:
            write_mission_outputs(result, out, wall_s=time.perf_counter() - started)
        except InputError as exc:  # after the run: its result and first cause go with it
            message = f"{exc}; the mission itself: {result.summary()}"
            raise OutputsNotWritten(message, result) from None
    return result


@one_run_in_process("run_mission")
def run_mission(
    plan_or_route: Any,
    *,
    port: str | Path,
    network: Any = None,
    faults: str | Iterable[str] | None = None,
    trace: str | Path | None = None,
    output: str | Path | None = None,
    robot: Any = None,
    max_time: str | float | None = None,
    rate: str | float = "20 Hz",
    map_tolerance: float = MAP_FRACTION,
    live: bool = False,
    foxglove: FoxgloveOption = None,
    observe: MissionObserver | None = None,
    ros2: Ros2Option = None,
    ros_domain_id: int | None = None,
    ros_namespace: str | None = None,
    groot2: Groot2Option = None,
) -> MissionResult:
    """Run a mission on a real robot at ``port``, as :func:`simulate_mission` does.

    Args:
        port: A serial port or pyserial URL (``"/dev/ttyACM0"``).
        faults: Link faults only (``"drop=0.05"``).

    The other arguments are :func:`simulate_mission`'s; there is no truth (the
    result's ``truth_m`` is ``None``) and no way back is driven automatically.

    Example::

        result = pirate_bt.run_mission("lab.route", port="/dev/ttyACM0")
        print(result.why)
    """
    port = port_url(port)
    description = load_robot_like(robot)
    plan = _plan(plan_or_route, network, description)
    faults = fault_list(faults)  # a generator: read once, checked and then run
    checks: dict[str, Any] = {"faults": faults, "trace": trace, "output": output, "live": live}
    checks |= {"observe": observe, "views": (foxglove, ros2, ros_domain_id, ros_namespace, groot2)}
    checks["inputs"] = {"route": plan_or_route, "robot": robot}
    period_s, max_time_s = _options(rate, max_time, map_tolerance, plan, description, checks)
    return _watched_mission(
        lambda: connect(port, robot=description, faults=faults),
        plan,
        description,
        views=(foxglove, ros2, ros_domain_id, ros_namespace, groot2, observe),
        output=output,
        trace=trace,
        period_s=period_s,
        max_time_s=max_time_s,
        map_tolerance=map_tolerance,
        live=live,
        realtime=False,
        return_on_stop=False,
    )
