"""``pirate-bt navigate NAME``: a navigator drives the robot step by step.

The command parses, calls :func:`pirate_bt.navigate` and prints: one line per
decision (unless ``--quiet``) and the result's summary. Exit codes as for ``run``:
0 success, 1 the navigation failed (robot left safe), 2 bad input, 3 link error.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from pirate_bt.cli import as_option
from pirate_bt.errors import InputError

if TYPE_CHECKING:
    from pirate_bt.task.navigation import Decision

__all__ = [
    "check_stepwise",
    "configure",
    "print_decisions",
    "print_summary",
    "run",
    "stepwise_options",
]


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


def check_stepwise(args: argparse.Namespace) -> float:
    """The options :func:`stepwise_options` adds, checked as the API checks them but
    named as typed (the API said ``seed: ...`` and ``max_time: ...``); returns the
    time limit in seconds.

    Raises:
        InputError: a seed or time limit the API would refuse, or a file the steps write
            in ``--trace`` that is a named pipe (one was waited on for ever).
    """
    from pirate_bt.api.options import NO_LIMIT, positive_time_s, seed_value
    from pirate_bt.cli import refuse_pipe
    from pirate_bt.cli.faults_option import check_faults_option
    from pirate_bt.robot.loader import load_robot

    seed_value(args.seed, "--seed")
    folder = Path(args.trace) if getattr(args, "trace", None) else None
    if folder is not None and folder.is_dir():
        steps = sorted(p.name for p in folder.glob("step-*.jsonl"))
        for name in ("navigation.jsonl", *steps):
            refuse_pipe(folder / name, "--trace")
    if getattr(args, "faults", None):  # at its column, the bundled robot's targets
        check_faults_option(args, load_robot())  # (it said "faults: ...")
    return positive_time_s(args.max_time, "--max-time", instead=NO_LIMIT)


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
    parser.add_argument(
        "--max-steps", type=int, default=500, metavar="N", help="step limit (default 500)"
    )
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


def as_typed(exc: InputError, *starts: str) -> None:
    """Raise the API's message again with the argument it names as the option typed
    (``trace: out is a file, not a folder`` is ``--trace: ...`` here) when it begins
    with one of ``starts`` (``"trace: "``); return for any other message.

    Raises:
        InputError: ``exc``'s message begins with one of ``starts``.
    """
    for start in starts:  # the parameter's name as the option's
        name = start.removesuffix(": ")
        as_option(exc, name, f"--{name}")


_PARAMS_ASKED = re.compile(r"\(params=\{'(\w+)': \.\.\.\};")
"""A parameter a navigator needs, as the API asks a Python caller for it
(*needs the parameter 'segment' (params={'segment': ...}; it takes: segment)*)."""


def _check_options(args: argparse.Namespace) -> None:
    """``navigate``'s own options, named as typed (the API said ``rate: '5' needs a
    unit``, ``deadline: ...``, ``max_steps: ...``)."""
    from pirate_bt.api.navigation import MAX_DEADLINE_S, MAX_STEPS
    from pirate_bt.api.options import positive_time_s, tick_period_s

    max_time_s = check_stepwise(args)
    tick_period_s(args.rate, max_time_s, option="--rate", limit_option="--max-time")
    positive_time_s(
        args.deadline,
        "--deadline",
        limit_s=MAX_DEADLINE_S,
        instead="give a wall time such as '5 s'",
    )
    if not 1 <= args.max_steps <= MAX_STEPS:
        raise InputError(f"--max-steps: give 1 to {MAX_STEPS:,}, not {args.max_steps}")


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
    _check_options(args)
    try:
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
    except InputError as exc:
        as_typed(exc, "trace: ", "sim: ", "map: ")  # "sim: no network 'x'", the API's
        asked = _PARAMS_ASKED.sub(lambda m: f"(--param {m.group(1)}=...;", str(exc))
        if asked != str(exc):  # a parameter it needs, as this command takes it
            raise InputError(asked) from exc
        raise
    if not args.quiet:
        print_decisions(result.decisions)
    for note in result.notes:
        print(f"pirate-bt: {note}", file=sys.stderr)
    print_summary(result.succeeded, result.summary())
    return result.exit_code
