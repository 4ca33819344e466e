"""Statistics of campaign rows: rates with Wilson intervals, percentiles, groups.

A Wilson interval treats a group's runs as independent samples. In a campaign a
case's seed feeds one thing only, the link faults' random draws (:data:`SEEDED`): the
simulator a campaign runs has no sensor noise, and its faults, networks and navigators
draw nothing from the seed. A group with no link fault rate above 0 therefore runs the
same run for every seed, and its 30 seeds are one sample, not 30: its statistics are
over its *distinct runs* (one per as-built variant; one per seed too where the seed
feeds the link), and such a group is *deterministic* when all its runs are one.
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pirate_bt.campaign.cases import group_key

__all__ = [
    "SEEDED",
    "Counts",
    "GroupStats",
    "group_stats",
    "note_repeated_seeds",
    "percentile",
    "run_identity",
    "seed_feeds",
    "success_interval",
    "wilson_interval",
]

_log = logging.getLogger("pirate_bt.campaign")

SEEDED = ("drop", "corrupt", "dup")
"""The case fields whose random draws the seed feeds: the link faults' rates."""

Z95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion (95 % by default).

    Unlike the normal approximation it stays inside [0, 1] and is honest at 0 or
    n successes, which is where a safety case lives (0 violations in n runs).

    Returns:
        ``(low, high)``; ``(0.0, 1.0)`` when ``n`` is 0.
    """
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def seed_feeds(row: Mapping[str, Any]) -> bool:
    """Whether a case's (or row's) seed changes its run: a link fault rate above 0."""
    return any(float(row.get(key) or 0.0) > 0.0 for key in SEEDED)


def run_identity(row: Mapping[str, Any]) -> str:
    """Which run a case (or row) is: its group, its as-built variant, and its seed only
    where the seed feeds something (:func:`seed_feeds`). Two rows of one identity are
    the same run, whatever their seeds."""
    seed = row.get("seed") if seed_feeds(row) else None
    return f"{group_key(dict(row), full=True)}\0{row.get('as_built')!r}\0{seed!r}"


def success_interval(rows: Sequence[Mapping[str, Any]]) -> tuple[float, float]:
    """The 95 % Wilson interval of the success rate of ``rows``, over their distinct
    runs (:func:`run_identity`; a run counts as a success when every row of it is)."""
    runs: dict[str, bool] = {}
    for row in rows:
        key = run_identity(row)
        runs[key] = runs.get(key, True) and row.get("outcome") == "success"
    return wilson_interval(sum(runs.values()), len(runs))


def percentile(values: Sequence[float], q: float) -> float | None:
    """The ``q``-th percentile (0..100) with linear interpolation; ``None`` if empty."""
    if not values:
        return None
    ordered = sorted(values)
    pos = (len(ordered) - 1) * q / 100.0
    low = math.floor(pos)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (pos - low)


@dataclass
class GroupStats:
    """One group of the matrix (every parameter but the seed)."""

    key: str
    params: dict[str, Any]
    n: int = 0
    success: int = 0
    failed_safe: int = 0
    errors: int = 0
    timeouts: int = 0
    violations: int = 0
    damage: int = 0
    sim_times_s: list[float] = field(default_factory=list)
    steps: list[float] = field(default_factory=list)
    """Navigators: the steps of each run."""
    seconds_per_m: list[float] = field(default_factory=list)
    """Navigators: clock seconds per metre driven, of each successful run."""
    reasons: Counter[str] = field(default_factory=Counter)
    nodes: Counter[str] = field(default_factory=Counter)
    runs: dict[str, bool] = field(default_factory=dict, repr=False)
    """Each distinct run (:func:`run_identity`) and whether every row of it succeeded."""

    @property
    def success_rate(self) -> float:
        return self.success / self.n if self.n else 0.0

    @property
    def failed_safe_rate(self) -> float:
        return self.failed_safe / self.n if self.n else 0.0

    @property
    def distinct_runs(self) -> int:
        """How many different runs the group's ``n`` rows are (``n`` when every seed
        drew its own)."""
        return len(self.runs) if self.runs else self.n

    @property
    def deterministic(self) -> bool:
        """Whether the group's rows are all one run (no draw fed by its seeds)."""
        return self.n > 1 and self.distinct_runs == 1

    @property
    def interval(self) -> tuple[float, float]:
        """The 95 % Wilson interval of the success rate, over the distinct runs: a run
        that every seed repeats is one sample (30 identical rows said 88.6–100 %)."""
        if self.distinct_runs >= self.n:
            return wilson_interval(self.success, self.n)
        return wilson_interval(sum(self.runs.values()), len(self.runs))


