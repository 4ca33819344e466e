"""One case: a plain function of a plain case that returns a plain record.

:func:`run_case` runs one tree (:func:`pirate_bt.simulate_tree`), one route
(:func:`pirate_bt.simulate_mission`) or one navigator (:func:`pirate_bt.navigate`,
whose record also has its ``steps`` and ``distance_m``) on the simulator through the
public API and returns a ``dict`` of JSON values: the case's parameters, the outcome, the first
cause (``reason``) and where (``failing_node``), the run's
:class:`~pirate_bt.safety.tally.Counters` as flat keys, and its ``coverage``
(:meth:`pirate_bt.trace.coverage.Coverage.as_dict`: per node path, ticks,
transitions, successes, failures, halts and skips). It is what each case
process calls (forked from a case server that has imported :data:`PRELOAD`
once, see :mod:`pirate_bt.campaign.child`); it never raises for a run that
fails, because a failure is an outcome.

Outcomes: ``success``; ``failed-safe`` (the run failed and the supervisor left
the robot in its safe state); ``error`` (the case could not run, a node raised,
the link was lost, or the robot was not left safe); ``timeout`` (killed after
its wall-time limit, set by the engine).
"""

from __future__ import annotations

import errno
import math
import shutil
import time
import traceback
from pathlib import Path
from typing import Any

from pirate_bt.errors import shown

__all__ = [
    "OUTCOMES",
    "PRELOAD",
    "REPORT_PRELOAD",
    "error_record",
    "preload",
    "prepare",
    "row_problem",
    "run_case",
]

OUTCOMES = ("success", "failed-safe", "error", "timeout")

REASON_LIMIT = 4000
"""The most characters of a row's ``reason`` (then cut with ``…``): a navigator that
raised with a 10 MB message wrote a 10 MB row, in ``results.jsonl`` and ``results.csv``
alike, for every case."""


def _bounded(reason: object) -> object:
    """``reason`` cut to :data:`REASON_LIMIT` characters (its start: the first cause)."""
    if isinstance(reason, str) and len(reason) > REASON_LIMIT:
        return f"{reason[: REASON_LIMIT - 1]}…"
    return reason


PRELOAD = (
    "pirate_bt.api.trees",
    "pirate_bt.api.missions",
    "pirate_bt.api.navigation",
    "pirate_bt.behaviours.primitives",
    "pirate_bt.behaviours.basic",
    "pirate_bt.behaviours.guards",
    "pirate_bt.link.opening",
    "pirate_bt.link.robot_link",
    "pirate_bt.link.transport",
    "pirate_bt.sim.simulator",
    "pirate_bt.sim.protocol_sim",
    "pirate_bt.treefile.loader",
    "pirate_bt.treefile.checks",
    "pirate_bt.pipes.asbuilt",
    "pirate_bt.task.route",
    "pirate_bt.task.replan",
    "pirate_bt.trace.writer",
    "pirate_bt.resources",
    "serial.urlhandler",
)
"""What a tree or route case imports, on its first run in a process: a case server
imports these once, before it forks any case (``benchmarks/bench_campaign.py``
prints what a case still imports itself)."""

REPORT_PRELOAD = (
    "pirate_bt.task.report",
    "pirate_bt.render.plot",
    "pirate_bt.render.tree",
    "pirate_bt.robot.diagram",
)
"""What a route case that writes its report folder imports besides (matplotlib, about
0.8 s): a server imports these on the first such case it is given."""


def _base(case: dict[str, Any]) -> dict[str, Any]:
    keys = ("id", "index", "run", "tree", "route", "network", "params", "robot", "map")
    record = {k: case.get(k) for k in keys}
    if case.get("navigator"):
        record.update(navigator=case["navigator"], blind=bool(case.get("blind")))
    if case.get("as_built") is not None:
        record.update(as_built=case["as_built"], as_built_scale=case.get("as_built_scale"))
    record.update({k: case.get(k) for k in ("sim_faults", "drop", "corrupt", "dup", "seed")})
    return record


_COUNTER_KEYS = (
    "violations",
    "damage",
    "refusals",
    "clips",
    "safe_states",
    "estops",
    "retries",
    "link_failures",
    "crc_errors",
    "duplicates",
    "frames_dropped",
    "overruns",
)


