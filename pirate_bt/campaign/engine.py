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

Should a worker of the local pool die all the same (killed from outside), only
the case it was running is lost: the pool (:class:`LocalPool`) is replaced and
the cases the broken pool failed without having run them run again, as Dask
reschedules them.

The only names joined onto the output folder are fixed ones and case ids, and a
case id must be a safe file name (:func:`pirate_bt.campaign.paths.safe_name`):
:func:`run_cases` refuses a case list with another id before any case runs, and
:func:`run_isolated` makes such a case an ``error`` without starting it.
"""

from __future__ import annotations

import codecs
import contextlib
import json
import logging
import multiprocessing
import os
import stat
import tempfile
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import CancelledError, Executor, Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

from pirate_bt.campaign.cancelled import not_run
from pirate_bt.campaign.case import error_record, row_problem
from pirate_bt.campaign.paths import OUTPUT, RESULTS_NAME, RESUME, is_safe_name, safe_name
from pirate_bt.campaign.sink import RowSink
from pirate_bt.campaign.started import RECORD_NAME, holds_a_record
from pirate_bt.campaign.stopping import pool_killed_on_signal
from pirate_bt.campaign.workers import pool_markers, run_in_server, start_pool_worker, tracked
from pirate_bt.errors import InputError, said_of

__all__ = [
    "DEFAULT_TARGET",
    "RESULTS_NAME",
    "LocalPool",
    "check_output",
    "make_executor",
    "read_rows",
    "run_cases",
    "run_isolated",
]

_log = logging.getLogger(__name__)

DEFAULT_TARGET = "pirate_bt.campaign.case:run_case"


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
    return _with_cut_trace(run_in_server(case, trace_dir, target), case, trace_dir)


def _with_cut_trace(
    record: dict[str, Any], case: dict[str, Any], trace_dir: str | None
) -> dict[str, Any]:
    """A killed or crashed case's record names the trace it wrote as far as it got.

    The case writes its trace as it runs (``traces/ID.jsonl``, a folder for a route or
    navigator); a case killed at its wall-time limit or dead of a crash left it there,
    cut, while its row said ``trace: null``: what it did before it hung was on disk
    under no row. A trace reader tolerates the cut last line.
    """
    if trace_dir is None or record.get("trace") is not None:
        return record
    if record.get("outcome") not in ("timeout", "error"):
        return record
    name = f"{case['id']}.jsonl" if case.get("tree") else str(case["id"])
    path = Path(trace_dir) / name
    if path.exists():
        record = {**record, "trace": str(path)}
    return record


_P = ParamSpec("_P")
_T = TypeVar("_T")


class LocalPool(Executor):
    """The local process pool, which :func:`run_cases` replaces when one of its workers dies.

    A :class:`~concurrent.futures.ProcessPoolExecutor` whose worker dies is broken:
    every call still pending fails with ``BrokenProcessPool``, run or not. This one
    knows which calls were running in a worker that died of itself
    (:func:`~pirate_bt.campaign.workers.tracked`; the pool terminates the others'
    workers) and starts a new pool for the rest (:meth:`replace`). Its workers
    start their case servers as they start, and die with this process (Linux).
    """

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.replaced = 0
        """How many times the pool was replaced (a worker died)."""
        self._markers = tempfile.TemporaryDirectory(prefix="pirate-bt-pool-")
        self._tokens: dict[Future[Any], int] = {}
        self._next = 0
        self._lock = threading.Lock()
        self._pool = self._new()

    def _new(self) -> ProcessPoolExecutor:
        forked = multiprocessing.get_start_method() != "forkserver"
        parent = os.getpid() if forked else None  # else the fork server is the parent
        return ProcessPoolExecutor(
            max_workers=self.workers,
            initializer=start_pool_worker,
            initargs=(parent, self._markers.name),
        )

    def submit(self, fn: Callable[_P, _T], /, *args: _P.args, **kwargs: _P.kwargs) -> Future[_T]:
        with self._lock:
            token = self._next
            self._next += 1
            send: Callable[..., Future[_T]] = self._pool.submit  # mypy: a ParamSpec in a ParamSpec
            try:
                future = send(tracked, token, fn, *args, **kwargs)
            except BrokenProcessPool as exc:  # broken since the last replacement: not run
                future = Future()
                future.set_exception(exc)
            self._tokens[future] = token
        future.add_done_callback(self._forget)
        return future

    def _forget(self, future: Future[Any]) -> None:
        if future.cancelled() or not isinstance(future.exception(), BrokenProcessPool):
            self._tokens.pop(future, None)

    def replace(self, failed: list[Future[Any]]) -> set[Future[Any]]:
        """After ``BrokenProcessPool``: a new pool; which of ``failed`` ran in the worker that died.

        Waits until every worker of the broken pool has ended. The calls of
        ``failed`` not returned (never started, or running in a worker the pool
        terminated) may be submitted again.
        """
        with self._lock:
            self._pool.shutdown(wait=True, cancel_futures=True)
            running = pool_markers(self._markers.name)
            self._pool = self._new()
            self.replaced += 1
            tokens = {future: self._tokens.pop(future, -1) for future in failed}
        return {f for f, token in tokens.items() if running.get(token) is False}

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)
        if wait:
            self._markers.cleanup()


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
        scheduler_timeout_s: How long to keep trying to reach the scheduler, then to
            wait for a worker there.

    Raises:
        InputError: Dask is asked for but not installed, or cannot be reached.
    """
    if scheduler is None and scheduler_file is None:
        count = workers or os.cpu_count() or 1
        # Each worker starts its case server as it starts (the imports, once).
        pool = LocalPool(count)
        try:
            yield pool, f"{count} local worker{'s' if count != 1 else ''}"
        except BaseException:  # Ctrl-C, SIGTERM: a second one kills the cases in flight
            with pool_killed_on_signal(pool):
                pool.shutdown(wait=True, cancel_futures=True)
            raise
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

    A cut last line (an interrupted write), a line that is not a JSON row (bytes
    that are not UTF-8, text that is not JSON, JSON nested too deep to read), a
    row that is not a record a case could have written
    (:func:`~pirate_bt.campaign.case.row_problem`: a file edited by hand) and a
    second row for a case id (two campaigns appending to one folder by mistake)
    are skipped, each with a warning naming its line; ``--resume`` runs the cases
    of the rows skipped again.

    Raises:
        InputError: the file cannot be read.
    """
    return [row for _line, row in _numbered_rows(path, warn=True)]


def _silent(*_args: object) -> None:
    return None


def _read(path: Path) -> bytes:
    # Only a regular file: /dev/zero was read until the kernel killed the process (and
    # `campaign report` would then have written its report into /dev), a FIFO waited.
    try:
        regular = stat.S_ISREG(path.stat().st_mode)
    except OSError as exc:
        raise InputError(f"{path}: cannot read the results: {exc.strerror or exc}") from None
    if not regular:
        raise InputError(f"{path}: not a file of results (a device, a pipe or a folder)")
    try:
        return path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the results: {exc.strerror or exc}") from None


def _numbered_rows(path: Path, *, warn: bool) -> list[tuple[int, dict[str, Any]]]:
    """:func:`read_rows`, each row with its line number; the warnings only if ``warn``."""
    say = _log.warning if warn else _silent
    rows: list[tuple[int, dict[str, Any]]] = []
    if not path.exists():
        return rows
    # an editor's UTF-8 "signature" (a BOM) made the first row no JSON row: skipped
    data = _read(path).removeprefix(codecs.BOM_UTF8)
    lines = data.splitlines()
    first: dict[object, int] = {}
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            row = json.loads(line.decode("utf-8"))
        except (ValueError, RecursionError):  # not UTF-8, not JSON, nested past the stack
            cut = number == len(lines) and not data.endswith((b"\n", b"\r"))
            what = "a cut line" if cut else "a line that is not a JSON row"
            say("%s:%d: skipped %s", path, number, what)
            continue
        problem = row_problem(row)
        if problem is not None:
            say("%s:%d: skipped a row that is not a case's result: %s", path, number, problem)
            continue
        if row["id"] in first:
            say(
                "%s:%d: skipped a second row for case %s (the first is line %d)",
                path,
                number,
                row["id"],
                first[row["id"]],
            )
            continue
        first[row["id"]] = number
        rows.append((number, row))
    return rows


_RESUME_OTHER = (
    f"{RESUME} continues the campaign that wrote them: give the same spec, or another {OUTPUT}"
)


def check_output(
    output: Path, resume: bool = False, cases: list[dict[str, Any]] | None = None
) -> list[dict[str, Any]]:
    """Make the output folder (if missing) and check that it can take this campaign's rows.

    Called before any worker starts, so that a bad ``--output`` costs nothing. It
    warns about no line of the results file: :func:`run_cases` reads them.

    Args:
        output: The campaign's folder.
        resume: Whether the rows there are to be continued.
        cases: The campaign's cases: with ``resume``, every row there must be one
            of them (its ``id`` and its ``index``).

    Raises:
        InputError: ``output`` is a file, or cannot be made; its results file is
            not a file; it holds any line and ``resume`` is off; with ``resume``,
            it holds a row that is not one of ``cases``.

    Returns:
        The rows there already that the campaign keeps (with ``resume``), else none.
    """
    return _check_output(output, resume, cases, quiet=True)


def _check_output(
    output: Path, resume: bool, cases: list[dict[str, Any]] | None, *, quiet: bool
) -> list[dict[str, Any]]:
    """:func:`check_output`; the rows to keep (``resume``: read, with warnings unless ``quiet``)."""
    if output.exists() and not output.is_dir():
        raise InputError(f"{output}: the output is a file, not a folder; give another {OUTPUT}")
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(
            f"{output}: cannot make the output folder: {exc.strerror or exc}"
        ) from None
    results = output / RESULTS_NAME
    if results.exists() and not results.is_file():
        raise InputError(f"{results}: not a file; give another {OUTPUT}")
    _check_fixed_names(output)
    if not resume:
        # Any line at all, even none a row: never overwrite what someone else may need.
        lines = _read(results).splitlines() if results.exists() else []
        written = sum(1 for line in lines if line.strip())
        if written:
            raise InputError(
                f"{results} holds {written} line{'s' if written != 1 else ''} already;"
                f" use {RESUME}, or another {OUTPUT}"
            )
        _check_no_report(output)
        return []
    numbered = _numbered_rows(results, warn=not quiet)
    if cases is not None:
        _check_ours(results, numbered, cases)
    if not numbered:
        _check_no_report(output)
    return [row for _line, row in numbered]


def _check_no_report(output: Path) -> None:
    """Refuse a folder without rows that holds a file the report would replace.

    A campaign's report is written with its rows: where there is none, and no
    record of a campaign started there (``campaign.json``), a ``report.md`` or
    ``results.csv`` is someone else's (``--output .`` in a project), and it was
    overwritten without a word when the campaign ended.
    """
    if holds_a_record(output):  # one no campaign wrote is refused
        return
    for name in _REPORT:
        if (output / name).exists():
            raise InputError(
                f"{output / name}: the campaign's report would replace it, and it is no"
                f" campaign's ({output} holds no row, nor {RECORD_NAME}); move it, or give another"
                f" {OUTPUT}"
            )


_REPORT = (
    "results.csv",
    "report.md",
    "report.html",
    *(f"success_vs_{key}.png" for key in ("drop", "corrupt", "dup")),
)
REPORT_FILES = (RESULTS_NAME + ".part", RECORD_NAME, *_REPORT)
"""The files a campaign writes into its output folder besides ``results.jsonl`` (the
record of how it started, :mod:`pirate_bt.campaign.started`, and the report)."""


def _check_fixed_names(output: Path) -> None:
    """Refuse an output folder a campaign could not finish writing, before any case runs.

    Without it, a ``traces`` that is a file made every case an ``error`` row
    (``FileExistsError``) and a ``report.md`` that is a folder failed the command
    after every case had run.
    """
    traces = output / "traces"
    if traces.exists() and not traces.is_dir():
        raise InputError(
            f"{traces}: not a folder (the kept traces go there); give another {OUTPUT}"
        )
    for name in REPORT_FILES:
        path = output / name
        if path.exists() and not path.is_file():
            raise InputError(f"{path}: not a file (the campaign writes it); give another {OUTPUT}")
    if not os.access(output, os.W_OK | os.X_OK):
        raise InputError(f"{output}: cannot write in the output folder; give another {OUTPUT}")


def _check_ours(
    results: Path, numbered: list[tuple[int, dict[str, Any]]], cases: list[dict[str, Any]]
) -> None:
    """Refuse rows that are not cases of this campaign (its ``id`` and its ``index``)."""
    wanted = {c.get("id"): c.get("index") for c in cases}
    foreign = [
        line
        for line, row in numbered
        if row["id"] not in wanted or row.get("index") != wanted[row["id"]]
    ]
    if foreign:
        n, total = len(foreign), len(numbered)
        what = "row of {} is not a case" if n == 1 else "rows of {} are not cases"
        raise InputError(
            f"{results}:{foreign[0]}: {n} {what.format(total)} of this campaign; {_RESUME_OTHER}"
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
        resume: Skip the cases whose ids already have a row; every row there must
            be one of ``cases`` (its ``id`` and its ``index``).
        on_record: Called with every new record (the progress bar).
        target: The case function (``module:function``).

    Returns:
        Every row of the campaign (old and new), in case order.

    Raises:
        InputError: the folder holds anything and ``resume`` is off; ``resume``
            and a row there that is not one of ``cases`` (another campaign's, or
            an edited spec's: nothing is rewritten); ``resume`` without a folder;
            a case id that is not a safe file name.
    """
    for case in cases:
        safe_name(case.get("id"), "case id")
    if output is None:
        if resume:
            raise InputError("resume needs an output folder to resume from")
        return _collect(cases, [], executor, None, None, on_record, target)
    # Read once, warning about each line skipped; every row left is one of the cases.
    old = _check_output(output, resume, cases, quiet=False)
    results = output / RESULTS_NAME
    # Rewrite without a cut last line, so every appended row starts on its own line.
    text = "".join(json.dumps(r, allow_nan=False) + "\n" for r in old)
    part = results.with_name(results.name + ".part")
    try:
        part.write_text(text, encoding="utf-8")
        os.replace(part, results)  # never half a results file, even if stopped right here
    except OSError as exc:  # a full disk: it said "No space left on device", no file
        part.unlink(missing_ok=True)
        raise InputError(
            f"{results}: cannot rewrite it to resume: {exc.strerror or exc}; it is as it"
            f" was: make room, then run again with {RESUME}"
        ) from None
    trace_dir = str((output / "traces").resolve())
    return _collect(cases, old, executor, results, trace_dir, on_record, target)


