"""A whole campaign from Python: :func:`run_campaign` and its :class:`CampaignResult`.

``pirate-bt campaign SPEC`` is this function with options parsed and results
printed::

    from pirate_bt.campaign import run_campaign

    result = run_campaign(
        {"name": "smoke", "runs": [{"tree": "straight", "params": {"distance": "0.2 m"}}],
         "seeds": {"count": 3}},
        workers=2,
    )
    print(result.counts["success"], result.groups[0].interval)

The order is fixed so that a bad spec costs nothing: the spec is checked, its
size is counted from its axes (:func:`~pirate_bt.campaign.cases.check_size`),
its input files are checked, the cases are expanded and their trees and routes
validated, and only then does an executor start and a file get written.
"""

from __future__ import annotations

import logging
import os
import shlex
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Executor
from contextlib import ExitStack, contextmanager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pirate_bt.atomic import new_folders_undone
from pirate_bt.campaign.case import OUTCOMES
from pirate_bt.campaign.cases import (
    DEFAULT_MAX_CASES,
    check_axes,
    check_faults,
    check_inputs,
    check_max_cases,
    check_runs,
    check_size,
    expand,
)
from pirate_bt.campaign.engine import DEFAULT_TARGET, check_output, make_executor, run_cases
from pirate_bt.campaign.loads import Loads
from pirate_bt.campaign.options import case_timeout_s, check_options, check_target, given_path
from pirate_bt.campaign.paths import RESULTS_NAME, campaign_lock, slug
from pirate_bt.campaign.spec import (
    CampaignSpec,
    SpecSource,
    campaign_from_data,
    load_campaign,
    spec_source,
)
from pirate_bt.campaign.started import Start, begin, write_record
from pirate_bt.campaign.stats import Counts, GroupStats, group_stats, note_repeated_seeds
from pirate_bt.campaign.unrecorded import drop_unrecorded_traces
from pirate_bt.errors import InputError

__all__ = [
    "CampaignResult",
    "SpecInput",
    "case_timeout_s",
    "checked_cases",
    "default_output",
    "load_spec",
    "run_campaign",
    "validate_campaign_file",
]

SpecInput = str | os.PathLike[str] | Mapping[str, Any] | CampaignSpec
"""What :func:`run_campaign` takes as a spec: a file, plain data or a model."""


@dataclass(frozen=True)
class CampaignResult:
    """What a campaign did.

    Attributes:
        name: The campaign's name.
        rows: One record per case (the rows of ``results.jsonl``), in case order;
            with ``resume``, the rows of earlier runs too.
        groups: Per-group statistics (every parameter but the seed), in the
            order groups first appear: runs, success rate and its 95 % Wilson
            interval (``interval``), failed-safe rate, errors, timeouts,
            violations, damage, simulated times, failure reasons and nodes.
        counts: Cases per outcome; every outcome of
            :data:`~pirate_bt.campaign.case.OUTCOMES` is a key (0 if none).
        violations: Simulator invariant violations, summed over the cases.
        damage: Simulator damage events, summed over the cases.
        output: The folder written, or ``None`` when nothing was written.
        report_path: ``OUTPUT/report.md``, or ``None`` without an output folder.
        files: The report files written (``report.md``, ``report.html``,
            ``results.csv``, plots); empty without an output folder.
        executor: What ran the cases (``2 local workers``, ``Dask cluster at ...``).
        wall_s: Wall time of the whole call, in seconds.
    """

    name: str
    rows: tuple[dict[str, Any], ...]
    groups: tuple[GroupStats, ...]
    counts: Mapping[str, int]
    violations: int
    damage: int
    output: Path | None
    report_path: Path | None
    files: tuple[Path, ...]
    executor: str
    wall_s: float

    @property
    def cases(self) -> int:
        """How many cases have a row."""
        return len(self.rows)

    @property
    def succeeded(self) -> bool:
        """Whether the campaign is clean: at least one case, every case ``success``,
        and no simulator violation or damage in any of them.

        ``False`` as soon as one case failed safe, errored or timed out. (The
        command's exit status does not depend on it: 0 means the campaign ran.)
        """
        return (
            bool(self.rows)
            and self.counts.get("success", 0) == len(self.rows)
            and self.violations == 0
            and self.damage == 0
        )

    def __repr__(self) -> str:
        """A short summary (what ``print(result)`` shows): the name, the cases by
        outcome, the groups, violations, damage and where it was written; the rows
        are in :attr:`rows` (the dataclass's own repr printed every row with its
        coverage, some 2,000 characters a case: megabytes for a large campaign)."""
        counts = ", ".join(f"{n} {outcome}" for outcome, n in self.counts.items() if n)
        output = None if self.output is None else str(self.output)
        return (
            f"{type(self).__name__}(name={self.name!r}, cases={len(self.rows)}"
            f" ({counts or 'none'}), groups={len(self.groups)}, violations={self.violations},"
            f" damage={self.damage}, succeeded={self.succeeded}, output={output!r},"
            f" executor={self.executor!r}, wall_s={self.wall_s:.2f})"
        )

    def summary(self) -> str:
        """One line: ``N runs: S success, F failed safe, E error, T timeout``."""
        c = self.counts
        return (
            f"{len(self.rows)} runs: {c['success']} success, {c['failed-safe']} failed safe,"
            f" {c['error']} error, {c['timeout']} timeout"
        )


