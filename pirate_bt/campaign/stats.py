"""Statistics of campaign rows: rates with Wilson intervals, percentiles, groups."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pirate_bt.campaign.cases import group_key

__all__ = ["Counts", "GroupStats", "group_stats", "percentile", "wilson_interval"]

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

    @property
    def success_rate(self) -> float:
        return self.success / self.n if self.n else 0.0

    @property
    def failed_safe_rate(self) -> float:
        return self.failed_safe / self.n if self.n else 0.0

    @property
    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.success, self.n)


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
