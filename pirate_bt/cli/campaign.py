"""``pirate-bt campaign SPEC``: run a campaign locally or on a Dask cluster, then report.

The command parses its options, calls :func:`pirate_bt.campaign.run_campaign`
and prints what it did: the line naming the cases and where they run, a
progress bar, the outcome counts and the report files written.

``pirate-bt campaign report RESULTS`` writes the report again from a results
file (or the folder holding it). Every case runs in its own process; a crash,
a hang (killed after ``case_timeout``) or an exception is that case's outcome.
Rows go to ``OUTPUT/results.jsonl`` as cases finish; after Ctrl-C, ``--resume``
runs only the cases still missing, and refuses (exit 2) an input file changed since
the campaign started or another ``--case-timeout``
(:mod:`pirate_bt.campaign.started`). Exit codes: 0 the campaign ran (whatever its
cases did); 2 bad input; 130 interrupted (Ctrl-C), 143 terminated (SIGTERM).
"""

from __future__ import annotations

import argparse
import re
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pirate_bt.campaign.cases import DEFAULT_MAX_CASES, MAX_CASES_CEILING, check_max_cases
from pirate_bt.campaign.paths import OUTPUT, RESUME
from pirate_bt.cli import said_path
from pirate_bt.errors import InputError, LinkError

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "spec", metavar="SPEC", help="a *.campaign.yaml file, or 'report' then a results file"
    )
    parser.add_argument("results", nargs="?", metavar="RESULTS", help=argparse.SUPPRESS)
    parser.add_argument(
        "--workers", type=int, metavar="N", help="local worker processes (default: the cores)"
    )
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDRESS", help="a Dask scheduler, tcp://host:8786")
    where.add_argument("--scheduler-file", metavar="FILE", help="a Dask scheduler file")
    parser.add_argument(
        "--scheduler-timeout",
        metavar="TIME",
        help="how long to keep trying to reach the Dask scheduler, then to wait for a"
        " worker there (default 10 s)",
    )
    parser.add_argument("--output", metavar="DIR", help="results folder (default: campaign-NAME)")
    parser.add_argument("--resume", action="store_true", help="skip the cases already done")
    parser.add_argument(
        "--case-timeout",
        metavar="TIME",
        help="wall-time limit per case (overrides the file; with --resume, default and only"
        " value: the one the campaign started with)",
    )
    parser.add_argument(
        "--max-cases",
        type=int,
        default=DEFAULT_MAX_CASES,
        metavar="N",
        help=(
            f"refuse a spec that expands to more cases (default: {DEFAULT_MAX_CASES:,};"
            f" at most {MAX_CASES_CEILING:,})"
        ),
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _report(args: argparse.Namespace) -> int:
    from pirate_bt.campaign import read_rows
    from pirate_bt.campaign.engine import RESULTS_NAME
    from pirate_bt.campaign.report import write_report
    from pirate_bt.campaign.started import recorded_name

    if not args.results:
        raise InputError("campaign report: give the results file (results.jsonl) or its folder")
    given = [
        option
        for option, value in (
            ("--output", args.output),
            ("--resume", args.resume or None),
            ("--workers", args.workers),
            ("--scheduler", args.scheduler),
            ("--scheduler-file", args.scheduler_file),
            ("--scheduler-timeout", args.scheduler_timeout),
            ("--case-timeout", args.case_timeout),
            ("--max-cases", None if args.max_cases == DEFAULT_MAX_CASES else args.max_cases),
        )
        if value is not None
    ]
    if given:  # dropped without a word: '--output X' wrote the report beside the results
        raise InputError(
            f"campaign report: {given[0]} is for running a campaign; the report runs no case"
            " and is written beside its results file"
        )
    path = Path(args.results)
    if path.is_dir():
        path = path / RESULTS_NAME
    if not path.exists():
        raise InputError(f"{path}: no such results file")
    rows = _read_results(path, read_rows)
    # the campaign's own name, as its end wrote the report (it became the folder's name)
    title = recorded_name(path.parent) or path.parent.name
    for written in write_report(rows, path.parent, title=title):
        print(f"wrote {said_path(written)}")
    return 0


def _read_results(path: Path, read_rows: Callable[[Path], list[Any]]) -> list[Any]:
    """``read_rows``, its warnings (one per line skipped) held back until it is known
    whether any row is a case's: a file with none (a trace given by mistake) was a
    warning for every one of its lines, thousands, before the one line of the error;
    now the first of them, then that line.

    Raises:
        InputError: no row of the file is a case's result.
    """
    import logging

    held: list[logging.LogRecord] = []

    def hold(record: logging.LogRecord) -> bool:
        held.append(record)
        return False

    logger = logging.getLogger("pirate_bt.campaign.engine")
    logger.addFilter(hold)
    try:
        rows = read_rows(path)
    finally:
        logger.removeFilter(hold)
    for record in held if rows else held[:1]:
        logger.handle(record)
    if not rows:
        more = f"; none of its {len(held):,} rows is a case's result" if len(held) > 1 else ""
        raise InputError(f"{path}: no results in it{more}")
    return rows


_OPTIONS = {
    "scheduler_file": "--scheduler-file",
    "scheduler_timeout": "--scheduler-timeout",
}
_BY_OPTION = re.compile(r"\b(" + "|".join(_OPTIONS) + r")\b")
_WORDS = {RESUME: "--resume", OUTPUT: "--output"}
# a word of advice, after a space and before the end, a space or punctuation (not a
# folder named "x output=y" at the start of the line)
_BY_WORD = re.compile(r"(?<= )(?:" + "|".join(map(re.escape, _WORDS)) + r")(?=$|[\s;,.)])")


def _by_option(text: str) -> str:
    """``run_campaign``'s message with the arguments named as this command's options
    (``scheduler_file: no scheduler file at ...`` is ``--scheduler-file: ...`` here).

    ``case_timeout`` is also the spec's key: only a message that starts with the
    argument's name (a resume's other case timeout) is about ``--case-timeout``.
    """
    if text.startswith("case_timeout: "):
        text = "--case-timeout: " + text.removeprefix("case_timeout: ")
    if text.startswith("workers: "):  # "workers: at most 1024 local processes"
        text = "--workers: " + text.removeprefix("workers: ")
    # what to do next, in the words typed: the API says "use resume=True, or another output="
    text = _BY_WORD.sub(lambda m: _WORDS[m.group(0)], text)
    return _BY_OPTION.sub(lambda m: _OPTIONS[m.group(1)], text)


def run(args: argparse.Namespace) -> int:
    if args.spec == "report":
        return _report(args)
    if args.results:
        raise InputError(f"unexpected argument {args.results!r}")
    from pirate_bt.campaign import default_output, load_spec, run_campaign
    from pirate_bt.campaign.run import case_timeout_s

    if args.workers is not None and args.workers < 1:
        raise InputError("--workers must be at least 1")
    cluster = "--scheduler-file" if args.scheduler_file else "--scheduler" if args.scheduler else ""
    if cluster and args.workers is not None:
        raise InputError(
            f"--workers is the local pool's size; with {cluster} the cases run on the"
            " cluster's own workers (give one or the other)"
        )
    if args.scheduler_timeout is not None and not cluster:  # it was dropped without a word
        raise InputError(
            "--scheduler-timeout is for --scheduler or --scheduler-file: the local pool"
            " needs no reaching; leave it out"
        )
    check_max_cases(args.max_cases, "--max-cases")
    case_timeout = case_timeout_s(args.case_timeout, "--case-timeout")
    from pirate_bt.cli import check_folder_output

    check_folder_output(args.output)  # not a folder named "-"
    if args.output is not None and not args.output.strip():
        raise InputError("--output: empty; name a folder")  # '' would be the working folder
    spec = load_spec(args.spec)
    output: Path = Path(args.output) if args.output is not None else default_output(spec)
    command = f"pirate-bt campaign {shlex.quote(str(Path(args.spec)))}"
    if args.workers:
        command += f" --workers {args.workers}"
    # what the cases ran with: without them the line refused the spec, or ran it otherwise
    if args.case_timeout is not None:
        command += f" --case-timeout {shlex.quote(str(args.case_timeout))}"
    if args.max_cases != DEFAULT_MAX_CASES:
        command += f" --max-cases {args.max_cases}"
    started = False

    def echo(line: str) -> None:
        nonlocal started
        started = True  # the cases are about to start: an interruption from now keeps rows
        print(line, flush=True)

    try:
        result = run_campaign(
            spec,
            workers=args.workers,
            scheduler=args.scheduler,
            scheduler_file=args.scheduler_file,
            scheduler_timeout=args.scheduler_timeout or "10 s",
            output=output,
            resume=args.resume,
            case_timeout=case_timeout,
            max_cases=args.max_cases,
            progress=not args.quiet,
            echo=echo,
            command=command,
        )
    except InputError as exc:
        raise InputError(_by_option(str(exc))) from None
    except LinkError as exc:  # a cluster with no worker: "give a longer --scheduler-timeout"
        raise LinkError(_by_option(str(exc))) from None
    except KeyboardInterrupt as exc:
        if not started:
            raise
        from pirate_bt.cli import EXIT_SIGINT, Terminated

        terminated = exc if isinstance(exc, Terminated) else None
        # how many: it said "keeps the cases done" with none done as with 39 of 40
        from pirate_bt.campaign.engine import read_rows

        total = spec.size()
        try:
            done = len(read_rows(output / "results.jsonl"))
        except InputError:  # pragma: no cover - the file was ours a moment ago
            done = 0
        print(
            f"pirate-bt: campaign"
            f" {f'terminated ({terminated.signal_name})' if terminated else 'interrupted'};"
            f" {output}/results.jsonl keeps {done:,} of its {total:,} cases (the cases in"
            f" flight are not recorded); run again with --resume to run the other"
            f" {total - done:,}",
            file=sys.stderr,
        )
        return terminated.exit_code if terminated else EXIT_SIGINT
    print(f"campaign {result.name}: {result.summary()}")
    for written in result.files:
        print(f"wrote {said_path(written)}")
    return 0
