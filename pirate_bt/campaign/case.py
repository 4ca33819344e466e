"""One case: a plain function of a plain case that returns a plain record.

:func:`run_case` runs one tree (with ``pirate-bt run``'s own functions) or one
route (with ``pirate-bt mission``'s) on the simulator and returns a ``dict`` of
JSON values. It is what the per-case child process calls (see
:mod:`pirate_bt.campaign.engine`); it never raises for a run that fails,
because a failure is an outcome.

Outcomes: ``success``; ``failed-safe`` (the run failed and the supervisor left
the robot in its safe state); ``error`` (the case could not run, a node raised,
the link was lost, or the robot was not left safe); ``timeout`` (killed after
its wall-time limit, set by the engine).
"""

from __future__ import annotations

import argparse
import shutil
import time
import traceback
from pathlib import Path
from typing import Any

__all__ = ["OUTCOMES", "error_record", "run_case"]

OUTCOMES = ("success", "failed-safe", "error", "timeout")


def _base(case: dict[str, Any]) -> dict[str, Any]:
    keys = ("id", "index", "run", "tree", "route", "network", "params", "robot", "map")
    record = {k: case.get(k) for k in keys}
    record.update({k: case.get(k) for k in ("sim_faults", "drop", "corrupt", "dup", "seed")})
    return record


def error_record(case: dict[str, Any], outcome: str, reason: str, wall_s: float) -> dict[str, Any]:
    """The record of a case that produced no result of its own (crash, hang, raise)."""
    record = _base(case)
    record.update(
        outcome=outcome,
        reason=reason,
        failing_node=None,
        sim_time_s=None,
        wall_time_s=round(wall_s, 3),
        ticks=None,
        refusals=None,
        link={},
        violations=None,
        damage=None,
        violation_kinds={},
        damage_kinds={},
        trace=None,
    )
    return record


def _link_faults(case: dict[str, Any]) -> str:
    parts = [f"{k}={case[k]:g}" for k in ("drop", "corrupt", "dup") if case.get(k)]
    return ",".join([*case.get("sim_faults", []), *parts])


def _figures(supervisor: Any, simulator: Any) -> dict[str, Any]:
    health = supervisor.health()
    link = {
        "crc_errors": health.crc_errors,
        "retries": health.retries,
        "failed": health.failed,
        "duplicates": health.duplicates,
        "loss_ratio": round(health.loss_ratio, 4),
    }
    out: dict[str, Any] = {"link": link}
    if simulator is not None:
        counters = simulator.counters()
        out.update(
            violations=counters.violation_count,
            damage=counters.damage_count,
            violation_kinds=dict(sorted(counters.violations.items())),
            damage_kinds=dict(sorted(counters.damage.items())),
            frames_dropped=counters.frames_dropped,
        )
    return out


def _outcome(result: Any, supervisor: Any) -> str:
    from pirate_bt.errors import LinkError
    from pirate_bt.runner import StopReason

    if result.succeeded:
        return "success"
    if result.reason is StopReason.EXCEPTION and not isinstance(result.error, LinkError):
        return "error"
    return "failed-safe" if supervisor.in_safe_state else "error"


def _tree_case(case: dict[str, Any], trace: Path | None) -> dict[str, Any]:
    from pirate_bt.cli.run import connect, run_tree
    from pirate_bt.resources import find_file
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.trace import attach_trace, supervised_extras
    from pirate_bt.treefile import load_tree

    robot = load_robot(case["robot"])
    checked = load_tree(
        find_file("trees", case["tree"]), robot=robot, params=case["params"], params_from_text=True
    )
    network = case["network"] or "straight"
    args = argparse.Namespace(
        port=None, sim=network, seed=case["seed"], faults=_link_faults(case) or None
    )
    connection = connect(args, robot, needs_robot=True)
    supervisor, simulator = connection.supervisor, connection.simulator
    refusals = [0]
    supervisor.add_listener(lambda v: refusals.__setitem__(0, refusals[0] + (not v.ok)))

    def observe(runner: Any) -> None:
        if trace is not None:
            extras = supervised_extras(supervisor, counters=simulator.counters)
            attach_trace(
                runner, trace, extras=extras, robot=robot, scenario=network, seed=case["seed"]
            )

    try:
        _tree, result = run_tree(
            checked,
            robot,
            connection,
            period_s=case["period_s"],
            max_time_s=case["max_time_s"],
            observe=observe,
        )
        figures = _figures(supervisor, simulator)
    finally:
        connection.close()
    reason = result.message
    if supervisor.safe_state_reason:
        reason = f"{result.message}: {supervisor.safe_state_reason}"
    return {
        "outcome": _outcome(result, supervisor),
        "reason": reason,
        "failing_node": result.failing_node,
        "sim_time_s": round(result.sim_time_s, 3),
        "ticks": result.ticks,
        "refusals": refusals[0],
        **figures,
    }


def _route_case(case: dict[str, Any], output: Path | None) -> dict[str, Any]:
    from pirate_bt.cli import mission

    argv = [case["route"], "--seed", str(case["seed"]), "--quiet"]
    argv += ["--rate", f"{1.0 / case['period_s']:g} Hz", "--max-time", f"{case['max_time_s']:g} s"]
    if case["robot"]:
        argv += ["--robot", case["robot"]]
    if case["map"]:
        argv += ["--sim", case["map"]]
    if case["network"]:
        argv += ["--network" if case["map"] else "--sim", case["network"]]
    faults = _link_faults(case)
    if faults:
        argv += ["--faults", faults]
    if output is not None:
        argv += ["--output", str(output)]
    parser = argparse.ArgumentParser()
    mission.configure(parser)
    args = parser.parse_args(argv)
    if case["map"] and not hasattr(args, "map_tolerance"):
        from pirate_bt.errors import InputError

        raise InputError("maps: this pirate_bt's missions cannot run a truth other than the map")
    import io

    outputs = mission.execute(args, out=io.StringIO(), live=False)
    result = outputs.result
    run = result.run
    return {
        "outcome": "success"
        if result.succeeded
        else ("failed-safe" if outputs.code == 1 else "error"),
        "reason": result.reason,
        "failing_node": run.failing_node,
        "sim_time_s": round(run.sim_time_s, 3),
        "ticks": run.ticks,
        "refusals": None,
        "link": {},
        "violations": int(result.sim.get("violations", 0)),
        "damage": int(result.sim.get("damage", 0)),
    }


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
        name = f"{case['id']}.jsonl" if case.get("tree") else case["id"]
        trace = Path(trace_dir) / name
        trace.parent.mkdir(parents=True, exist_ok=True)
    try:
        if case.get("tree"):
            body = _tree_case(case, trace)
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
        record["traceback"] = traceback.format_exc(limit=-8)
        return record
    if trace is not None and keep == "failures" and body["outcome"] == "success":
        if trace.is_dir():
            shutil.rmtree(trace, ignore_errors=True)
        else:
            trace.unlink(missing_ok=True)
        trace = None
    record = _base(case)
    record.update(body)
    record.setdefault("violation_kinds", {})
    record.setdefault("damage_kinds", {})
    record["wall_time_s"] = round(time.perf_counter() - started, 3)
    record["trace"] = str(trace) if trace is not None and trace.exists() else None
    return record
