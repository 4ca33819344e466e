"""Running cases in isolation on a ``concurrent.futures`` executor, locally or on Dask.

One code path: the campaign submits :func:`run_isolated` for every case to an
executor, a :class:`~concurrent.futures.ProcessPoolExecutor` on this machine or
``distributed.Client.get_executor()`` on a Dask cluster, and writes each record
as it comes back. :func:`run_isolated` runs the case in a process of its own,
forked from the worker's long-lived case server, which imported everything
once (:mod:`pirate_bt.campaign.workers`, :mod:`pirate_bt.campaign.child`), and
waits for it at most the case's wall-time limit: a hung case's whole process
group is killed, a crashed one is recorded with its exit status, a server that
dies is replaced, and the executor's worker is never the one that hangs or
dies. A case costs a fork, not a Python start (docs/performance.md).

The only names joined onto the output folder are fixed ones and case ids, and a
case id must be a safe file name (:func:`pirate_bt.campaign.paths.safe_name`):
:func:`run_cases` refuses a case list with another id before any case runs, and
:func:`run_isolated` makes such a case an ``error`` without starting it.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from pirate_bt.campaign.case import error_record, row_problem
from pirate_bt.campaign.paths import is_safe_name, safe_name
from pirate_bt.campaign.workers import prestart, run_in_server
from pirate_bt.errors import InputError

__all__ = [
    "DEFAULT_TARGET",
    "RESULTS_NAME",
    "check_output",
    "make_executor",
    "read_rows",
    "run_cases",
    "run_isolated",
]

_log = logging.getLogger(__name__)

DEFAULT_TARGET = "pirate_bt.campaign.case:run_case"
RESULTS_NAME = "results.jsonl"


def run_isolated(
    case: dict[str, Any], trace_dir: str | None, target: str = DEFAULT_TARGET
) -> dict[str, Any]:
    """Run one case in a process of its own and return its record, whatever happens there.

    A plain function of plain arguments: this is what goes to the executor. The
    process is forked from this worker's case server (started once, imports
    done; :func:`pirate_bt.campaign.workers.run_in_server`).

    Args:
        case: The case (its ``timeout_s`` is the wall-time limit).
        trace_dir: Where the case may keep its trace (``traces/ID``); ``None``: none.
        target: ``module:function`` the case process calls (tests point it elsewhere).

    Returns:
        The case's record, or an ``error``/``timeout`` record made here (an
        ``error`` without a process for a case whose id is not a safe file name).
    """
    if trace_dir is not None and not is_safe_name(case.get("id")):
        return error_record(
            case, "error", f"case id {str(case.get('id'))[:60]!r} is not a safe file name", 0.0
        )
    return run_in_server(case, trace_dir, target)


@contextmanager
def make_executor(
    workers: int | None = None,
    scheduler: str | None = None,
    scheduler_file: str | None = None,
    scheduler_timeout_s: float = 10.0,
) -> Iterator[tuple[Executor, str]]:
    """The executor cases go to, and one line saying what it is.

    Args:
        workers: Local worker processes (default: the number of cores).
        scheduler: A Dask scheduler address (``tcp://host:8786``).
        scheduler_file: A Dask scheduler file (as ``dask-scheduler --scheduler-file``
            writes, and dask-jobqueue set-ups share).
        scheduler_timeout_s: How long to keep trying to reach the scheduler.

    Raises:
        InputError: Dask is asked for but not installed, or cannot be reached.
    """
    if scheduler is None and scheduler_file is None:
        count = workers or os.cpu_count() or 1
        # Each worker starts its case server as it starts (the imports, once).
        pool = ProcessPoolExecutor(max_workers=count, initializer=prestart)
        try:
            yield pool, f"{count} local worker{'s' if count != 1 else ''}"
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        return
    try:
        from pirate_bt.campaign.cluster import dask_executor
    except ImportError:
        raise InputError(
            "--scheduler needs Dask's distributed;"
            " install it with: pip install 'pirate-bt[cluster]'"
        ) from None
    with dask_executor(scheduler, scheduler_file, scheduler_timeout_s) as (executor, what):
        yield executor, what


def read_rows(path: Path) -> list[dict[str, Any]]:
    """The records of a results file, one per case id (the first written).

    A cut line (an interrupted write) is skipped, and so is a second row for a
    case id (two campaigns appending to one folder by mistake), and a row that is
    not a record a case could have written (:func:`~pirate_bt.campaign.case.row_problem`:
    a file edited by hand), each with a warning naming its line; ``--resume`` runs
    the cases of the rows skipped again.

    Raises:
        InputError: the file cannot be read.
    """
    rows: list[dict[str, Any]] = []
    if not path.exists():
        return rows
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the results: {exc.strerror or exc}") from None
    seen: set[object] = set()
    for number, line in enumerate(data.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            row = json.loads(line.decode("utf-8"))
        except ValueError:  # a cut line, or bytes that are not UTF-8
            _log.warning("%s:%d: skipped a cut line", path, number)
            continue
        problem = row_problem(row)
        if problem is not None:
            _log.warning(
                "%s:%d: skipped a row that is not a case's result: %s", path, number, problem
            )
            continue
        if row["id"] not in seen:
            seen.add(row["id"])
            rows.append(row)
    return rows


def check_output(output: Path, resume: bool = False) -> None:
    """Make the output folder (if missing) and check that it can take this campaign's rows.

    Called before any worker starts, so that a bad ``--output`` costs nothing.

    Raises:
        InputError: ``output`` is a file, or cannot be made; its results file is
            not a file; it holds results and ``resume`` is off.
    """
    if output.exists() and not output.is_dir():
        raise InputError(f"{output}: the output is a file, not a folder; give another --output")
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"{output}: cannot make the output folder: {exc.strerror or exc}"
        ) from None
    results = output / RESULTS_NAME
    if results.exists() and not results.is_file():
        raise InputError(f"{results}: not a file; give another --output")
    old = [] if resume else read_rows(results)
    if old:
        raise InputError(
            f"{results} holds {len(old)} results already; use --resume, or another --output"
        )


def run_cases(
    cases: list[dict[str, Any]],
    output: Path | None,
    executor: Executor,
    *,
    resume: bool = False,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    target: str = DEFAULT_TARGET,
) -> list[dict[str, Any]]:
    """Run the cases not yet in ``output/results.jsonl`` and append one row each.

    Rows are written in the order cases finish, each line flushed at once, so an
    interruption loses only the cases in flight. ``KeyboardInterrupt`` cancels
    the cases not started and propagates.

    Args:
        cases: The cases; each ``id`` must be a safe file name (it names the
            case's trace under ``output/traces/``).
        output: The campaign's folder; ``None`` writes nothing (no results file,
            no traces) and keeps the rows in memory only.
        executor: Where the cases run.
        resume: Skip the cases whose ids already have a row.
        on_record: Called with every new record (the progress bar).
        target: The case function (``module:function``).

    Returns:
        Every row of the campaign (old and new), in case order.

    Raises:
        InputError: the folder holds results and ``resume`` is off; ``resume``
            without a folder; a case id that is not a safe file name.
    """
    for case in cases:
        safe_name(case.get("id"), "case id")
    if output is None:
        if resume:
            raise InputError("resume needs an output folder to resume from")
        return _collect(cases, [], executor, None, None, on_record, target)
    check_output(output, resume)
    results = output / RESULTS_NAME
    old = read_rows(results)
    # A row counts as done only for the case it claims to be (its id and its index).
    wanted = {c["id"]: c["index"] for c in cases}
    old = [r for r in old if r["id"] in wanted and r.get("index") == wanted[r["id"]]]
    # Rewrite without a cut last line, so every appended row starts on its own line.
    text = "".join(json.dumps(r, allow_nan=False) + "\n" for r in old)
    part = results.with_name(results.name + ".part")
    part.write_text(text, encoding="utf-8")
    os.replace(part, results)  # never half a results file, even if stopped right here
    trace_dir = str((output / "traces").resolve())
    return _collect(cases, old, executor, results, trace_dir, on_record, target)


def _collect(
    cases: list[dict[str, Any]],
    old: list[dict[str, Any]],
    executor: Executor,
    results: Path | None,
    trace_dir: str | None,
    on_record: Callable[[dict[str, Any]], None] | None,
    target: str,
) -> list[dict[str, Any]]:
    """Submit the cases not in ``old``, gather their records (appended to ``results``)."""
    done = {r["id"] for r in old}
    # Seed-major order: every group gets its first seeds before any gets its last,
    # so a campaign stopped early still covers the whole matrix evenly.
    todo = sorted((c for c in cases if c["id"] not in done), key=lambda c: (c["seed"], c["index"]))
    rows = list(old)
    futures: dict[Future[dict[str, Any]], dict[str, Any]] = {}
    try:
        for case in todo:
            futures[executor.submit(run_isolated, case, trace_dir, target)] = case
        with contextlib.ExitStack() as stack:
            sink = stack.enter_context(results.open("a", encoding="utf-8")) if results else None
            for future in as_completed(futures):
                case = futures[future]
                try:
                    record = future.result()
                except Exception as exc:  # a lost worker, not the case's own doing
                    record = error_record(case, "error", f"worker lost: {exc}", 0.0)
                if sink is not None:
                    sink.write(json.dumps(record, allow_nan=False, default=str) + "\n")
                    sink.flush()
                rows.append(record)
                if on_record is not None:
                    on_record(record)
    except BaseException:
        for future in futures:
            future.cancel()
        raise
    return sorted(rows, key=lambda r: int(r.get("index", 0)))