def default_output(spec: CampaignSpec) -> Path:
    """The command's default output folder, ``campaign-NAME``, with NAME as a safe name."""
    return Path(f"campaign-{slug(spec.name)}")


def load_spec(spec: SpecInput, base: str | os.PathLike[str] | None = None) -> CampaignSpec:
    """A checked :class:`CampaignSpec` from a file, plain data or a model.

    Args:
        spec: A ``.campaign.yaml`` path, a mapping as the YAML would load, or a model.
        base: For data and models: the folder relative file names resolve
            against first (default: the working folder). Ignored for a file
            (its own folder).

    Raises:
        InputError: the spec does not load or validate (located for a file).
    """
    if isinstance(spec, CampaignSpec):
        if base is None:
            return spec
        # The same model, with the folder its names resolve against.
        return campaign_from_data(spec.model_dump(), base=base)
    if isinstance(spec, Mapping):
        return campaign_from_data(spec, base=base)
    if isinstance(spec, (str, os.PathLike)):
        path = given_path(spec, "spec")
        try:
            return load_campaign(path)
        except OSError as exc:  # a name the system refuses (a part too long)
            raise InputError(f"spec: cannot read {str(path)[:80]!r}: {exc.strerror}") from None
    raise NotASpec(
        f"spec: a campaign spec is a path, a mapping or a CampaignSpec, not {spec!r}"[:200]
    )


def checked_cases(
    model: CampaignSpec, base: Path | None, max_cases: int = DEFAULT_MAX_CASES
) -> list[dict[str, Any]]:
    """The cases of ``model``, after every check made before a worker starts: no
    axis names one point twice, the files it names, each distinct tree loaded with
    its parameters against each robot, each route planned on its map and each
    network, the simulator faults (see :func:`run_campaign`).

    Raises:
        InputError: the first problem (:class:`~pirate_bt.errors.ValidationFailed`
            for a file, each problem at its place).
        ConfigurationError: a named file is missing or not a file.
    """
    return _checked(model, base, max_cases)[0]


def _checked(
    model: CampaignSpec, base: Path | None, max_cases: int, timeout_s: float | None = None
) -> tuple[list[dict[str, Any]], list[Path]]:
    """:func:`checked_cases`, and the input files the checks read (what a resume checks);
    ``timeout_s``, a case timeout given beside the spec's."""
    loads = Loads()  # each robot and each tree with its parameters loaded once
    check_axes(model, base, loads)
    check_inputs(model, base)
    cases = expand(model, base, max_cases=max_cases)
    inputs = check_runs(cases, model, base, timeout_s, loads)
    check_faults(model, base, loads)
    note_repeated_seeds(cases)  # 30 seeds of a run that draws nothing are one run
    return cases, inputs


