"""Expanding a campaign's matrix into cases: plain, picklable, ordered, bounded.

A case is a plain ``dict`` of JSON values (so it crosses a process pipe, a
pickle or a Dask scheduler unchanged). Its ``id`` is its position in the
expansion plus a short digest of its parameters (``000042-1f3a9c0d``), so
``--resume`` can tell a finished case from one of an edited spec; it is a safe
file name whatever the spec says (see :mod:`pirate_bt.campaign.paths`).

Before anything is built, :func:`check_size` counts the cases from the axes'
lengths (the seed range by its count) and refuses a matrix larger than
``max_cases``; :func:`expand` does the same first. The checks of the files a spec
names (:func:`check_inputs`, :func:`check_runs`, :func:`check_faults`) live in
:mod:`pirate_bt.campaign.inputs` and :mod:`pirate_bt.campaign.checks`, and are
named here too.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pirate_bt.campaign.checks import check_axes, check_faults, check_runs
from pirate_bt.campaign.inputs import check_inputs, resolve_name, source_of
from pirate_bt.campaign.paths import OUTPUT
from pirate_bt.campaign.spec import CampaignSpec
from pirate_bt.errors import ArgumentValueError

__all__ = [
    "DEFAULT_MAX_CASES",
    "MAX_CASES_CEILING",
    "Case",
    "check_axes",
    "check_faults",
    "check_inputs",
    "check_runs",
    "check_size",
    "expand",
    "group_key",
    "param_text",
]

Case = dict[str, Any]

DEFAULT_MAX_CASES = 100_000
"""The most cases a campaign may expand to unless the caller allows more."""

MAX_CASES_CEILING = 1_000_000
"""The most a caller may allow: every case and its row are held in memory (about
1 kB and a few kB each), so a limit raised to 10**9 let a spec of that size fill the
machine's memory as it expanded instead of being refused."""


def check_max_cases(max_cases: int, name: str = "max_cases") -> None:
    """Refuse a limit below 1 or above :data:`MAX_CASES_CEILING`, naming ``name``.

    Raises:
        ArgumentValueError: one line (``--max-cases: at most 1,000,000 cases ...``), an
            :class:`~pirate_bt.errors.InputError` and a ``ValueError``.
    """
    if max_cases < 1:
        raise ArgumentValueError(f"{name} must be at least 1")
    if max_cases > MAX_CASES_CEILING:
        raise ArgumentValueError(
            f"{name}: at most {MAX_CASES_CEILING:,} cases, not {max_cases:,} (every case and"
            " its row are held in memory): split a larger campaign into several by"
            f" seeds.start, each into its own {'--output' if name.startswith('--') else OUTPUT}"
        )


# The parameters that define a group: every case parameter but the seed.
GROUP_FIELDS = ("run", "robot", "map", "sim_faults", "drop", "corrupt", "dup")


def check_size(spec: CampaignSpec, max_cases: int = DEFAULT_MAX_CASES) -> int:
    """How many cases ``spec`` expands to, counted from its axes without expanding them.

    Args:
        spec: The campaign.
        max_cases: The most cases allowed.

    Returns:
        The number of cases.

    Raises:
        InputError: more than ``max_cases``; one line naming the spec's file and
            the place of its longest axis (``big.campaign.yaml:9:17: the campaign
            expands to 1,000,000,000 cases, more than the limit of 100,000
            (max_cases): ...``). A :class:`~pirate_bt.errors.LocatedError` for a file.
        ArgumentValueError: ``max_cases`` is below 1 or above :data:`MAX_CASES_CEILING`
            (an ``InputError`` and a ``ValueError``).
    """
    check_max_cases(max_cases)
    total = spec.size()
    if total <= max_cases:
        return total
    axes = spec.axes()
    longest, _ = max(axes, key=lambda axis: axis[1])
    factors = " × ".join(f"{'.'.join(path)} {n:,}" for path, n in axes if n > 1)
    raise source_of(spec).error(
        longest,
        f"the campaign expands to {total:,} cases, more than the limit of {max_cases:,}"
        f" (max_cases): {factors}",
    )


