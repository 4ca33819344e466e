"""``pirate-bt survey``: map a network nobody has drawn, and write it as a network file.

The command parses, calls :func:`pirate_bt.survey` and prints: one line per
decision (unless ``--quiet``) and the survey's summary. ``--extend SURVEYED`` is a
second insertion into the first branch a survey left as a stub. Exit codes: 0 every line
surveyed to where it ends, 1 the survey stopped (robot left safe) or left branches
unsurveyed (named; what was surveyed is written), 2 bad input, 3 link error.
"""

from __future__ import annotations

import argparse
import sys

from pirate_bt.errors import InputError

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    from pirate_bt.cli import utf8_text
    from pirate_bt.cli.navigate import stepwise_options

    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="the simulator in this network, the truth (default: the simulator, in 'straight')",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial port or pyserial URL")
    parser.add_argument(
        "-o", "--output", metavar="FILE", required=True, help="where to write the network (.yaml)"
    )
    parser.add_argument(
        "--name", default="surveyed", type=utf8_text, help="the network's name (default surveyed)"
    )
    parser.add_argument(
        "--extend",
        metavar="SURVEYED",
        help="a second insertion: drive to the first branch this surveyed network left as a"
        " stub, survey it and write the network with it filled in (-o may name the same file)",
    )
    parser.add_argument(
        "--search",
        default="3 m",
        metavar="LENGTH",
        help="how far one straight step drives before it looks again (default 3 m)",
    )
    parser.add_argument(
        "--radius",
        default="90 mm",
        metavar="LENGTH",
        help="the bends' radius, assumed (default 90 mm)",
    )
    stepwise_options(parser, max_time_help="time budget (default 3600 s)")


def run(args: argparse.Namespace) -> int:
    from pirate_bt.api.survey import survey
    from pirate_bt.cli.navigate import print_decisions, print_summary

    if args.port is not None and args.firmware_chain:
        raise InputError("--firmware-chain runs the simulator; with --port the robot is real")
    from pirate_bt.api.options import quantity
    from pirate_bt.cli import as_option, check_output
    from pirate_bt.cli.navigate import as_typed, check_stepwise

    check_stepwise(args)  # named as typed: the API said "seed:", "max_time:"
    for option, value in (("--search", args.search), ("--radius", args.radius)):
        if not quantity(value, "length", option) > 0:  # was "explore: search: ..."
            raise InputError(f"{option} must be positive, not {value!r}")
    check_output(args.output)  # before the survey, not after it
    try:
        result = survey(
            sim=args.sim,
            port=args.port,
            output=args.output,
            name=args.name,
            search=args.search,
            radius=args.radius,
            seed=args.seed,
            faults=args.faults,
            trace=args.trace,
            max_time=args.max_time,
            firmware=args.firmware_chain,
            extend=args.extend,
        )
    except InputError as exc:
        # the API names its arguments; here they are the options typed
        as_typed(exc, "extend: ", "sim: ", "trace: ")
        as_option(exc, "output", "-o")  # "output: x.txt is not a .yaml file name"
        raise
    if not args.quiet:
        print_decisions(result.navigation.decisions)
    for note in result.navigation.notes:
        print(f"pirate-bt: {note}", file=sys.stderr)
    print_summary(result.succeeded, result.summary())
    return result.exit_code