_FRUITLESS = 3
"""Pool replacements in a row after which the local pool is given up: none of them
ran a case, and none lost one (a worker that dies as it starts)."""

LOST_REASON = (
    "worker lost: the local worker process running the case died (killed from outside?);"
    " the pool was replaced and the other cases ran on"
)


def _seed_major(case: dict[str, Any]) -> tuple[Any, Any]:
    return case["seed"], case["index"]


def _collect(
    cases: list[dict[str, Any]],
    old: list[dict[str, Any]],
    executor: Executor,
    results: Path | None,
    trace_dir: str | None,
    on_record: Callable[[dict[str, Any]], None] | None,
    target: str,
) -> list[dict[str, Any]]:
    """Submit the cases not in ``old``, gather their records (appended to ``results``).

    A broken local pool (:class:`LocalPool`, a worker killed) costs only the case
    that was running in the dead worker: the pool is replaced and the other cases
    it failed are submitted again, at most once per case of the campaign, and not
    when replacing it ran nothing :data:`_FRUITLESS` times in a row.
    """
    done = {r["id"] for r in old}
    # Seed-major order: every group gets its first seeds before any gets its last,
    # so a campaign stopped early still covers the whole matrix evenly.
    todo = sorted((c for c in cases if c["id"] not in done), key=_seed_major)
    rows = list(old)
    futures: dict[Future[dict[str, Any]], dict[str, Any]] = {}
    pool = executor if isinstance(executor, LocalPool) else None
    fruitless = 0
    most = len(todo)  # pool replacements, at most
    unrun = 0  # cancelled by the executor, never run: no row (cancelled.py)
    try:
        with contextlib.ExitStack() as stack:
            sink = stack.enter_context(RowSink(results)) if results else None

            def keep(record: dict[str, Any]) -> None:
                if sink is not None:
                    sink.write(record)  # a whole line, or none and an InputError
                rows.append(record)
                if on_record is not None:
                    on_record(record)

            while todo:
                futures = {executor.submit(run_isolated, c, trace_dir, target): c for c in todo}
                broken: list[Future[dict[str, Any]]] = []
                ran = 0
                for future in as_completed(futures):
                    case = futures[future]
                    try:
                        record = future.result()
                    except Exception as exc:  # a lost worker, not the case's own doing
                        if pool is not None and isinstance(exc, BrokenProcessPool):
                            broken.append(future)  # lost, or to run again: see below
                            continue
                        if isinstance(exc, CancelledError):
                            unrun += 1
                            continue
                        why = said_of(exc, 1000) or type(exc).__name__
                        record = error_record(case, "error", f"worker lost: {why}", 0.0)
                    ran += 1
                    keep(record)
                todo = []
                if not broken or pool is None:
                    break
                lost = pool.replace(broken)
                fruitless = 0 if ran or lost else fruitless + 1
                give_up = fruitless >= _FRUITLESS or pool.replaced >= most
                for future in broken:
                    case = futures[future]
                    if future in lost:
                        keep(error_record(case, "error", LOST_REASON, 0.0))
                    elif give_up:
                        why = f"worker lost: the local pool broke {pool.replaced} times; gave up"
                        keep(error_record(case, "error", why, 0.0))
                    else:
                        todo.append(case)
                todo.sort(key=_seed_major)
            if unrun:
                raise not_run(results, unrun, len(rows), len(cases))
    except BaseException:
        for future in futures:
            future.cancel()
        raise
    return sorted(rows, key=lambda r: int(r.get("index", 0)))