def error_record(case: dict[str, Any], outcome: str, reason: str, wall_s: float) -> dict[str, Any]:
    """The record of a case that produced no result of its own (crash, hang, raise)."""
    record = _base(case)
    record.update(
        outcome=outcome,
        reason=_bounded(reason),
        failing_node=None,
        sim_time_s=None,
        wall_time_s=round(wall_s, 3),
        ticks=None,
        **dict.fromkeys(_COUNTER_KEYS),
        violation_kinds={},
        damage_kinds={},
        coverage=None,
        trace=None,
    )
    return record


def _count(value: Any) -> bool:
    return value is None or (type(value) is int and value >= 0)


def _number(value: Any) -> bool:
    return value is None or (
        isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    )


def row_problem(row: Any) -> str | None:
    """Why ``row`` is not a record this module could have written, or ``None``.

    What the report and ``--resume`` rely on is checked, where the row has it: a
    safe ``id`` (always), an integer ``index``, a known ``outcome``, counters as
    counts, times and rates as finite numbers, kinds as counts by name. A results
    file edited by hand, or by anything else, is read only as far as its rows pass.
    """
    from pirate_bt.campaign.paths import is_safe_name

    if not isinstance(row, dict):
        return f"not a record but {type(row).__name__}"
    if not is_safe_name(row.get("id")):
        return "no case id"
    if "index" in row and not (type(row["index"]) is int and row["index"] >= 0):
        return f"index {row['index']!r} is not a case number"
    if "outcome" in row and row["outcome"] not in OUTCOMES:
        return f"outcome {row['outcome']!r} is not one of {', '.join(OUTCOMES)}"
    for key in (*_COUNTER_KEYS, "ticks", "steps", "seed", "as_built"):
        if not _count(row.get(key)):
            return f"{key} {shown(row.get(key))} is not a count"
    # what the report shows as text: a value of another kind was shown as a group
    # ("{'a': 1} drop=0.1 ...") or a reason; an as_built_scale that is no number ended
    # `campaign report` in an internal error
    for key in ("run", "tree", "route", "network", "robot", "map", "navigator", "reason"):
        if row.get(key) is not None and not isinstance(row[key], str):
            return f"{key} {shown(row[key])} is not text"
    if row.get("failing_node") is not None and not isinstance(row["failing_node"], str):
        return f"failing_node {shown(row['failing_node'])} is not text"
    if row.get("blind") is not None and not isinstance(row["blind"], bool):
        return f"blind {shown(row['blind'])} is not true or false"
    for key in (
        "sim_time_s",
        "wall_time_s",
        "distance_m",
        "belief_m",
        "truth_m",
        "drop",
        "corrupt",
        "dup",
        "as_built_scale",
    ):
        if not _number(row.get(key)):
            return f"{key} {row.get(key)!r} is not a number"
    for key in ("violation_kinds", "damage_kinds"):
        kinds = row.get(key) or {}
        if not isinstance(kinds, dict) or not all(
            type(n) is int and n >= 0 for n in kinds.values()
        ):
            return f"{key} is not counts by kind"
    faults = row.get("sim_faults") or []
    if not isinstance(faults, list) or not all(isinstance(f, str) for f in faults):
        return "sim_faults is not a list of faults"
    for key in ("params", "coverage"):
        if row.get(key) is not None and not isinstance(row[key], dict):
            return f"{key} is not a mapping"
    return None


def _faults(case: dict[str, Any]) -> str:
    parts = [f"{k}={case[k]:g}" for k in ("drop", "corrupt", "dup") if case.get(k)]
    return ",".join([*case.get("sim_faults", []), *parts])


def _options(case: dict[str, Any]) -> dict[str, Any]:
    """What every kind of case passes its API call alike: seed, faults, robot, limits."""
    return {
        "seed": case["seed"],
        "faults": _faults(case) or None,
        "robot": case["robot"],
        "max_time": case["max_time_s"],
        "rate": 1.0 / case["period_s"],
    }


