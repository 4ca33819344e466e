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
import importlib
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
        description: One line for people (``simulator: straight.yaml``).
    """

    clock: Clock
    supervisor: Any = None
    close: Callable[[], None] = field(default=lambda: None)
    description: str = "no robot"


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


def _resolve(ref: str) -> Any:
    module_name, _, attr = ref.partition(":")
    return getattr(importlib.import_module(module_name), attr)


def split_faults(text: str | None) -> tuple[list[str], str | None]:
    """Split ``--faults`` into simulator faults and a link fault spec.

    Items are separated by ``;`` or whitespace. An item with ``@`` is a simulator
    fault (``motor_stall:bend_3_drive@5s+2s``); the others are link byte faults
    (``drop=0.05,corrupt=0.01``), joined into one spec for the host side.

    Returns:
        ``(simulator faults, link fault spec or None)``.
    """
    sim_faults: list[str] = []
    link_parts: list[str] = []
    for item in (text or "").replace(";", " ").split():
        (sim_faults if "@" in item else link_parts).append(item)
    return sim_faults, (",".join(link_parts) or None)


def connect(args: argparse.Namespace, robot: Any, needs_robot: bool) -> Connection:
    """Open the simulator or the robot link and the supervisor, as the tree needs.

    This is the one place where ``pirate-bt run`` reaches below the tree layer. With
    ``--port`` it opens ``pirate_bt.link.open_link(url, robot, clock)`` on a wall
    clock. Otherwise it starts an in-process ``pirate_bt.sim.Simulator`` on the
    network ``--sim`` (a file or a bundled name; default ``straight``) on a
    simulated clock, with the simulator faults of ``--faults`` (``KIND:TARGET@AT``),
    and reaches it through the same link (``sim://NAME``) with the link faults of
    ``--faults`` (``drop=0.05,corrupt=0.01``; seeded from ``--seed``). Either way
    the port is wrapped in ``pirate_bt.safety.supervisor.Supervisor(port, clock)``
    once its first state has arrived.

    Raises:
        LinkError: the tree needs a robot and none can be reached.
        InputError: a malformed fault.
    """
    simulated = args.port is None
    clock: Clock = SimClock() if simulated else WallClock()
    if not needs_robot:
        return Connection(clock=clock, description="no robot needed by this tree")
    closers: list[Callable[[], None]] = []

    def close() -> None:
        for closer in reversed(closers):
            closer()

    try:
        from pirate_bt.safety.factory import wait_for_state
        from pirate_bt.safety.supervisor import Supervisor

        open_link = _resolve("pirate_bt.link:open_link")
        if simulated:
            assert isinstance(clock, SimClock)
            simulator_cls = _resolve("pirate_bt.sim:Simulator")
            sim_faults, link_faults = split_faults(args.faults)
            if link_faults is not None and "seed=" not in link_faults:
                link_faults += f",seed={args.seed}"
            network = args.sim or "straight"
            sim = simulator_cls(network, robot, seed=args.seed, clock=clock, faults=sim_faults)
            closers.append(sim.close)
            port = open_link(sim.url, robot, clock, faults=link_faults)
            what = f"simulator: {network}"
        else:
            port = open_link(args.port, robot, clock)
            what = f"robot at {args.port}"
        closers.append(port.close)
        wait_for_state(port, clock, 5.0)
    except (ImportError, AttributeError) as exc:
        close()
        part = "simulator" if simulated else "link"
        raise LinkError(
            f"cannot connect: this tree needs a robot, but the {part} is not available ({exc})"
        ) from None
    except BaseException:
        close()
        raise
    supervisor = Supervisor(port, clock)
    return Connection(clock=clock, supervisor=supervisor, close=close, description=what)


def run(args: argparse.Namespace) -> int:
    from pirate_bt.behaviours.base import BuildContext
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.runner import Runner, StopReason
    from pirate_bt.treefile import build, load_tree

    max_time_s = _quantity(args.max_time, "time", "--max-time")
    rate_hz = _quantity(args.rate, "frequency", "--rate")
    if rate_hz <= 0 or max_time_s <= 0:
        raise InputError("--rate and --max-time must be positive")
    params = parse_params(args.param)
    robot = load_robot(args.robot)
    # Check the tree (exit 2) before connecting; build it on the run's clock after.
    checked = load_tree(args.tree, robot=robot, params=params, params_from_text=True)
    connection = connect(args, robot, checked.needs_robot)
    try:
        context = BuildContext(
            robot=robot, clock=connection.clock, supervisor=connection.supervisor
        )
        tree = dataclasses.replace(checked, root=build(checked.spec, context))
        supervisor = connection.supervisor
        runner = Runner(
            tree,
            clock=connection.clock,
            period_s=1.0 / rate_hz,
            max_time_s=max_time_s,
            realtime=args.realtime,
            safe_state=(
                (lambda: supervisor.safe_state("tree run ended without success"))
                if supervisor is not None
                else None
            ),
        )
        if supervisor is not None:
            runner.add_pre_tick(lambda _info: supervisor.tick())
        result = runner.run()
    finally:
        connection.close()
    summary = (
        f"{tree.name}: {result.outcome.upper()} - {result.message}"
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
