"""``pirate-bt run TREE``: run a behaviour tree against the simulator or a robot.

The tree is loaded and checked against the robot description first (exit 2 on
any problem). Connecting goes through one function, :func:`connect`, which
imports the simulator, the link and the safety supervisor only when the tree
needs a robot: a tree of generic leaves runs on a simulated clock with nothing
attached. Exit codes: 0 the tree succeeded; 1 it failed, timed out, raised or
was interrupted, and the robot was left in its safe state; 2 invalid input;
3 link error (cannot connect, link lost).
"""

from __future__ import annotations

import argparse
import dataclasses
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pirate_bt.clock import Clock, SimClock, WallClock
from pirate_bt.errors import InputError, LinkError, UnitError
from pirate_bt.units import parse_quantity


@dataclass
class Connection:
    """What :func:`connect` hands the runner.

    Attributes:
        clock: The clock the tree and the runner read.
        supervisor: The safety supervisor (``None`` when no robot is attached).
        close: Releases the link and the simulator.
        description: One line for people (``simulator: straight``).
    """

    clock: Clock
    supervisor: Any = None
    close: Callable[[], None] = field(default=lambda: None)
    description: str = "no robot"

    @property
    def simulator(self) -> Any:
        """The in-process simulator behind the supervisor, if simulated (else ``None``)."""
        return getattr(self.supervisor, "simulator", None)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("tree", metavar="TREE", help="the tree file (YAML)")
    parser.add_argument("--robot", metavar="FILE", help="robot description (default: bundled)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="run against the built-in simulator in this pipe network (the default)",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial port or pyserial URL")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a tree parameter, e.g. --param roll=90deg (repeatable)",
    )
    parser.add_argument("--seed", type=int, default=0, help="simulator random seed (default 0)")
    parser.add_argument("--faults", metavar="SPEC", help="simulator fault injection")
    parser.add_argument(
        "--max-time", default="600 s", metavar="TIME", help="time limit (default 600 s)"
    )
    parser.add_argument("--rate", default="20 Hz", metavar="FREQ", help="tick rate (default 20 Hz)")
    parser.add_argument("--realtime", action="store_true", help="pace a simulated run to wall time")
    parser.add_argument(
        "--trace", metavar="FILE", help="write a tick-by-tick trace (.jsonl, .jsonl.gz or .mcap)"
    )
    parser.add_argument("--quiet", action="store_true", help="no live view of the tree")
    from pirate_bt.interop.foxglove_option import add_foxglove_option

    add_foxglove_option(parser)


def _quantity(text: str, dimension: str, option: str) -> float:
    try:
        return parse_quantity(text, dimension)
    except UnitError as exc:
        raise InputError(f"{option}: {exc}") from None


def parse_params(items: list[str]) -> dict[str, str]:
    """``["roll=90 deg"]`` → ``{"roll": "90 deg"}``.

    Raises:
        InputError: an item is not ``key=value``.
    """
    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--param {item!r}: write key=value, e.g. --param roll=90deg")
        out[key.strip()] = value.strip()
    return out


def split_faults(text: str | None) -> tuple[list[str], str | None]:
    """Split ``--faults`` into simulator faults and a link fault spec.

    Items are separated by ``,``, ``;`` or whitespace. An item with ``@`` is a
    simulator fault (``motor_stall:bend_3_drive@5s+2s``); the others are link byte
    faults (``drop=0.05``, ``corrupt=0.01``), joined into one spec for the host side.
    So ``motor_stall:bend_1_drive@30s+5s,drop=0.05,corrupt=0.01`` gives both kinds.

    Returns:
        ``(simulator faults, link fault spec or None)``.
    """
    sim_faults: list[str] = []
    link_parts: list[str] = []
    for item in re.split(r"[,;\s]+", text or ""):
        if item:
            (sim_faults if "@" in item else link_parts).append(item)
    return sim_faults, (",".join(link_parts) or None)