REASON_CHARS = 1000
"""The most of a failure reason a group keeps (and the report shows): whole, as a rule.
It kept 120 characters and cut the rest without a mark, so the report read *where the
map has no turn* for *... has no turn and no end within 0.61 m*, and two causes that
differ past the 120th character were counted as one."""


def _cause(reason: Any) -> str:
    text = str(reason)
    return text if len(text) <= REASON_CHARS else text[: REASON_CHARS - 1] + "…"


def group_stats(rows: Sequence[dict[str, Any]]) -> list[GroupStats]:
    """Rows gathered by group, in the order groups first appear by case index."""
    groups: dict[str, GroupStats] = {}
    for row in sorted(rows, key=lambda r: int(r.get("index", 0))):
        key = group_key(row)
        params = {k: row.get(k) for k in ("run", "map", "robot", "drop", "corrupt", "dup")}
        # two robots (or truths) of one file name in two folders, or two rates alike to 6
        # digits, are two groups: they were one, of both's runs, under one label
        g = groups.setdefault(group_key(row, full=True), GroupStats(key=key, params=params))
        g.n += 1
        outcome = row.get("outcome")
        identity = run_identity(row)
        g.runs[identity] = g.runs.get(identity, True) and outcome == "success"
        g.success += outcome == "success"
        g.failed_safe += outcome == "failed-safe"
        g.errors += outcome == "error"
        g.timeouts += outcome == "timeout"
        g.violations += int(row.get("violations") or 0)
        g.damage += int(row.get("damage") or 0)
        if row.get("sim_time_s") is not None:
            g.sim_times_s.append(float(row["sim_time_s"]))
        if row.get("steps") is not None:
            g.steps.append(float(row["steps"]))
        distance = row.get("distance_m")
        if outcome == "success" and distance and row.get("sim_time_s") is not None:
            g.seconds_per_m.append(float(row["sim_time_s"]) / float(distance))
        if outcome != "success":
            g.reasons[_cause(row.get("reason"))] += 1
            if row.get("failing_node"):
                g.nodes[str(row["failing_node"])] += 1
    labels = Counter(g.key for g in groups.values())
    for identity, g in groups.items():
        if labels[g.key] > 1:
            g.key = identity
    return list(groups.values())


def note_repeated_seeds(cases: Sequence[Mapping[str, Any]]) -> str | None:
    """One line saying which groups' seeds repeat their runs, or ``None``; logged as a
    warning under ``pirate_bt.campaign``, so ``validate`` and the campaign say it."""
    groups: dict[str, list[Mapping[str, Any]]] = {}
    for case in cases:
        groups.setdefault(group_key(dict(case), full=True), []).append(case)
    repeated = [
        mine
        for mine in groups.values()
        if not seed_feeds(mine[0]) and len({c.get("seed") for c in mine}) > 1
    ]
    if not repeated:
        return None
    mine = repeated[0]
    n, distinct = len(mine), len({run_identity(c) for c in mine})
    seeds = len({c.get("seed") for c in mine})
    more = f" (and {len(repeated) - 1} more groups alike)" if len(repeated) > 1 else ""
    said = f"run {str(mine[0].get('run'))[:80]!r}{more} draws nothing random (no link fault"
    said += " rate above 0, and the simulator has no sensor noise), so its"
    if distinct == 1:
        said = f"the seeds repeat one run: {said} {n} seeds give {n} identical runs"
    else:
        said = f"the seeds repeat runs: {said} {seeds} seeds repeat each of its {distinct} runs"
    note = (
        f"{said}; the report counts {distinct} distinct run{'s' if distinct > 1 else ''},"
        f" not {n} samples: give 'seeds: {{count: 1}}', or a link fault rate above 0"
    )
    _log.warning("%s", note)
    return note


class Counts(Mapping[str, int]):
    """Cases per outcome, read-only, and a result that pickles (a process pool, Dask):
    a ``MappingProxyType`` does not, so a :class:`~pirate_bt.campaign.run.CampaignResult`
    holding one could not be sent back from a worker."""

    __slots__ = ("_counts",)

    def __init__(self, counts: Mapping[str, int]) -> None:
        self._counts = dict(counts)

    def __getitem__(self, key: str) -> int:
        return self._counts[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._counts)

    def __len__(self) -> int:
        return len(self._counts)

    def __repr__(self) -> str:
        return f"Counts({self._counts!r})"

    def __reduce__(self) -> tuple[Any, ...]:
        return (Counts, (self._counts,))
