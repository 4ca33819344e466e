"""``pirate-bt robot``: print a robot description's board table and draw it.

``pirate-bt robot header ROBOT.yaml -o layout.h`` writes the robot's wire layout
as the C header the PIRATEbay firmware is built with (``firmware/piratebay/``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pirate_bt.cli import STDOUT, said_path, stdout_open
from pirate_bt.errors import InputError
from pirate_bt.render.files import write_diagram
from pirate_bt.robot.diagram import board_table, robot_graph
from pirate_bt.robot.loader import load_robot

__all__ = ["configure", "format_table", "run"]

_HEAD = ("board", "module", "motor 0", "motor 1", "sensor 0", "sensor 1")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", type=Path, help="robot description (default: bundled)")
    parser.add_argument("--draw", type=Path, metavar="OUT", help="draw to OUT (.dot/.svg/.png)")
    actions = parser.add_subparsers(dest="action", metavar="ACTION")
    header = actions.add_parser(
        "header", help="write the wire layout as a C header for the bridge firmware"
    )
    header.add_argument("description", type=Path, nargs="?", help="robot description")
    header.add_argument(
        "-o",
        "--output",
        type=Path,
        metavar="OUT",
        help="header file (default, or '-': standard output)",
    )


def format_table(rows: list[tuple[str, ...]]) -> str:
    """Align rows under the DOMAIN.md headings."""
    table = [_HEAD, *rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(_HEAD))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)) for r in table]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(line.rstrip() for line in lines)


def _header(args: argparse.Namespace) -> int:
    from pirate_bt.robot.header import render_header, write_header

    path = args.description or args.robot
    if path is not None:
        from pirate_bt.filekinds import validate_file

        # as `pirate-bt validate` checks it, the frames' fit included: a robot the wire
        # protocol cannot carry got a header, then a C static assertion in the build
        robot = validate_file(path, "hardware")
    else:
        robot = load_robot(path)
    source = str(path) if path is not None else "the bundled robot description"
    if args.output is None or str(args.output) == STDOUT:  # "-" was a file named "-"
        stdout_open("the header")
        sys.stdout.write(render_header(robot, source))
    else:
        from pirate_bt.api.options import not_an_input
        from pirate_bt.cli import check_output
        from pirate_bt.resources import default_robot_path

        check_output(args.output)
        # header r.yaml -o r.yaml replaced the robot description with C, exit 0
        described = path if path is not None else default_robot_path()
        not_an_input(args.output, "-o", {"robot description": described})
        write_header(robot, args.output, source)
        print(
            f"wrote {said_path(args.output)}"
        )  # the path written, on stdout as every command says it
    return 0


def run(args: argparse.Namespace) -> int:
    if getattr(args, "action", None) == "header":
        # each was dropped without a word: no drawing, or the other description's header
        if args.draw is not None:
            raise InputError(
                "--draw: 'robot header' draws nothing; run 'pirate-bt robot --draw OUT' on its own"
            )
        if args.robot is not None and args.description is not None:
            raise InputError(
                f"two robot descriptions ({args.robot} by --robot, {args.description} after"
                " header): give one"
            )
        return _header(args)
    robot = load_robot(args.robot)
    if not args.draw:  # the table is the output (with --draw, the drawing is)
        stdout_open("the board table")  # >&-: it went nowhere, exit 0
    if args.draw:
        from pirate_bt.cli.render import check_diagram

        check_diagram(args.draw, "--draw")  # before the table: nothing printed for bad input
        from pirate_bt.api.options import not_an_input
        from pirate_bt.resources import default_robot_path

        # a description named r.dot was replaced by the drawing's source, exit 0
        described = {"robot description": args.robot or default_robot_path()}
        for drawn in dict.fromkeys((args.draw, args.draw.with_suffix(".dot"))):
            not_an_input(drawn, "--draw", described)
    print(f"{robot.name}: {len(robot.modules)} modules, {len(robot.boards)} boards")
    print(format_table(board_table(robot)))
    if args.draw:
        try:
            written = write_diagram(robot_graph(robot), args.draw)
        except FileNotFoundError as exc:
            if exc.filename is not None:  # a file that cannot be written, not a missing Graphviz
                raise
            print(f"pirate-bt: {exc}", file=sys.stderr)
            return 0
        except ValueError as exc:
            raise InputError(f"--draw {args.draw}: {exc}") from None
        print(f"drew {said_path(written)}")
    return 0
