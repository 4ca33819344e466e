"""Probe 18b: planner code written from docs/api.md, README.md and docs/navigators.md."""

from __future__ import annotations

import json
from pathlib import Path

import pirate_bt


def test_survey_result_has_what_api_md_says_every_navigation_result_has(
    tmp_path: Path,
) -> None:
    # docs/api.md: NavigationResult (navigations, surveys): the same status, why,
    # failing_node, counters, safe_state, exit_code, summary() and as_dict(); a
    # survey's result had no counters, safe_state or as_dict (AttributeError)
    result = pirate_bt.survey(sim="t-joint", output=tmp_path / "surveyed.yaml")
    assert result.counters is result.navigation.counters
    assert result.safe_state is result.navigation.safe_state
    plain = json.loads(json.dumps(result.as_dict()))
    assert plain["status"] == result.status
    assert plain["why"] == result.why
    assert plain["counters"] == result.counters.as_dict()
    assert plain["survey"]["counts"] == result.counts()
    assert plain["survey"]["output"] == str(tmp_path / "surveyed.yaml")
    assert plain["survey"]["unexplored"] == result.unexplored
    segments = plain["survey"]["network"]["segments"]
    assert [s["type"] for s in segments].count("tee") == result.counts()["tee"] == 1