def validate_campaign_file(path: str | Path) -> CampaignSpec:
    """``pirate-bt validate SPEC.campaign.yaml``: the spec, and every check
    ``pirate-bt campaign`` makes before it runs a case (:func:`checked_cases`), so a
    spec that validates is one the campaign does not refuse for its input."""
    model = load_campaign(path)
    source = spec_source(model)
    check_size(model)
    checked_cases(model, source.base if source is not None else Path(path).parent)
    return model


class NotASpec(InputError, TypeError):
    """A campaign spec of the wrong type (also a ``TypeError``, as it always was)."""


@contextmanager
def _given(executor: Executor) -> Iterator[tuple[Executor, str]]:
    yield executor, f"the given executor ({type(executor).__name__})"


@contextmanager
def _nothing_to_run() -> Iterator[tuple[Executor, str]]:
    """No executor for a resume with every case done: no pool started, no cluster
    reached (the base class's ``submit`` refuses, and nothing is submitted)."""
    yield Executor(), "no worker (every case was done)"


def run_campaign(
    spec: SpecInput,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    scheduler_file: str | os.PathLike[str] | None = None,
    scheduler_timeout: str | float = 10.0,
    executor: Executor | None = None,
    output: str | os.PathLike[str] | None = None,
    resume: bool = False,
    case_timeout: str | float | None = None,
    max_cases: int = DEFAULT_MAX_CASES,
    base: str | os.PathLike[str] | None = None,
    progress: bool = False,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    echo: Callable[[str], None] | None = None,
    command: str | None = None,
    target: str = DEFAULT_TARGET,
) -> CampaignResult:
    """Run a campaign: every case in its own process, then the statistics and the report.

    Args:
        spec: A ``*.campaign.yaml`` path, a mapping (as the YAML would load), or a
            :class:`CampaignSpec`. Relative file names in a file resolve against
            its folder, then as given (the working folder), then the bundled
            files; in data or a model, against ``base`` (default: the working
            folder), then the bundled files.
        workers: Local worker processes (default: one per core); refused beside a
            scheduler or an executor, which have workers of their own.
        scheduler: A Dask scheduler address (``tcp://host:8786``) instead.
        scheduler_file: A Dask scheduler file instead.
        scheduler_timeout: How long to try to reach the scheduler, then to wait for a
            worker there (``"30 s"`` or seconds; default 10 s; LinkError after it).
        executor: A ``concurrent.futures`` executor of your own instead (it is not
            shut down here).
        output: The folder for ``results.jsonl``, ``traces/`` and the report.
            ``None`` (the default) writes nothing at all: no rows, no traces, no
            report; the result holds the rows and statistics.
        resume: Run only the cases without a row in ``output`` (needs ``output``);
            every row there must be one of this spec's cases, every input file
            the same as when the campaign started there (its SHA-256 in
            ``output/campaign.json``), and ``case_timeout``, if given, the one it
            started with (else refused before any worker starts, nothing
            rewritten; see :mod:`pirate_bt.campaign.started`). Without it an
            output folder whose results file holds any line is refused.
        case_timeout: Wall-time limit per case, overriding the spec's
            (``"90 s"`` or seconds). With ``resume``, left out: the one the
            campaign started with.
        max_cases: The most cases the spec may expand to; counted from its axes
            before anything is built (see :func:`~pirate_bt.campaign.cases.check_size`).
        base: Where relative names of a spec given as data resolve.
        progress: Show a progress bar (tqdm, on standard error).
        on_record: Called with each case's record as it arrives, ``on_record(row)``.
        echo: Called with one line before the cases start, ``echo(line)``
            (``campaign NAME: N cases on WHAT -> OUTPUT``); the command passes ``print``.
        command: The command that reproduces the campaign, for the report (default
            for a file: ``pirate-bt campaign FILE [--workers N]``).
        target: The case function each case process calls (``module:function``);
            tests point it elsewhere.

    Returns:
        CampaignResult: The rows, per-group statistics and counts.

    Raises:
        ArgumentTypeError: an ``on_record`` or ``echo`` that cannot be called with one
            argument, or is an ``async def`` (before the spec is read; an InputError).
        InputError: a bad spec or option (one line each, located in a file): it
            does not validate, an axis names a point twice, it expands past
            ``max_cases``, a named input file is missing or not a file, a tree or
            route does not validate (against every robot of the axis), a route does
            not fit its run's network, the output folder holds anything without
            ``resume`` or, with it, rows of another campaign, an input file changed
            since the campaign started there or another ``case_timeout``, Dask is
            missing or unreachable; a simulator fault due after ``max_time``; a
            folder without rows holding a report file of someone else's; a row or
            report file the disk has no room for (the rows before it stay).
        ConfigurationError: a named input file is missing (seen in the cases).
        KeyboardInterrupt: Ctrl-C; the rows written so far stay in ``output``,
            cases in flight are not recorded; run again with ``resume=True``.

    Example::

        result = pirate_bt.run_campaign(
            {"name": "smoke", "seeds": {"count": 20}, "link": {"drop": [0.0, 0.1]},
             "runs": [{"tree": "straight", "params": {"distance": "0.2 m"}}]},
            workers=2,                      # output=None: nothing written
        )
        print(result.summary())             # 40 runs: S success, F failed safe, ...
        for group in result.groups:
            print(group.key, group.success_rate, group.interval)

    The cases run in worker processes: where they are spawned (macOS, Windows),
    call it under ``if __name__ == "__main__":``.
    """
    started = time.perf_counter()
    checked = check_options(
        {
            "workers": workers,
            "max_cases": max_cases,
            "resume": resume,
            "progress": progress,
            "on_record": on_record,
            "echo": echo,
            "scheduler": scheduler,
            "command": command,
            "target": target,
            "scheduler_file": scheduler_file,
            "output": output,
            "base": base,
            "executor": executor,
        }
    )
    # as checked: a NumPy number or truth value as the Python one
    workers, max_cases = checked["workers"], checked["max_cases"]
    resume, progress = checked["resume"], checked["progress"]
    if workers is not None and workers < 1:
        raise InputError("workers must be at least 1")
    check_max_cases(max_cases)
    where_to = {"scheduler": scheduler, "scheduler_file": scheduler_file, "executor": executor}
    chosen = [name for name, value in where_to.items() if value is not None]
    if len(chosen) > 1:
        raise InputError(f"give at most one of {' and '.join(chosen)}")
    check_target(target, cluster=bool(chosen) and executor is None)
    if chosen and workers is not None:
        # it was silently dropped: the cluster or the executor has workers of its own
        raise InputError(
            f"workers is the local pool's size; with {chosen[0]} the cases run on its own"
            " workers (give one or the other)"
        )
    if resume and output is None:
        raise InputError("resume needs an output folder")
    model = load_spec(spec, base)
    source = spec_source(model) or SpecSource(f"campaign {model.name!r}", Path(base or "."))
    count = check_size(model, max_cases)  # before anything is built
    timeout_s = case_timeout_s(case_timeout)
    reach_s = case_timeout_s(scheduler_timeout, "scheduler_timeout") or 10.0  # at most a week
    cases, inputs = _checked(model, source.base, max_cases, timeout_s)
    folder = Path(output) if output is not None else None
    start = Start(timeout_s, None)
    before: list[dict[str, Any]] = []  # the rows a resume keeps
    # the folders this call makes are taken away again if it fails before writing in
    # them (a scheduler nobody answers left an empty campaign-NAME/ behind)
    undone = new_folders_undone(folder) if folder is not None else nullcontext()
    with undone, ExitStack() as lock:
        if folder is not None:
            if resume and not (folder / RESULTS_NAME).is_file():  # a typo in --output?
                logging.getLogger("pirate_bt.campaign").warning(
                    "%s: nothing to resume (no %s there): every case runs", folder, RESULTS_NAME
                )
            check_output(folder, resume, cases)  # before any worker starts, warning of no line
            # one campaign at a time in a folder: two started together both passed the
            # check above and one's rows were lost; checked again once it is ours
            lock.enter_context(campaign_lock(folder))
            before = check_output(folder, resume, cases)
            # resumed: the inputs and the case timeout it started with (started.py)
            spec_timeout_s = model.quantity("case_timeout", "time")
            start = begin(folder, resume, inputs, model.name, spec_timeout_s, timeout_s)
        if start.timeout_s is not None:  # not in the ids: the record keeps it
            for case in cases:
                case["timeout_s"] = start.timeout_s
        try:
            return _run(
                model, cases, count, folder, resume, workers, executor, scheduler,
                scheduler_file, reach_s, command, spec, echo, progress, on_record, target,
                started, start.record, before,
            )  # fmt: skip
        except BaseException:  # Ctrl-C, a full disk: no trace without its row (unrecorded.py)
            if folder is not None:
                drop_unrecorded_traces(folder, cases)
            raise


