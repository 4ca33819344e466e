"""``pirate-bt robot``: print a robot description's board table and draw it."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pirate_bt.robot.diagram import board_table, robot_graph, write_diagram
from pirate_bt.robot.loader import load_robot

_HEAD = ("board", "module", "motor 0", "motor 1", "sensor 0", "sensor 1")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", type=Path, help="robot description (default: bundled)")
    parser.add_argument("--draw", type=Path, metavar="OUT", help="draw to OUT (.dot/.svg/.png)")


def format_table(rows: list[tuple[str, ...]]) -> str:
    """Align rows under the DOMAIN.md headings."""
    table = [_HEAD, *rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(_HEAD))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)) for r in table]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(line.rstrip() for line in lines)


def run(args: argparse.Namespace) -> int:
    robot = load_robot(args.robot)
    print(f"{robot.name}: {len(robot.modules)} modules, {len(robot.boards)} boards")
    print(format_table(board_table(robot)))
    if args.draw:
        try:
            written = write_diagram(robot_graph(robot), args.draw)
        except FileNotFoundError as exc:
            print(f"pirate-bt: {exc}", file=sys.stderr)
            return 0
        print(f"drew {written}")
    return 0