def connect(
    args: argparse.Namespace, robot: Any, needs_robot: bool, network: Any = None
) -> Connection:
    """Open the simulator or the robot behind the supervisor, as the tree needs.

    This is the one place where ``pirate-bt run`` reaches below the tree layer, and
    it does so only through the protective layer's factory,
    :func:`pirate_bt.safety.factory.open_supervisor`, which opens the link itself.
    With ``--port`` the robot is reached on a wall clock. Otherwise an in-process
    simulator runs the network ``--sim`` (a file or a bundled name; default
    ``straight``) on a simulated clock, with the simulator faults of ``--faults``
    (``KIND:TARGET@AT``) and the link faults (``drop=0.05,corrupt=0.01``, seeded
    from ``--seed``) on the host side of the same wire protocol.

    Args:
        args: The parsed options (``sim``, ``port``, ``seed``, ``faults``).
        robot: The robot description.
        needs_robot: Whether the tree commands a robot at all.
        network: The simulator's network (a ``Network`` or a name), overriding
            ``--sim``; a mission passes the map it planned on.

    Raises:
        LinkError: the robot cannot be reached.
        InputError: a malformed fault, or simulator faults with ``--port``.
    """
    simulated = args.port is None
    clock: Clock = SimClock() if simulated else WallClock()
    if not needs_robot:
        return Connection(clock=clock, description="no robot needed by this tree")
    from pirate_bt.safety.factory import open_supervisor

    sim_faults, link_faults = split_faults(args.faults)
    options: dict[str, Any] = {}
    if link_faults is not None:
        options["faults"] = (
            link_faults if "seed=" in link_faults else f"{link_faults},seed={args.seed}"
        )
    if simulated:
        network = network if network is not None else (args.sim or "straight")
        supervisor = open_supervisor(
            robot, clock=clock, network=network, seed=args.seed, sim_faults=sim_faults, **options
        )
        what = f"simulator: {getattr(network, 'name', network)}"
    else:
        if sim_faults:
            raise InputError(
                "--faults: simulator faults (KIND:TARGET@AT) need the simulator, not --port"
            )
        supervisor = open_supervisor(robot, url=args.port, clock=clock, **options)
        what = f"robot at {args.port}"
    return Connection(
        clock=clock,
        supervisor=supervisor,
        close=supervisor.close,
        description=what,
    )


def _safe_state(supervisor: Any) -> None:
    """Safe state at the end of a failed run, keeping the reason a PAB gave first."""
    reason = supervisor.safe_state_reason if supervisor.in_safe_state else None
    supervisor.safe_state(reason or "tree run ended without success")


def open_foxglove(args: argparse.Namespace) -> Any:
    """The Foxglove server of ``--foxglove [HOST:PORT]``, or ``None`` without the option.

    Raises:
        InputError: a bad address, or the port is taken.
        ConfigurationError: the ``foxglove`` extra is missing.
    """
    if getattr(args, "foxglove", None) is None:
        return None
    from pirate_bt.interop.foxglove_live import FoxgloveServer, parse_address

    host, port = parse_address(args.foxglove)
    server = FoxgloveServer(host, port)
    print(f"pirate-bt: Foxglove live view on {server.url}", file=sys.stderr)
    return server


def _observe(
    runner: Any,
    args: argparse.Namespace,
    robot: Any,
    connection: Connection,
    foxglove: Any = None,
) -> None:
    """Attach the live view (unless ``--quiet``), the trace (``--trace``), Foxglove."""
    from pirate_bt.trace import attach_live_view, attach_trace, supervised_extras

    attach_live_view(runner, quiet=args.quiet)
    if foxglove is not None:
        from pirate_bt.interop.foxglove_live import attach_foxglove

        sim = connection.simulator
        attach_foxglove(
            runner,
            foxglove,
            extras=supervised_extras(
                connection.supervisor, counters=sim.counters if sim is not None else None
            )
            if connection.supervisor is not None
            else None,
            robot=robot,
            scenario=(args.sim or "straight") if args.port is None else args.port,
            seed=args.seed if args.port is None else None,
        )
    if not args.trace:
        return
    extras = None
    supervisor, simulator = connection.supervisor, connection.simulator
    if supervisor is not None:
        extras = supervised_extras(
            supervisor, counters=simulator.counters if simulator is not None else None
        )
    attach_trace(
        runner,
        args.trace,
        extras=extras,
        robot=robot,
        scenario=(args.sim or "straight") if args.port is None else args.port,
        seed=args.seed if args.port is None else None,
    )


