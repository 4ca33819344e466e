"""``pirate-bt demo``: the main job, a full inspection of the lab network on the simulator.

What ``make demo`` runs. With no robot attached it:

1. validates the bundled robot description, prints its board table and draws it
   (``robot.svg``);
2. plans ``scenarios/lab.route`` (entry to the top of the riser: five bends, two
   T-joints, inspections on the way) on ``scenarios/lab.yaml``;
3. runs it as one tree on the built-in simulator, on simulated time, with the
   live tree view on standard error (``--quiet`` hides it);
4. writes into the output folder: the trace (``trace.jsonl``), the tree diagram
   (``tree.svg``), the plots (``plot.png``, ``belief.png``) and the mission report
   (``report.md``, ``report.html``) with the robot's board table.

Exit codes as for ``pirate-bt mission``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pirate_bt.cli import said_path
from pirate_bt.cli.robot import format_table
from pirate_bt.render.files import write_diagram
from pirate_bt.resources import bundled, default_robot_path
from pirate_bt.robot.diagram import board_table, robot_graph
from pirate_bt.robot.loader import load_robot

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--output",
        type=Path,
        default=Path("demo-output"),
        metavar="DIR",
        help="folder for the outputs (default demo-output)",
    )
    parser.add_argument(
        "--robot", type=Path, metavar="FILE", help="robot description (default: bundled)"
    )
    parser.add_argument(
        "--route",
        type=Path,
        help="the route to run (default: the bundled lab.route)",
    )
    parser.add_argument("--seed", type=int, default=0, help="simulator random seed (default 0)")
    parser.add_argument("--faults", metavar="SPEC", help="simulator faults (see 'mission')")
    parser.add_argument("-q", "--quiet", action="store_true", help="no live view")
    parser.add_argument("--realtime", action="store_true", help="pace the run to wall time")


def run(args: argparse.Namespace) -> int:
    from pirate_bt.cli.mission import check_outputs_in, execute

    path = args.robot or default_robot_path()
    robot = load_robot(path)
    # bad input is refused before anything is printed or written: the route, and an
    # output folder that cannot be made or written in
    from pirate_bt.cli import check_folder_output
    from pirate_bt.filekinds import validate_file

    check_folder_output(args.output)  # not a folder named "-"
    # the run's options, as the API checks them, before the robot is drawn (a bad
    # --faults or --seed left demo-output/robot.svg and the board table behind)
    from pirate_bt.api.connection import check_fault_targets
    from pirate_bt.api.options import seed_value, split_faults
    from pirate_bt.cli.faults_option import check_faults_option

    seed_value(args.seed, "--seed")
    check_faults_option(args, robot)  # at its column: it said "faults: ..."
    check_fault_targets(split_faults(args.faults)[0], robot)

    route = args.route or bundled("scenarios", "lab.route")
    validate_file(route, "route")
    check_outputs_in(Path(args.output), trace_there=True, also=("robot.svg",))
    print(f"validated {path}: {robot.name}")
    print(
        f"state frame: {len(robot.state_channels())} channels;"
        f" setpoint frame: {len(robot.setpoint_slots())} motors"
    )
    table = format_table(board_table(robot))
    print(table)
    out: Path = args.output
    out.mkdir(parents=True, exist_ok=True)
    pictures: list[tuple[str, str]] = []
    try:
        written = write_diagram(robot_graph(robot), out / "robot.svg")
        print(f"drew {said_path(written)}")
        pictures.append(("The robot", written.name))
    except FileNotFoundError as exc:
        if exc.filename is not None:  # a file that cannot be written, not a missing Graphviz
            raise
        print(f"pirate-bt: {exc}", file=sys.stderr)
    mission_args = argparse.Namespace(
        route=str(route),
        sim=None,
        port=None,
        network=None,
        robot=str(path),
        seed=args.seed,
        faults=args.faults,
        output=out,
        quiet=args.quiet,
        plan=False,
        rate="20 Hz",
        max_time=None,
        realtime=args.realtime,
        debug=getattr(args, "debug", False),
    )
    sections = [("Robot boards", ["```text", *table.splitlines(), "```"])]
    outputs = execute(mission_args, extra_sections=sections, extra_pictures=pictures)
    if outputs.result is not None:
        run_result = outputs.result.run
        speedup = run_result.sim_time_s / outputs.wall_time_s if outputs.wall_time_s else 0.0
        print(
            f"demo: {run_result.sim_time_s:.0f} s of mission in {outputs.wall_time_s:.1f} s"
            f" ({speedup:.0f}x real time); report: {out / 'report.html'}"
        )
    return outputs.code