def param_text(value: str | bool | int | float) -> str:
    """A run's parameter as the text a case passes on (``true``, not ``True`` or ``1``)."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def expand(
    spec: CampaignSpec, base: Path | None = None, *, max_cases: int = DEFAULT_MAX_CASES
) -> list[Case]:
    """Every case of the matrix, in a fixed order.

    Args:
        spec: The campaign.
        base: The campaign file's folder; file names resolve against it first,
            then as given (the working folder, then the bundled files). Default:
            the folder the spec was loaded from (the working folder for data).
        max_cases: The most cases allowed (:func:`check_size`, checked first).

    Returns:
        The cases.

    Raises:
        InputError: the matrix has more than ``max_cases`` cases.
    """
    check_size(spec, max_cases)
    folder = base if base is not None else source_of(spec).base
    max_time_s = spec.quantity("max_time", "time")
    timeout_s = spec.quantity("case_timeout", "time")
    period_s = 1.0 / spec.quantity("rate", "frequency")
    link_grid = list(itertools.product(spec.link.drop, spec.link.corrupt, spec.link.dup))
    # One resolved string per name, shared by every case that names it.
    resolved: dict[str | None, str | None] = {}

    def resolve(name: str | None) -> str | None:
        if name not in resolved:
            resolved[name] = resolve_name(name, folder)
        return resolved[name]

    cases: list[Case] = []
    axes = itertools.product(spec.runs, spec.robots, spec.maps, spec.sim_faults, link_grid)
    built = spec.as_built
    variants: list[int | None] = (
        [None] if built is None else list(range(built.first, built.first + built.count))
    )
    for run, robot, truth, sim_faults, (drop, corrupt, dup) in axes:
        params = {k: param_text(v) for k, v in sorted(run.params.items())}
        if run.navigator is not None:  # its file parameters, as a tree's or a route's name
            params.update(_navigator_files(run.navigator, params, resolve))
        for variant, seed in itertools.product(
            variants, range(spec.seeds.start, spec.seeds.start + spec.seeds.count)
        ):
            case: Case = {
                "index": len(cases),
                "run": run.label,
                "tree": resolve(run.tree),
                "route": resolve(run.route),
                "network": resolve(run.network),
                "params": dict(params),
                "robot": resolve(robot),
                "map": resolve(truth),
                "sim_faults": list(sim_faults),
                "drop": drop,
                "corrupt": corrupt,
                "dup": dup,
                "seed": seed,
                "max_time_s": max_time_s,
                "timeout_s": timeout_s,
                "period_s": period_s,
                "keep_traces": spec.keep_traces,
            }
            # only when given: the ids of campaigns without them stay as they were
            if run.navigator is not None:
                case["navigator"] = run.navigator
                case["blind"] = run.blind
            if built is not None:
                case["as_built"] = variant
                case["as_built_scale"] = built.scale
            digest = hashlib.sha256(json.dumps(case, sort_keys=True).encode()).hexdigest()
            # The index and a hex digest: always a safe file name (traces/ID).
            case["id"] = f"{case['index']:06d}-{digest[:8]}"
            cases.append(case)
    return cases


def group_key(row: dict[str, Any], *, full: bool = False) -> str:
    """One line naming a case's group (every parameter but the seed); a robot and a
    truth by their file's stem and numbers to 6 digits, or with ``full`` as the row
    names them and in full (two files of one name in two folders; ``drop`` 0.1 and
    0.1000001)."""
    parts = [str(row.get("run"))]
    if row.get("blind"):
        parts.append("blind")
    for key, said in (("robot", "robot"), ("map", "truth")):
        if row.get(key):
            parts.append(f"{said}={row[key] if full else Path(str(row[key])).stem}")
    number = repr if full else (lambda x: f"{x:g}")
    if row.get("as_built") is not None:  # the variants of a group are its runs, like seeds
        parts.append(f"as-built x{number(float(row.get('as_built_scale') or 1.0))}")
    if row.get("sim_faults"):
        parts.append("+".join(row["sim_faults"]))
    # a row's rates may be null (a record made without its case): read as none
    rates = {k: number(float(row.get(k) or 0)) for k in ("drop", "corrupt", "dup")}
    parts.append(f"drop={rates['drop']} corrupt={rates['corrupt']} dup={rates['dup']}")
    return " ".join(parts)


def _navigator_files(
    navigator: str, params: dict[str, str], resolve: Callable[[str | None], str | None]
) -> dict[str, str]:
    """A navigator run's parameters that name a file (``route``'s ``route``,
    ``explore``'s ``extend``), resolved against the spec's folder when a file is there:
    they were read from the working folder, so a spec run from elsewhere did not find
    the route beside it."""
    from pirate_bt.task.navigators import navigator_file_params

    out: dict[str, str] = {}
    for key in navigator_file_params(navigator) & params.keys():
        found = resolve(params[key])
        if found is not None:
            out[key] = found
    return out
