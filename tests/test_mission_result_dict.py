"""A mission's result says itself in one line and as plain JSON, as a tree run's does."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main

ROUTE = Path(__file__).resolve().parents[1] / "scenarios" / "straight.route"


def test_a_mission_says_itself_in_one_line_and_as_json() -> None:
    result = pirate_bt.simulate_mission(ROUTE)
    line = result.summary()
    assert line.startswith("mission straight: SUCCESS - mission completed") and "\n" not in line
    assert f"{result.ticks} ticks" in line and "truly" in line
    data = json.loads(json.dumps(result.as_dict()))
    assert data["status"] == "success" and data["route"] == "straight"
    assert [p["outcome"] for p in data["pabs"]] == [p.outcome for p in result.pabs]
    assert data["ticks"] == result.ticks and data["counters"]["violations"] == 0
    assert data["truth_m"] == pytest.approx(result.truth_m, abs=1e-3)
    assert data["coverage"] is not None and data["returned"] is None


def test_a_failed_mission_names_its_first_cause_and_node() -> None:
    result = pirate_bt.simulate_mission(ROUTE, max_time="3 s")
    line = result.summary()
    assert line.startswith("mission straight: FAILED - time limit of 3 s")
    data = result.as_dict()
    assert data["status"] == "failure" and data["why"] == result.why
    assert data["failing_node"] == result.failing_node
    assert any(p["outcome"] in ("failure", "stopped") for p in data["pabs"])


def test_the_command_prints_the_result_s_own_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["mission", str(ROUTE), "--quiet"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("mission straight: SUCCESS - mission completed")
    assert " s wall; believed at " in out[0]
