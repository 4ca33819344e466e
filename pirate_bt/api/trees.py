"""Run a behaviour tree on the simulator or a robot: :func:`simulate_tree`, :func:`run_tree`.

See :mod:`pirate_bt.api.running` for what a tree may be and how a run is supervised.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from pirate_bt.api.connection import connect
from pirate_bt.api.live import (
    FoxgloveOption,
    Groot2Option,
    Ros2Option,
    chain,
    check_live_options,
    foxglove_server,
    groot2_server,
    groot2_tree_observer,
    ros2_node,
    ros2_tree_observer,
    tree_observer,
)
from pirate_bt.api.options import (
    fault_list,
    file_name,
    flag,
    load_robot_like,
    port_url,
    run_limits,
    seed_value,
    split_faults,
)
from pirate_bt.api.process_run import one_run_in_process
from pirate_bt.api.results import RunResult, after_close
from pirate_bt.api.running import (
    Observer,
    as_loaded,
    check_run_options,
    check_trace,
    needs_robot,
    run_on,
)
from pirate_bt.errors import ArgumentTypeError, shown

__all__ = ["run_tree", "simulate_tree"]


@one_run_in_process("simulate_tree")
def simulate_tree(
    tree: Any,
    *,
    network: Any = "straight",
    params: Mapping[str, Any] | None = None,
    seed: int = 0,
    faults: str | Iterable[str] | None = None,
    trace: str | Path | None = None,
    robot: Any = None,
    max_time: str | float = "600 s",
    rate: str | float = "20 Hz",
    realtime: bool = False,
    live: bool = False,
    observe: Observer | None = None,
    foxglove: FoxgloveOption = None,
    ros2: Ros2Option = None,
    ros_domain_id: int | None = None,
    ros_namespace: str | None = None,
    groot2: Groot2Option = None,
    firmware: bool = False,
) -> RunResult:
    """Run a tree on the built-in simulator, to its end, and say why it ended.

    Args:
        tree: A tree file or bundled name (``"bend"``), a mapping, a ``LoadedTree``,
            or a ``py_trees`` behaviour built in Python.
        network: The pipe network the simulator runs: a bundled name (``"lab"``), a
            file, a ``NetworkSpec`` (an as-built variant from ``perturb_network``) or a
            ``Network``.
        params: The tree's parameters, as on the command line (``{"roll": "90 deg"}``;
            numbers are SI).
        seed: The simulator's seed (and the link faults').
        faults: ``"motor_stall:bend_3_drive@5s+20s"``, ``"drop=0.05,corrupt=0.01"``.
        trace: Write a tick-by-tick trace here (``.jsonl``, ``.jsonl.gz``, ``.mcap``).
        robot: The robot description (a loaded one, a file, or ``None``: bundled).
        max_time: Time limit on the run's clock (``"600 s"`` or seconds): above 0 and
            at most 1e9 s. ``nan`` and ``inf`` are refused (a run with no finite limit
            could run for ever): give a long limit instead.
        rate: Tick rate (``"20 Hz"`` or hertz): above 0, at most 1000 Hz, and a tick
            must come within ``max_time``.
        realtime: Pace the simulated run to wall time (to watch it).
        live: Draw the tree live on standard error.
        observe: ``observe(runner, connection)`` before the run: attach more hooks.
        foxglove: Serve the run live to Foxglove or Lichtblick (``"HOST:PORT"``, ``True``
            for 127.0.0.1:8765, or an open ``FoxgloveServer``, which stays open;
            docs/interop-foxglove.md). Needs the ``foxglove`` extra.
        ros2: Show the run on a ROS 2 graph over Zenoh (``"tcp/HOST:PORT"`` of a
            router, ``True`` for rmw_zenoh's default, or an open ``Ros2Node``); its
            ``estop`` topic e-stops the robot through the supervisor (docs/ros2.md).
        ros_domain_id: The ROS domain (default: ``ROS_DOMAIN_ID``, else 0).
        ros_namespace: The namespace of the node and its topics (default ``/pirate``).
        groot2: Serve the run live to Groot2 (``"HOST:PORT"``, a port, ``True`` for
            127.0.0.1:1667, or an open ``Groot2Server``; docs/interop-groot2.md).
        firmware: Run the physics behind the real firmwares in simavr (the bridge
            and a reference PICO per board, in virtual time) instead of the Python
            bridge; link faults only. Needs ``make firmware`` (docs/firmware-sim.md).

    Returns:
        RunResult: How the run ended and why; a failed run is a result, not an
            exception.

    Raises:
        ValidationFailed: the tree or a parameter does not validate (before anything
            connects).
        InputError: a malformed option or fault (checked before anything connects; one
            line naming the argument).
        LinkError: the simulator cannot be reached.

    Example::

        import pirate_bt
        result = pirate_bt.simulate_tree("bend", network="bend-right",
                                         params={"roll": "90 deg"},
                                         faults="motor_stall:bend_3_drive@5s+20s")
        print(result.status, result.why, result.failing_node)
    """
    run_limits(max_time, rate)
    check_run_options(trace=trace, realtime=realtime, live=live, observe=observe)
    check_live_options(foxglove, ros2, ros_domain_id, ros_namespace, groot2)
    seed = seed_value(seed)
    flag(firmware, "firmware")
    faults = fault_list(faults)  # a generator: read once, checked and then run
    split_faults(faults)
    if trace is not None:
        check_trace(trace, inputs={"tree": tree, "network": network, "robot": robot})
    if isinstance(network, str | Path):
        file_name(network, "network")
    else:
        from pirate_bt.pipes import Network, NetworkSpec

        if isinstance(network, NetworkSpec):  # perturb_network's, as simulate_mission's truth
            network = Network(network)
        if not isinstance(network, Network):
            raise ArgumentTypeError(
                "simulate_tree: network: give a bundled name, a network file or a Network"
                f" (pirate_bt.load_network; or its NetworkSpec), not {shown(network)}"
            )
    description = load_robot_like(robot)
    checked = as_loaded(tree, description, params)
    with (
        foxglove_server(foxglove) as server,
        ros2_node(ros2, domain_id=ros_domain_id, namespace=ros_namespace) as node,
        groot2_server(groot2) as groot2_view,
    ):
        options: dict[str, Any] = {
            "max_time": max_time,
            "rate": rate,
            "trace": trace,
            "realtime": realtime,
            "live": live,
            "observe": chain(
                tree_observer(server, description) if server else None,
                ros2_tree_observer(node, description) if node else None,
                groot2_tree_observer(groot2_view) if groot2_view else None,
                observe,
            ),
        }
        if not needs_robot(checked):
            # no simulator is started, but what it would have run on is still checked:
            # --sim /nonexistent.yaml or --faults bogus:x@1s were accepted, exit 0
            _check_world(network, faults, description)
            return run_on(None, checked, robot=description, **options)
        with connect(
            f"sim:{network}" if isinstance(network, str) else network,
            robot=description,
            seed=seed,
            faults=faults,
            firmware=firmware,
        ) as connection:
            connection.check_built_here(checked)  # no node commanding another robot
            result = run_on(connection, checked, count_from_open=True, **options)
        return after_close(result, connection.close_error)  # the robot stopped?


@one_run_in_process("run_tree")
def run_tree(
    tree: Any,
    *,
    port: str | Path,
    params: Mapping[str, Any] | None = None,
    faults: str | Iterable[str] | None = None,
    trace: str | Path | None = None,
    robot: Any = None,
    max_time: str | float = "600 s",
    rate: str | float = "20 Hz",
    live: bool = False,
    observe: Observer | None = None,
    foxglove: FoxgloveOption = None,
    ros2: Ros2Option = None,
    ros_domain_id: int | None = None,
    ros_namespace: str | None = None,
    groot2: Groot2Option = None,
) -> RunResult:
    """Run a tree on a real robot (a PIRATEbay bridge at ``port``), as :func:`simulate_tree`.

    Args:
        port: A serial port or pyserial URL (``"/dev/ttyACM0"``, ``"socket://host:7000"``).
        faults: Link faults only (``"drop=0.05"``), for testing a link.

    The other arguments are :func:`simulate_tree`'s. Runs on the wall clock. With
    ``groot2``, Groot2 may set breakpoints but not replace a node's result (refused
    against a robot), and a client that falls silent at a breakpoint ends the run in
    the safe state.

    Example::

        result = pirate_bt.run_tree("straight", port="/dev/ttyACM0",
                                    params={"distance": "1 m"})
        print(result.summary())
    """
    port = port_url(port)
    run_limits(max_time, rate)
    check_run_options(trace=trace, live=live, observe=observe)
    if trace is not None:
        check_trace(trace, inputs={"tree": tree, "robot": robot})
    check_live_options(foxglove, ros2, ros_domain_id, ros_namespace, groot2)
    faults = fault_list(faults)  # a generator: read once, checked and then run
    split_faults(faults)
    description = load_robot_like(robot)
    checked = as_loaded(tree, description, params)
    with (
        foxglove_server(foxglove) as server,
        ros2_node(ros2, domain_id=ros_domain_id, namespace=ros_namespace) as node,
        groot2_server(groot2) as groot2_view,
        connect(port, robot=description, faults=faults) as connection,
    ):
        connection.check_built_here(checked)  # no node commanding another robot
        result = run_on(
            connection,
            checked,
            max_time=max_time,
            rate=rate,
            trace=trace,
            live=live,
            observe=chain(
                tree_observer(server, description) if server else None,
                ros2_tree_observer(node, description) if node else None,
                groot2_tree_observer(groot2_view) if groot2_view else None,
                observe,
            ),
            count_from_open=True,
        )
    return after_close(result, connection.close_error)  # the robot stopped?


def _check_world(network: Any, faults: Any, robot: Any) -> None:
    """The network and the faults a simulated run would use, checked as a run does.

    Raises:
        InputError: the network cannot be loaded, or a fault is malformed or names
            a motor, channel or board the robot does not have.
    """
    from pirate_bt.link.faults import parse_fault_spec
    from pirate_bt.pipes import Network, load_network
    from pirate_bt.sim.faults import check_fault_target, parse_fault

    if not isinstance(network, Network):
        load_network(network)
    physics, link = split_faults(faults)
    for text in physics:
        check_fault_target(parse_fault(text), robot)
    if link:
        parse_fault_spec(link)