def run_tree(
    checked: Any,
    robot: Any,
    connection: Connection,
    *,
    period_s: float,
    max_time_s: float,
    realtime: bool = False,
    observe: Callable[[Any], None] | None = None,
) -> tuple[Any, Any]:
    """Build a checked tree on the connection's clock and run it to its end.

    Shared by ``pirate-bt run`` and campaigns. A failed run is a result, not an
    exception; the caller closes the connection.

    Args:
        checked: The loaded tree (``load_tree``), not yet built.
        robot: The robot description.
        connection: What :func:`connect` returned.
        period_s: Tick period.
        max_time_s: Time limit on the run's clock.
        realtime: Pace a simulated run to wall time.
        observe: Called with the runner before it runs (live view, trace).

    Returns:
        ``(the built tree, the runner's RunResult)``.
    """
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.runner import Runner
    from pirate_bt.treefile import build

    context = BuildContext(robot=robot, clock=connection.clock, supervisor=connection.supervisor)
    tree = dataclasses.replace(checked, root=build(checked.spec, context))
    supervisor = connection.supervisor
    runner = Runner(
        tree,
        clock=connection.clock,
        period_s=period_s,
        max_time_s=max_time_s,
        realtime=realtime,
        safe_state=(lambda: _safe_state(supervisor)) if supervisor is not None else None,
        paused=(lambda: bool(supervisor.tree_paused)) if supervisor is not None else None,
    )
    if supervisor is not None:
        runner.add_pre_tick(lambda _info: supervisor.tick())
    if observe is not None:
        observe(runner)
    return tree, runner.run()


def run(args: argparse.Namespace) -> int:
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.runner import StopReason
    from pirate_bt.treefile import load_tree

    max_time_s = _quantity(args.max_time, "time", "--max-time")
    rate_hz = _quantity(args.rate, "frequency", "--rate")
    if rate_hz <= 0 or max_time_s <= 0:
        raise InputError("--rate and --max-time must be positive")
    params = parse_params(args.param)
    robot = load_robot(args.robot)
    # Check the tree (exit 2) before connecting; build it on the run's clock after.
    from pirate_bt.resources import find_file

    tree_path = find_file("trees", args.tree)
    checked = load_tree(tree_path, robot=robot, params=params, params_from_text=True)
    foxglove = open_foxglove(args)
    try:
        connection = connect(args, robot, checked.needs_robot)
        try:
            tree, result = run_tree(
                checked,
                robot,
                connection,
                period_s=1.0 / rate_hz,
                max_time_s=max_time_s,
                realtime=args.realtime,
                observe=lambda runner: _observe(runner, args, robot, connection, foxglove),
            )
        finally:
            connection.close()
    finally:
        if foxglove is not None:
            foxglove.close()
    why = result.message
    if connection.supervisor is not None and connection.supervisor.safe_state_reason:
        why = f"{result.message}: {connection.supervisor.safe_state_reason}"
    summary = (
        f"{tree.name}: {result.outcome.upper()} - {why}"
        f" ({connection.description}; {result.ticks} ticks, {result.sim_time_s:.2f} s clock,"
        f" {result.wall_time_s:.2f} s wall"
        + (f", {result.overrun_count} tick overruns" if result.overrun_count else "")
        + ")"
    )
    if result.succeeded:
        print(summary)
        return 0
    print(f"pirate-bt: {summary}", file=sys.stderr)
    if result.reason is StopReason.EXCEPTION and result.traceback and args.debug:
        print(result.traceback, file=sys.stderr)
    return 3 if isinstance(result.error, LinkError) else 1
