"""``pirate-bt demo``: the main job.

Today it does the most real thing the project can do without the simulator:
validate the bundled robot description, print its board table and draw it.
Later layers grow it into a full inspection run of the lab network.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pirate_bt.cli.robot import format_table
from pirate_bt.resources import default_robot_path
from pirate_bt.robot.diagram import board_table, robot_graph, write_diagram
from pirate_bt.robot.loader import load_robot


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--output", type=Path, default=Path("demo-output"), help="folder for the outputs"
    )
    parser.add_argument("--robot", type=Path, help="robot description (default: bundled)")


def run(args: argparse.Namespace) -> int:
    path = args.robot or default_robot_path()
    robot = load_robot(path)
    print(f"validated {path}: {robot.name}")
    print(
        f"state frame: {len(robot.state_channels())} channels;"
        f" setpoint frame: {len(robot.setpoint_slots())} motors"
    )
    print(format_table(board_table(robot)))
    out: Path = args.output
    try:
        written = write_diagram(robot_graph(robot), out / "robot.svg")
        print(f"drew {written}")
    except FileNotFoundError as exc:
        print(f"pirate-bt: {exc}", file=sys.stderr)
    return 0
