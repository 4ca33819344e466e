"""``pirate-bt campaign SPEC``: run a campaign locally or on a Dask cluster, then report.

``pirate-bt campaign report RESULTS`` writes the report again from a results
file (or the folder holding it). Every case runs in its own process; a crash,
a hang (killed after ``case_timeout``) or an exception is that case's outcome.
Rows go to ``OUTPUT/results.jsonl`` as cases finish; after Ctrl-C, ``--resume``
runs only the cases still missing. Exit codes: 0 the campaign ran (whatever its
cases did); 2 bad input; 130 interrupted.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections import Counter
from pathlib import Path
from typing import Any

from pirate_bt.errors import InputError


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
        "--output", type=Path, metavar="DIR", help="results folder (default: campaign-NAME)"
    )
    parser.add_argument("--resume", action="store_true", help="skip the cases already done")
    parser.add_argument(
        "--case-timeout", metavar="TIME", help="wall-time limit per case (overrides the file)"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _report(args: argparse.Namespace) -> int:
    from pirate_bt.campaign import read_rows
    from pirate_bt.campaign.engine import RESULTS_NAME
    from pirate_bt.campaign.report import write_report

    if not args.results:
        raise InputError("campaign report: give the results file (results.jsonl) or its folder")
    path = Path(args.results)
    if path.is_dir():
        path = path / RESULTS_NAME
    if not path.exists():
        raise InputError(f"{path}: no such results file")
    rows = read_rows(path)
    if not rows:
        raise InputError(f"{path}: no results in it")
    for written in write_report(rows, path.parent, title=path.parent.name):
        print(f"wrote {written}")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.spec == "report":
        return _report(args)
    if args.results:
        raise InputError(f"unexpected argument {args.results!r}")
    from pirate_bt.campaign import expand, load_campaign, make_executor, run_cases
    from pirate_bt.campaign.report import write_report
    from pirate_bt.units import parse_quantity

    if args.workers is not None and args.workers < 1:
        raise InputError("--workers must be at least 1")
    spec_path = Path(args.spec)
    spec = load_campaign(spec_path)
    cases = expand(spec, spec_path.parent)
    from pirate_bt.campaign.cases import check_runs

    check_runs(cases)
    if args.case_timeout:
        try:
            limit = parse_quantity(args.case_timeout, "time")
        except Exception as exc:
            raise InputError(f"--case-timeout: {exc}") from None
        for case in cases:
            case["timeout_s"] = limit
    output: Path = args.output or Path(f"campaign-{spec.name}")
    counts: Counter[str] = Counter()
    bar: Any = None
    with make_executor(args.workers, args.scheduler, args.scheduler_file) as (executor, what):
        print(f"campaign {spec.name}: {len(cases)} cases on {what} -> {output}")
        from tqdm import tqdm

        bar = tqdm(total=len(cases), unit="case", file=sys.stderr, disable=args.quiet, ncols=100)

        def progress(record: dict[str, Any]) -> None:
            counts[str(record.get("outcome"))] += 1
            bar.update(1)
            bar.set_postfix_str(
                f"ok {counts['success']} safe {counts['failed-safe']}"
                f" err {counts['error']} t/o {counts['timeout']}",
                refresh=False,
            )

        try:
            rows = run_cases(cases, output, executor, resume=args.resume, on_record=progress)
        except KeyboardInterrupt:
            bar.close()
            print(
                f"pirate-bt: campaign interrupted; {output}/results.jsonl keeps the cases done;"
                " run again with --resume",
                file=sys.stderr,
            )
            return 130
        bar.close()
    command = f"pirate-bt campaign {shlex.quote(str(spec_path))}"
    if args.workers:
        command += f" --workers {args.workers}"
    total = Counter(str(r.get("outcome")) for r in rows)
    print(
        f"campaign {spec.name}: {len(rows)} runs: {total['success']} success,"
        f" {total['failed-safe']} failed safe, {total['error']} error, {total['timeout']} timeout"
    )
    for written in write_report(rows, output, title=spec.name, command=command):
        print(f"wrote {written}")
    return 0