def _outcome(succeeded: bool, safe: bool, error: BaseException | None) -> str:
    """``success``; ``failed-safe`` (failed, robot left safe); ``error`` (a node raised,
    the link was lost, or the robot was not left safe). A survey that ends incomplete
    (``explore``'s :class:`~pirate_bt.task.explore_parts.SurveyIncomplete`) is how that
    navigator fails in a world it cannot survey, not a crash: failed-safe when safe."""
    from pirate_bt.errors import LinkError
    from pirate_bt.task.explore_parts import SurveyIncomplete

    if succeeded:
        return "success"
    if isinstance(error, SurveyIncomplete):
        error = None  # `pirate-bt survey` says the same: a failure, exit 1
    if error is not None and not isinstance(error, LinkError):
        return "error"
    return "failed-safe" if safe and not isinstance(error, LinkError) else "error"


def _body(result: Any, safe: bool) -> dict[str, Any]:
    """The row fields every case has, from a ``RunResult`` or a ``MissionResult``."""
    error = result.error if hasattr(result, "error") else result.run.error
    coverage = getattr(result, "coverage", None)  # a navigation runs a tree per step: none
    return {
        "outcome": _outcome(result.succeeded, safe, error),
        "reason": result.why,
        "failing_node": result.failing_node,
        "sim_time_s": round(result.sim_time_s, 3),
        "ticks": result.ticks,
        **result.counters.as_dict(),
        "coverage": coverage.as_dict() if coverage is not None else None,
    }


def _tree_case(case: dict[str, Any], trace: Path | None) -> dict[str, Any]:
    from pirate_bt.api.trees import simulate_tree

    result = simulate_tree(
        case["tree"],
        network=case["network"] or "straight",
        params=case["params"],
        trace=trace,
        **_options(case),
    )
    return _body(result, result.safe_state)


def _as_built(case: dict[str, Any], drawing: Any, base: Path | None = None) -> Any:
    """The case's as-built variant of ``drawing`` (the map), as the simulated truth."""
    from pirate_bt.api.missions import load_network
    from pirate_bt.pipes import Network
    from pirate_bt.pipes.asbuilt import AsBuiltBounds, perturb_network
    from pirate_bt.robot.loader import load_robot

    network = load_network(drawing, base=base)
    variant = case["as_built"]
    # its robot put in on straight pipe, as in the drawing (a truth across a bend is refused)
    robot = load_robot(case.get("robot"))
    bounds = AsBuiltBounds(put_in_m=sum(module.length for module in robot.modules))
    spec = perturb_network(
        network.spec, variant, bounds.scaled(float(case.get("as_built_scale", 1.0)))
    )
    return Network(spec, source=f"{network.name} as built #{variant}")


def _navigator_case(case: dict[str, Any], trace: Path | None) -> dict[str, Any]:
    from pirate_bt.api.navigation import navigate

    # as `pirate-bt navigate NAME --sim TRUTH --map NETWORK --param KEY=VALUE ...`
    network = case["network"] or "straight"
    truth = case["map"] or network
    if case.get("as_built") is not None:
        truth = _as_built(case, network)
    result = navigate(
        case["navigator"],
        sim=truth,
        map=None if case.get("blind") else network,
        params=case["params"],
        trace=trace,
        **_options(case),
    )
    body = _body(result, result.safe_state)
    body.update(steps=result.steps, distance_m=round(result.distance_m, 4))
    body.update(_where(result))
    return body


def _route_case(case: dict[str, Any], output: Path | None) -> dict[str, Any]:
    from pirate_bt.api.missions import load_route, simulate_mission

    route = load_route(case["route"])  # a file, or a bundled name with or without .route
    # as `pirate-bt mission ROUTE --network MAP --sim TRUTH`: the run's network is the
    # map (default: the route's own network line), the spec's `maps` axis the truth
    # (default: the map); the spec check refuses a map the route does not fit
    network, truth = case["network"], case["map"]
    if case.get("as_built") is not None:  # the truth: a variant of the map
        drawing = network or route.network
        if drawing is None:
            raise ValueError(f"{route.source}: 'as_built' needs the route's map (a network)")
        truth = _as_built(case, drawing, Path(route.source).parent)
    result = simulate_mission(
        route,
        network=network,
        truth=truth,
        output=output,
        **_options(case),
    )
    return {**_body(result, result.safe_state), **_where(result)}


def _where(result: Any) -> dict[str, Any]:
    """Where a mission or a navigation ended, by the belief (along the map) and by the
    truth (along the simulated pipe): a row says how far they parted, not only why."""
    truth = result.truth_m
    return {
        "belief_m": round(float(result.belief_m), 4),
        "truth_m": None if truth is None else round(float(truth), 4),
    }


