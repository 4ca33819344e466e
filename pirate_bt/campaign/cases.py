"""Expanding a campaign's matrix into cases: plain, picklable, ordered.

A case is a plain ``dict`` of JSON values (so it crosses a process pipe, a
pickle or a Dask scheduler unchanged). Its ``id`` is its position in the
expansion plus a short digest of its parameters, so ``--resume`` can tell a
finished case from one of an edited spec.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from pathlib import Path
from typing import Any

from pirate_bt.campaign.spec import CampaignSpec

__all__ = ["Case", "check_runs", "expand", "group_key"]

Case = dict[str, Any]

# The parameters that define a group: every case parameter but the seed.
GROUP_FIELDS = ("run", "robot", "map", "sim_faults", "drop", "corrupt", "dup")


def _resolve(name: str | None, base: Path) -> str | None:
    """A path relative to the campaign file, when it exists there; else as written."""
    if name is None:
        return None
    candidate = base / name
    return str(candidate.resolve()) if candidate.exists() else name


def expand(spec: CampaignSpec, base: Path | None = None) -> list[Case]:
    """Every case of the matrix, in a fixed order.

    Args:
        spec: The campaign.
        base: The campaign file's folder; file names resolve against it first,
            then as given (the working folder, then the bundled files).

    Returns:
        The cases.
    """
    folder = base or Path(".")
    max_time_s = spec.quantity("max_time", "time")
    timeout_s = spec.quantity("case_timeout", "time")
    period_s = 1.0 / spec.quantity("rate", "frequency")
    link_grid = list(itertools.product(spec.link.drop, spec.link.corrupt, spec.link.dup))
    cases: list[Case] = []
    axes = itertools.product(spec.runs, spec.robots, spec.maps, spec.sim_faults, link_grid)
    for run, robot, truth, sim_faults, (drop, corrupt, dup) in axes:
        for seed in range(spec.seeds.start, spec.seeds.start + spec.seeds.count):
            case: Case = {
                "index": len(cases),
                "run": run.label,
                "tree": _resolve(run.tree, folder),
                "route": _resolve(run.route, folder),
                "network": _resolve(run.network, folder),
                "params": {k: str(v) for k, v in sorted(run.params.items())},
                "robot": _resolve(robot, folder),
                "map": _resolve(truth, folder),
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
            digest = hashlib.sha256(json.dumps(case, sort_keys=True).encode()).hexdigest()
            case["id"] = f"{case['index']:06d}-{digest[:8]}"
            cases.append(case)
    return cases


def group_key(row: dict[str, Any]) -> str:
    """One line naming a case's group (every parameter but the seed)."""
    parts = [str(row.get("run"))]
    if row.get("robot"):
        parts.append(f"robot={Path(str(row['robot'])).stem}")
    if row.get("map"):
        parts.append(f"truth={Path(str(row['map'])).stem}")
    if row.get("sim_faults"):
        parts.append("+".join(row["sim_faults"]))
    parts.append(f"drop={row.get('drop', 0):g} corrupt={row.get('corrupt', 0):g}")
    parts[-1] += f" dup={row.get('dup', 0):g}"
    return " ".join(parts)


def check_runs(cases: list[Case]) -> None:
    """Load every distinct tree (with its parameters) and route once, before any case runs.

    Bad input is the campaign's fault, not a case outcome: it stops the campaign
    with exit 2 and a located error instead of a thousand ``error`` rows.

    Raises:
        ValidationFailed: a tree or route does not validate.
        ConfigurationError: a file is missing.
    """
    from pirate_bt.filekinds import validate_file
    from pirate_bt.resources import find_file

    seen: set[str] = set()
    for case in cases:
        key = json.dumps([case["tree"], case["route"], case["params"]], sort_keys=True)
        if key in seen:
            continue
        seen.add(key)
        if case["tree"]:
            validate_file(find_file("trees", case["tree"]), "tree", case["params"] or None)
        else:
            validate_file(find_file("scenarios", case["route"]), "route")
