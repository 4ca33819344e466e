"""``pirate-bt navigate NAME``: a navigator drives the robot step by step.

The command parses, calls :func:`pirate_bt.navigate` and prints: one line per
decision (unless ``--quiet``) and the result's summary. Exit codes as for ``run``:
0 success, 1 the navigation failed (robot left safe), 2 bad input, 3 link error.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from pirate_bt.errors import InputError

if TYPE_CHECKING:
    from pirate_bt.task.navigation import Decision

__all__ = ["configure", "print_decisions", "print_summary", "run", "stepwise_options"]


def stepwise_options(parser: argparse.ArgumentParser, *, max_time_help: str) -> None:
    """The options of every step-wise command (``navigate``, ``survey``): seed,
    faults, trace, time limit, the firmware chain, quiet."""
    parser.add_argument("--seed", type=int, default=0, help="simulator random seed (default 0)")
    parser.add_argument("--faults", metavar="SPEC", help="simulator and link fault injection")
    parser.add_argument(
        "--trace", metavar="DIR", help="write navigation.jsonl and one trace per step here"
    )
    parser.add_argument("--max-time", default="3600 s", metavar="TIME", help=max_time_help)
    parser.add_argument(
        "--firmware-chain",
        action="store_true",
        help="with the simulator: run it behind the real firmwares in simavr (virtual time)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="print the summary only")


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "navigator",
        metavar="NAME",
        help="a navigator: route, goal, or one an installed package registers"
        " (`pirate-bt navigate --list`)",
        nargs="?",
    )
    parser.add_argument("--list", action="store_true", help="list the navigators and exit")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--sim",
        metavar="NETWORK",
        help="the simulator in this network, the truth (default: the simulator, in the"
        " --map network, else in 'straight')",
    )
    where.add_argument("--port", metavar="URL", help="a real robot: serial port or pyserial URL")
    parser.add_argument(
        "--map", metavar="MAP", help="the map the navigator sees (default: none, odometry only)"
    )
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a navigator parameter, e.g. --param segment=run-d (repeatable)",
    )
    stepwise_options(parser, max_time_help="time limit (default 3600 s)")
    parser.add_argument(
        "--deadline",
        default="5 s",
        metavar="TIME",
        help="wall time the navigator may take per decision (default 5 s)",
    )
    parser.add_argument("--max-steps", type=int, default=500, help="step limit (default 500)")
    parser.add_argument("--rate", default="20 Hz", metavar="FREQ", help="tick rate (default 20 Hz)")


def print_decisions(decisions: Sequence[Decision]) -> None:
    """One line per decision: where, the step (or done), and how it ended."""
    for d in decisions:
        where = d.observation.belief
        seg = f" ({where.segment})" if where.segment else ""
        what = repr(d.step) if d.step is not None else "done"
        end = f" -> {d.outcome}" if d.outcome else ""
        if d.error:
            end = f" -> refused: {d.error}"
        print(f"{d.index:3d}. at {where.position_m:6.2f} m{seg}: {what}{end}")


def print_summary(succeeded: bool, summary: str) -> None:
    """The result's one line: on stdout for a success, else on stderr, prefixed."""
    if succeeded:
        print(summary)
    else:
        print(f"pirate-bt: {summary}", file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    from pirate_bt.api.navigation import navigate
    from pirate_bt.cli.run import parse_params
    from pirate_bt.task.navigators import navigator_names

    if args.list:
        print("\n".join(navigator_names()))
        return 0
    if args.navigator is None:
        raise InputError("navigate: name a navigator (`pirate-bt navigate --list`)")
    if args.port is not None and args.firmware_chain:
        raise InputError("--firmware-chain runs the simulator; with --port the robot is real")
    result = navigate(
        args.navigator,
        sim=args.sim,
        port=args.port,
        map=args.map,
        params=parse_params(args.param),
        seed=args.seed,
        faults=args.faults,
        trace=args.trace,
        max_time=args.max_time,
        deadline=args.deadline,
        max_steps=args.max_steps,
        rate=args.rate,
        firmware=args.firmware_chain,
    )
    if not args.quiet:
        print_decisions(result.decisions)
    for note in result.notes:
        print(f"pirate-bt: {note}", file=sys.stderr)
    print_summary(result.succeeded, result.summary())
    return result.exit_code
