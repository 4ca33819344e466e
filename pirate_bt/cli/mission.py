"""``pirate-bt mission ROUTE``: plan a route on its network and run it.

The route is parsed and planned on the map first (exit 2 with
``file:line:column`` when it is malformed or does not fit the map); then it runs
as one tree on the built-in simulator or on a robot (``--port URL``). The map is
``--network MAP`` or the route's ``network`` line (or ``--sim`` when neither is
given); the simulator runs ``--sim TRUTH`` (default: the map). With a TRUTH
other than the map (``pirate-bt network perturb``), the mission plans on a
drawing and runs on the pipe as built. With ``--output DIR`` the trace, the
tree diagram, the plots and the mission report are written there. Exit codes:
0 the mission succeeded; 1 it failed and the robot was left in its safe state;
2 invalid input (and a report that cannot be written after a mission that
succeeded; after one that failed, its own code stands); 3 link error.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from pirate_bt.cli import said_path
from pirate_bt.errors import InputError
from pirate_bt.units import parse_quantity

__all__ = ["MissionOutputs", "configure", "execute", "run"]


def check_outputs_in(folder: Path, *, trace_there: bool, also: tuple[str, ...] = ()) -> None:
    """Check a mission's ``--output`` folder before anything is planned or run: its
    report as ``-o`` checks a file (a folder that takes no file), and each other file it
    writes there (``also``: the caller's own) for a named pipe, which was waited on for
    ever at the end (``plot.png``), or refused as the API's ``trace: DIR/trace.jsonl
    ...``, an option nobody typed. A picture that cannot be written otherwise (a folder
    in its place) is said after the run, which it does not fail.

    Raises:
        InputError: the report cannot be written, or a file is a named pipe or a socket.
    """
    from pirate_bt.api.mission_outputs import OUTPUT_NAMES
    from pirate_bt.cli import check_output, refuse_pipe

    check_output(folder / "report.md", "--output")
    traced = ("trace.jsonl",) if trace_there else ()
    for name in (*also, *traced, *OUTPUT_NAMES):
        refuse_pipe(folder / name, "--output")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("route", metavar="ROUTE", help="the route file (.route)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="run the built-in simulator in this network, the truth (default: the map)",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial port or pyserial URL")
    parser.add_argument(
        "--firmware-chain",
        action="store_true",
        help="with the simulator: run its physics behind the real firmwares in simavr (the"
        " bridge and a reference PICO per board, virtual time; needs `make firmware`)",
    )
    parser.add_argument(
        "--network",
        metavar="MAP",
        help="the map the mission plans on (default: the route's network line)",
    )
    parser.add_argument(
        "--map-tolerance",
        default="10%",
        metavar="FRACTION",
        help="how far the map's lengths may be off, per metre from the last feature"
        " (default 10%%; 0 for a map known to be exact)",
    )
    parser.add_argument("--robot", metavar="FILE", help="robot description (default: bundled)")
    parser.add_argument("--seed", type=int, default=0, help="simulator random seed (default 0)")
    parser.add_argument(
        "--faults",
        metavar="SPEC",
        help="simulator faults KIND[:TARGET]@AT[+DURATION] and link faults KEY=VALUE,"
        " comma-separated, e.g. motor_stall:bend_1_drive@30s+5s,drop=0.05",
    )
    parser.add_argument("--output", type=Path, metavar="DIR", help="write trace, plots, report")
    parser.add_argument(
        "--trace",
        type=Path,
        metavar="FILE",
        help="write the trace here (.jsonl, .jsonl.gz or .mcap) instead of DIR/trace.jsonl",
    )
    from pirate_bt.interop.foxglove_option import add_foxglove_option

    add_foxglove_option(parser)
    from pirate_bt.interop.ros2_option import add_ros2_options

    add_ros2_options(parser)
    from pirate_bt.interop.groot2_option import add_groot2_option

    add_groot2_option(parser)
    parser.add_argument("-q", "--quiet", action="store_true", help="no live view, no plan")
    parser.add_argument("--plan", action="store_true", help="print the plan and stop")
    parser.add_argument("--rate", default="20 Hz", metavar="FREQ", help="tick rate (default 20 Hz)")
    parser.add_argument("--max-time", metavar="TIME", help="time limit (default: from the plan)")
    parser.add_argument("--realtime", action="store_true", help="pace a simulated run to wall time")


@dataclass
class MissionOutputs:
    """What :func:`execute` produced.

    Attributes:
        code: The exit code.
        result: The mission result (``None`` with ``--plan``).
        files: Files written into the output folder.
        wall_time_s: Wall time of the run.
    """

    code: int
    result: Any = None
    files: tuple[Path, ...] = ()
    wall_time_s: float = 0.0


def _quantity(text: str, dimension: str, option: str) -> float:
    try:
        return parse_quantity(text, dimension)
    except InputError as exc:
        raise InputError(f"{option}: {exc}") from None


def _fraction(text: str, option: str) -> float:
    body = str(text).strip()
    try:
        value = float(body[:-1]) / 100.0 if body.endswith("%") else float(body)
    except ValueError:
        raise InputError(f"{option}: {text!r} is not a fraction (write e.g. 10% or 0.1)") from None
    if not 0.0 <= value < 1.0:
        raise InputError(f"{option}: {text!r} must be at least 0 and below 100%")
    return value


def _outputs_not_inputs(args: argparse.Namespace, inputs: dict[str, object]) -> None:
    """``--output DIR`` never writes over the mission's own files, before the run.

    Raises:
        InputError: a file the mission writes in ``DIR`` is one of ``inputs``.
    """
    from pirate_bt.api.mission_outputs import outputs_not_inputs

    there = not getattr(args, "trace", None)
    outputs_not_inputs(args.output, "--output", dict(inputs), trace_there=there)


def execute(
    args: argparse.Namespace,
    *,
    out: TextIO | None = None,
    extra_sections: list[tuple[str, list[str]]] | None = None,
    extra_pictures: list[tuple[str, str]] | None = None,
    live: bool | None = None,
) -> MissionOutputs:
    """Plan and run a mission from parsed command-line arguments (shared with ``demo``).

    Raises:
        InputError: a malformed route, a route that does not fit, a bad option.
        LinkError: cannot reach the robot.
    """
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.task.planner import load_network_for, plan_route
    from pirate_bt.task.route import load_route

    stream = out or sys.stdout
    rate_hz = _quantity(args.rate, "frequency", "--rate")
    max_time_s = None
    if args.max_time is not None:  # as the API takes it: 0 s, -5 s and 1e300 s were
        # refused as 'max_time' after the whole plan (or, -5 s, as a rate too high)
        from pirate_bt.api.options import NO_LIMIT, positive_time_s

        max_time_s = positive_time_s(args.max_time, "--max-time", instead=NO_LIMIT)
    if rate_hz <= 0:
        raise InputError("--rate must be positive")
    from pirate_bt.cli import check_folder_output
    from pirate_bt.cli.run import check_firmware_chain, check_rate, check_trace_path, live_outputs

    check_folder_output(args.output)  # not a folder named "-"
    if getattr(args, "trace", None) is not None:
        check_trace_path(str(args.trace))  # before planning and connecting
    if args.output is not None and not args.plan:
        # named --output, not "trace" (DIR/trace.jsonl was the first path checked)
        from pirate_bt.api.options import output_folder

        output_folder(args.output, "--output")
        check_outputs_in(Path(args.output), trace_there=getattr(args, "trace", None) is None)
    tolerance = _fraction(getattr(args, "map_tolerance", "10%"), "--map-tolerance")
    robot = load_robot(args.robot)
    # the run's options, as the API checks them, before the plan is printed (a bad
    # --faults or --seed was refused after the whole plan, on stdout, exit 2)
    from pirate_bt.api.connection import check_fault_targets
    from pirate_bt.api.options import find, seed_value, split_faults
    from pirate_bt.cli.faults_option import check_faults_option

    seed_value(args.seed, "--seed")
    check_firmware_chain(args)  # with --port: it was refused after the whole plan
    if args.port is not None:  # its URL's scheme: it was refused after the whole plan
        from pirate_bt.api.options import port_url

        port_url(args.port)  # named --port as typed by the command line
    check_faults_option(args, robot)  # at its column: it said "faults: ..."
    check_fault_targets(split_faults(args.faults)[0], robot)

    # "lab" is the bundled lab.route, as for load_route (not the network lab.yaml)
    route = load_route(find("scenarios", args.route, ".route", "route"))
    map_name = getattr(args, "network", None) or (None if route.network else args.sim)
    network = load_network_for(route, map_name, option="--network" if map_name else "--sim")
    truth = network
    if args.sim not in (None, map_name, route.network):
        truth = load_network_for(route, args.sim, option="--sim")
    if args.output is not None and not args.plan:
        _outputs_not_inputs(
            args,
            {
                "route": route.source,
                "network": network.source,
                "simulated network": truth.source,
                "robot description": args.robot,
            },
        )
    plan = plan_route(route, network, robot)
    from pirate_bt.task.mission import estimate_time_s

    limit_s = max_time_s or estimate_time_s(plan, robot.motion.nominal_speed)
    check_rate(rate_hz, limit_s, "--rate", args.max_time or "the plan's time limit")

    def show_plan() -> None:
        if not args.quiet or args.plan:
            on = f" (simulator: {truth.name})" if truth is not network else ""
            print(
                f"route {route.source} on map {network.name}{on}: {len(plan.pabs)}"
                f" PAB{'' if len(plan.pabs) == 1 else 's'},"
                f" {plan.distance_m:.2f} m",
                file=stream,
            )
            for line in plan.describe():
                print(f"  {line}", file=stream)

    if args.plan:
        show_plan()
        return MissionOutputs(0)
    output: Path | None = args.output
    trace_path = output / "trace.jsonl" if output is not None else None
    if getattr(args, "trace", None) is not None:
        trace_path = args.trace
    from pirate_bt.api.missions import run_mission, simulate_mission, write_mission_outputs

    with live_outputs(args) as (server, node, groot2):  # opened before the plan is shown:
        show_plan()  # an --foxglove host that does not resolve was refused after it
        options: dict[str, Any] = {
            "faults": args.faults,
            "trace": trace_path,
            "robot": robot,
            "max_time": max_time_s,
            "rate": rate_hz,
            "map_tolerance": tolerance,
            "live": (not args.quiet) if live is None else live,
            "foxglove": server,
            "ros2": node,
            "groot2": groot2,
        }
        started = time.perf_counter()
        if args.port is not None:
            result = run_mission(plan, port=args.port, **options)
        else:
            result = simulate_mission(
                plan,
                truth=truth,
                seed=args.seed,
                realtime=args.realtime,
                firmware=getattr(args, "firmware_chain", False),
                **options,
            )
    wall = time.perf_counter() - started
    files: list[Path] = []
    summary = result.summary(wall_s=wall)
    if output is not None:
        try:
            files = write_mission_outputs(
                result,
                output,
                wall_s=wall,
                extra_sections=extra_sections or [],
                extra_pictures=extra_pictures or [],
                warn=lambda text: print(f"pirate-bt: {text}", file=sys.stderr),
                option="--output",
            )
        except InputError as exc:  # the report: the mission's own line first, its code
            # (a full disk said "No space left on device" alone, the mission unsaid, exit 2)
            stream.flush()
            print(f"pirate-bt: {summary}", file=sys.stderr)
            print(f"pirate-bt: {exc}", file=sys.stderr)
            return MissionOutputs(
                exc.exit_code if result.succeeded else result.exit_code, result, (), wall
            )
    for note in (*result.replans, *result.map_notes):
        print(f"pirate-bt: {note}", file=sys.stderr)
    if result.succeeded:
        print(summary, file=stream)
        code = 0
    else:
        print(f"pirate-bt: {summary}", file=sys.stderr)
        code = result.exit_code  # 3: a lost link, or a close that left it moving
    for path in files:
        print(f"wrote {said_path(path)}", file=stream)
    return MissionOutputs(code, result, tuple(files), wall)


def run(args: argparse.Namespace) -> int:
    return execute(args).code
