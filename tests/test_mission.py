"""Missions end to end on the simulator: shipped routes complete, misfits and mismatches stop.

The lab route runs once, through ``pirate-bt demo`` (about 25 s of wall time for
about 9 minutes of simulated mission); the other shipped routes run through
``pirate-bt mission``.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.cli.mission import MissionOutputs, execute
from pirate_bt.task.localise import FIX_BOUND_M
from tests.golden_runs import LAB_DEMO, LabDemo

REPO = Path(__file__).resolve().parent.parent
# lab and lab-long (the scale figures' 220-PAB route) are long: the lab mission runs elsewhere.
SHORT = sorted(p for p in (REPO / "scenarios").glob("*.route") if p.stem not in ("lab", "lab-long"))


def mission(route: Path | str, **options: object) -> MissionOutputs:
    args = argparse.Namespace(
        route=str(route),
        sim=None,
        port=None,
        network=None,
        robot=None,
        seed=0,
        faults=None,
        output=None,
        quiet=True,
        plan=False,
        rate="20 Hz",
        max_time=None,
        realtime=False,
    )
    for key, value in options.items():
        setattr(args, key, value)
    return execute(args, out=io.StringIO())


def check_clean_success(outputs: MissionOutputs) -> None:
    result = outputs.result
    assert outputs.code == 0, result.reason
    assert result.succeeded and result.mismatch is None
    assert result.sim["violations"] == 0 and result.sim["damage"] == 0
    # The stated bound, checked on the simulator: within 0.10 m after every fix...
    assert result.max_fix_error_m is None or result.max_fix_error_m <= FIX_BOUND_M
    # ...and (no slip in these networks) within it over the whole run too.
    assert result.max_error_m is not None and result.max_error_m <= FIX_BOUND_M
    # It ended where the plan said, within the bound, less what the legs kept back
    # in case the map's lengths are off (each such leg says so).
    kept_back = sum(leg.planned_m - leg.driven_m for leg in result.legs if leg.why)
    assert all(leg.driven_m <= leg.planned_m + 1e-9 for leg in result.legs if leg.why)
    assert result.plan.end_m - kept_back - FIX_BOUND_M <= result.truth_m
    assert result.truth_m <= result.plan.end_m + FIX_BOUND_M


@pytest.mark.parametrize("route", SHORT, ids=[p.stem for p in SHORT])
def test_shipped_route_completes_in_its_network(route: Path) -> None:
    outputs = mission(route)
    check_clean_success(outputs)
    turns = [p for p in outputs.result.plan.pabs if p.pab in ("bend", "t-joint")]
    assert len(outputs.result.fixes) == len(turns)


@pytest.mark.slow
@pytest.mark.xdist_group(LAB_DEMO)
def test_demo_inspects_the_lab_network(lab_demo: LabDemo) -> None:
    # the demo's run, shared with the golden lab mission's test (conftest.py)
    out = lab_demo.folder
    assert lab_demo.digests["exit_code"] == 0
    text = lab_demo.printed
    assert "mission lab: SUCCESS" in text and "x real time" in text
    for name in ("robot", "tree"):
        assert (out / f"{name}.svg").exists() or (out / f"{name}.dot").exists()
    for name in ("trace.jsonl", "plot.png", "belief.png", "report.md", "report.html"):
        assert (out / name).stat().st_size > 0, name
    report = (out / "report.md").read_text()
    for heading in ("## Route", "## Plan", "## Timeline", "## Localisation", "## Robot boards"):
        assert heading in report
    assert "- **Outcome:** SUCCESS" in report
    from pirate_bt.trace import read_trace

    trace = read_trace(out / "trace.jsonl")
    assert trace.outcome == "success"
    last = list(trace.frames())[-1]
    assert abs(last.sim["task.error_m"]) <= FIX_BOUND_M
    assert "task.truth_m" in last.sim and "task.belief_m" in last.sim


def test_route_that_does_not_fit_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    route = REPO / "scenarios" / "bend-left.route"
    assert main(["mission", str(route), "--network", "bend-right", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{route}:5:1: " in err and "turns right, not left" in err


def test_malformed_route_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.route"
    bad.write_text("network straight\nforwad 1 m\n")
    assert main(["mission", str(bad)]) == 2
    assert "did you mean 'forward'" in capsys.readouterr().err


def test_plan_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["mission", str(REPO / "scenarios" / "lab.route"), "--plan"]) == 0
    out = capsys.readouterr().out
    assert "bend right (bend-a)" in out and "T-joint straight (tee-1)" in out


def test_map_that_disagrees_with_the_pipe_stops_safe(tmp_path: Path) -> None:
    """The map says a bend turns up at 2 m; the real pipe is straight."""
    world = tmp_path / "world.yaml"
    world.write_text((REPO / "scenarios" / "straight.yaml").read_text())
    route = tmp_path / "r.route"
    route.write_text("network bend-up\nat the bend turn up\nforward 1 m\n")
    from pirate_bt.clock import SimClock
    from pirate_bt.pipes import load_network
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.safety.factory import open_supervisor
    from pirate_bt.sim import Simulator
    from pirate_bt.task.mission import run_mission
    from pirate_bt.task.planner import load_network_for, plan_route
    from pirate_bt.task.route import load_route

    robot = load_robot()
    parsed = load_route(route)
    plan = plan_route(parsed, load_network_for(parsed, None), robot)
    clock = SimClock()
    with Simulator(load_network(world), robot, clock=clock) as sim:
        supervisor = open_supervisor(robot, url=sim.url, clock=clock)
        try:
            result = run_mission(plan, robot, supervisor, clock, truth=lambda: sim.truth().front_m)
        finally:
            supervisor.close()
    assert not result.succeeded
    assert result.run.safe_state_called
    assert result.mismatch is not None and "no turn was felt" in result.mismatch
    assert result.reason == result.mismatch


def test_fault_fails_the_mission_safely() -> None:
    outputs = mission(
        REPO / "scenarios" / "straight.route", faults="motor_stall:bend_1_drive@5s+60s"
    )
    assert outputs.code == 1
    assert not outputs.result.succeeded and outputs.result.run.safe_state_called