def prepare() -> None:
    """Build what every run builds first and every process builds alike, once.

    The node registry with its entry points (reading the installed packages'
    metadata: about 40 ms, a tenth of a short run). A case server calls it after
    importing :data:`PRELOAD`, before it forks any case; the registry it builds is
    the one a fresh process would build on its first run.
    """
    from pirate_bt.treefile.registry import default_registry

    default_registry()


def preload(case: dict[str, Any], trace_dir: str | None) -> tuple[str, ...]:
    """The modules this case needs beyond :data:`PRELOAD` (a failing route's report)."""
    if case.get("route") and trace_dir is not None and case.get("keep_traces") != "none":
        return REPORT_PRELOAD
    return ()


def _remove(trace: Path) -> None:
    if trace.is_dir():
        shutil.rmtree(trace, ignore_errors=True)
    else:
        trace.unlink(missing_ok=True)


_NO_ROOM = {errno.ENOSPC: "No space left on device", errno.EDQUOT: "Disk quota exceeded"}


def no_room(exc: BaseException | str) -> str | None:
    """What a full disk or a quota said, if that is why ``exc`` was raised or a run
    ended (the trace writer's process reports it as text: ``OSError: [Errno 28]
    ...``, and a run ends with that as its cause); else ``None``."""
    if isinstance(exc, OSError) and exc.errno in _NO_ROOM:
        return _NO_ROOM[exc.errno]
    return next((w for n, w in _NO_ROOM.items() if f"[Errno {n}] {w}" in str(exc)), None)


def run_case(case: dict[str, Any], trace_dir: str | None = None) -> dict[str, Any]:
    """Run one case and return its record; an exception becomes an ``error`` record.

    Args:
        case: One case of :func:`pirate_bt.campaign.cases.expand`.
        trace_dir: Where kept traces go (``None``: keep none).

    Returns:
        The record: the case's parameters, outcome, reason, failing node, simulated
        and wall time, ticks, refusals, link figures, simulator violations and
        damage, and the trace path if one was kept.
    """
    started = time.perf_counter()
    keep = case.get("keep_traces", "failures") if trace_dir else "none"
    trace: Path | None = None
    if keep != "none" and trace_dir is not None:
        name = f"{case['id']}.jsonl" if case.get("tree") else case["id"]  # else a folder
        trace = Path(trace_dir) / name
        trace.parent.mkdir(parents=True, exist_ok=True)
    try:
        if case.get("tree"):
            body = _tree_case(case, trace)
        elif case.get("navigator"):
            body = _navigator_case(case, trace)
        else:
            # A route's trace comes with its report folder; a failing case is run again
            # to write it (the runs are deterministic), so successes pay nothing.
            body = _route_case(case, trace if keep == "all" else None)
            if keep == "failures" and body["outcome"] != "success":
                _route_case(case, trace)
    except Exception as exc:
        record = error_record(
            case, "error", f"{type(exc).__name__}: {exc}", time.perf_counter() - started
        )
        from pirate_bt.errors import said_of

        # the frames, then the message bounded as the reason is (format_exc wrote it whole)
        frames = "".join(traceback.format_tb(exc.__traceback__, limit=-8))
        record["traceback"] = f"{frames}{type(exc).__name__}: {said_of(exc, REASON_LIMIT)}"
        if no_room(exc) and trace is not None:
            # the disk's doing, not the case's: not a row (it stopped the campaign as an
            # error row no resume ran again), and no half-written trace left behind
            record["no_room"] = f"{trace}: {no_room(exc)}"
            _remove(trace)
        return record
    if trace is not None and keep == "failures" and body["outcome"] == "success":
        _remove(trace)
        trace = None
    record = _base(case)
    record.update(body)
    if trace is not None and body["outcome"] == "error" and no_room(str(body["reason"])):
        record["no_room"] = f"{trace}: {no_room(str(body['reason']))}"
        _remove(trace)
        trace = None
    record["reason"] = _bounded(record.get("reason"))
    record.setdefault("violation_kinds", {})
    record.setdefault("damage_kinds", {})
    record["wall_time_s"] = round(time.perf_counter() - started, 3)
    record["trace"] = str(trace) if trace is not None and trace.exists() else None
    return record