def _run(
    model: Any, cases: list[dict[str, Any]], count: int, folder: Path | None, resume: bool,
    workers: int | None, executor: Any, scheduler: Any, scheduler_file: Any, reach_s: float,
    command: str | None, spec: Any, echo: Any, progress: bool, on_record: Any, target: Any,
    started: float, record: dict[str, Any] | None, before: list[dict[str, Any]],
) -> CampaignResult:  # fmt: skip
    """:func:`run_campaign` once its arguments are checked and its folder is its own;
    ``record``, when given, is written as the cases start (a folder first written);
    ``before``, the rows a resume keeps (the bar and the line count them as done)."""
    if command is None and isinstance(spec, (str, os.PathLike)):
        command = f"pirate-bt campaign {shlex.quote(str(spec))}"
        command += f" --workers {workers}" if workers else ""
    # a resume's bar ended at 6/10 with "ok 6" when all 10 were done: count the kept rows
    counts: Counter[str] = Counter(str(row.get("outcome")) for row in before)
    local = min(workers, max(count, 1)) if workers is not None else None  # no idle processes
    # a resume of a campaign whose every case has its row started a pool (or reached for
    # a cluster) to run nothing: "(8 done, 0 to run) on 1 local worker"
    all_done = bool(before) and len(before) >= count
    if executor is not None:
        where = _given(executor)
    elif all_done:
        where = _nothing_to_run()
    else:
        where = make_executor(
            local, scheduler, None if scheduler_file is None else str(scheduler_file), reach_s
        )
    with where as (pool, what):
        if echo is not None:
            done = f" ({len(before)} done, {count - len(before)} to run)" if before else ""
            on = ": all done, no worker started" if all_done else f" on {what}"
            to = folder or "no output folder"
            echo(f"campaign {model.name}: {count} cases{done}{on} -> {to}")
        from tqdm import tqdm

        bar: Any = tqdm(
            total=count,
            initial=len(before),
            unit="case",
            file=sys.stderr,
            disable=not progress,
            ncols=100,
        )

        def show() -> None:
            bar.set_postfix_str(
                f"ok {counts['success']} safe {counts['failed-safe']}"
                f" err {counts['error']} t/o {counts['timeout']}",
                refresh=False,
            )

        def keep(row: dict[str, Any]) -> None:
            counts[str(row.get("outcome"))] += 1
            bar.update(1)
            show()
            if on_record is not None:
                on_record(row)

        show()

        if folder is not None and record is not None:
            write_record(folder, record)  # here: a scheduler that never answered wrote nothing
        try:
            rows = run_cases(cases, folder, pool, resume=resume, on_record=keep, target=target)
        finally:
            bar.close()
    files: list[Path] = []
    if folder is not None:
        from pirate_bt.campaign.report import write_report

        files = write_report(rows, folder, title=model.name, command=command or "")
    total = Counter({k: 0 for k in OUTCOMES})
    total.update(str(r.get("outcome")) for r in rows)
    return CampaignResult(
        name=model.name,
        rows=tuple(rows),
        groups=tuple(group_stats(rows)),
        counts=Counts(total),
        violations=sum(int(r.get("violations") or 0) for r in rows),
        damage=sum(int(r.get("damage") or 0) for r in rows),
        output=folder,
        report_path=folder / "report.md" if folder is not None else None,
        files=tuple(files),
        executor=what,
        wall_s=time.perf_counter() - started,
    )
