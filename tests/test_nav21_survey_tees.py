"""Tees a survey cannot pass or probe: the stop names the tee, where it is, and why.

Until the twenty-first session each of these stopped safe in words that named no tee:
a tee 0.05 m after a bend, or two tees 0.05 m apart, with the drive's slip (*slipping:
no half holds the robot after 0.086 m ...*); two 51 mm tees 0.3 m apart with the
supervisor's refusal (*refused unclamp(front): other_half_not_clamped ...*); a tee in
100 mm pipe as *an opening ... with no branch the robot could steer into*, as if it had
none. Each is something the robot cannot do (DOMAIN.md: the half over an opening
cannot clamp, so the other must hold), and the survey now says which tee, where, and
why, with the line written up to it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

import pirate_bt


def _survey(tmp_path: Path, segments: list[dict[str, Any]], diameter_mm: int = 63) -> Any:
    network = tmp_path / "net.yaml"
    network.write_text(
        yaml.safe_dump(
            {
                "schema_version": 1,
                "name": "net",
                "diameter": f"{diameter_mm} mm",
                "segments": segments,
            },
            sort_keys=False,
        ),
        encoding="utf-8",
    )
    result = pirate_bt.survey(sim=str(network), output=tmp_path / "surveyed.yaml")
    assert result.exit_code == 1 and not result.succeeded
    assert result.navigation.safe_state
    assert result.navigation.counters.violations == 0
    assert result.navigation.sim["damage"] == 0
    assert "\n" not in result.why
    return result


def _tee(name: str, side: str) -> dict[str, Any]:
    branch = [{"id": f"{name}-b", "type": "straight", "length": "0.6 m"}]
    return {"id": name, "type": "tee", "branch": {"direction": side, "segments": branch}}


def _straight(name: str, length: str) -> dict[str, Any]:
    return {"id": name, "type": "straight", "length": length}


def _written(tmp_path: Path) -> list[dict[str, Any]]:
    data = yaml.safe_load((tmp_path / "surveyed.yaml").read_text(encoding="utf-8"))
    segments: list[dict[str, Any]] = data["segments"]
    return segments


def test_a_tee_just_after_a_bend_is_named_where_the_robot_stopped(tmp_path: Path) -> None:
    result = _survey(
        tmp_path,
        [
            _straight("before", "1.2 m"),
            {"id": "b", "type": "bend", "direction": "right"},
            _straight("mid", "0.05 m"),
            _tee("t", "left"),
            _straight("after", "0.8 m"),
        ],
    )
    why = result.why
    # before: 'slipping: no half holds the robot after 0.086 m (front bend_1 off ...'
    assert why.startswith("the robot stopped in bend-1: as its rear half turned through bend-1,")
    assert (
        "crossed an opening 0.1" in why and "m after bend-1 (a tee this close after a bend)" in why
    )
    assert "(rear through turn: slipping: no half holds the robot after" in why
    assert "the survey cannot pass a tee this close after a bend" in why
    assert any("not surveyed past an opening 0.1" in u for u in result.unexplored)
    assert [s["type"] for s in _written(tmp_path)] == ["straight", "bend"]


def test_two_tees_0_05_m_apart_are_named_where_the_robot_stopped(tmp_path: Path) -> None:
    result = _survey(
        tmp_path,
        [
            _straight("before", "1.2 m"),
            _tee("t1", "left"),
            _straight("mid", "0.05 m"),
            _tee("t2", "right"),
            _straight("after", "0.8 m"),
        ],
    )
    why = result.why
    # before: 'no feature (opening_passed) before slipping: no half holds the robot ...'
    assert why.startswith("the robot stopped going straight through tee-1: as its rear half")
    assert "a second opening 0.1" in why and "m after tee-1 (a tee this close after a tee)" in why
    assert "tee-1's branch (left, 63 mm) is not entered, a second insertion" in why
    assert any("tee-1's branch (left, 63 mm): not entered" in u for u in result.unexplored)
    assert [s["type"] for s in _written(tmp_path)] == ["straight", "tee"]


def test_a_51_mm_tee_0_3_m_after_a_tee_is_not_probed_and_named(tmp_path: Path) -> None:
    result = _survey(
        tmp_path,
        [
            _straight("before", "1.2 m"),
            _tee("t1", "left"),
            _straight("mid", "0.3 m"),
            _tee("t2", "right"),
            _straight("after", "0.8 m"),
        ],
        diameter_mm=51,
    )
    why = result.why
    # before: 'refused unclamp(front): other_half_not_clamped: ...'
    assert "refused" not in why and "other_half_not_clamped" not in why
    assert "the robot stopped over the opening of a tee 0.3" in why
    assert "probe-tee would hold the robot there by its rear half alone" in why
    assert "over tee-1's opening" in why
    assert any("tee-1's branch (left, 51 mm): not entered" in u for u in result.unexplored)
    segments = _written(tmp_path)
    assert [s["type"] for s in segments] == ["straight", "tee", "straight"]
    run_2 = float(segments[2]["length"].split()[0]) / 1000
    assert abs(run_2 - 0.3) < 0.02  # the line written up to the second tee


def test_a_63_mm_tee_0_3_m_after_a_tee_is_still_probed(tmp_path: Path) -> None:
    # the rear half's last joint is clear of the first tee's opening there (3.5 mm as
    # built): the probe tells the second tee's branch, and the survey is not stopped
    result = _survey(
        tmp_path,
        [
            _straight("before", "1.2 m"),
            _tee("t1", "left"),
            _straight("mid", "0.3 m"),
            _tee("t2", "right"),
            _straight("after", "0.8 m"),
        ],
    )
    assert "stopped over the opening" not in result.why
    segments = _written(tmp_path)
    assert [s["type"] for s in segments[:4]] == ["straight", "tee", "straight", "tee"]
    assert segments[3]["branch"]["direction"] == "right"


def test_a_tee_in_100_mm_pipe_is_not_said_to_have_no_branch(tmp_path: Path) -> None:
    result = _survey(
        tmp_path,
        [_straight("before", "1.2 m"), _tee("t1", "left"), _straight("after", "0.8 m")],
        diameter_mm=100,
    )
    why = result.why
    # before: 'an opening at 1.22 m with no branch the robot could steer into'
    assert "no branch the robot could steer into" not in why
    assert "in 100 mm pipe, where probe-tee felt no branch turn on any side" in why
    assert "in pipe over 85 mm it cannot" in why
    assert [s["type"] for s in _written(tmp_path)] == ["straight"]


def test_a_tee_0_2_m_after_a_tee_that_the_pab_carried_the_front_onto_is_named(
    tmp_path: Path,
) -> None:
    # going straight through tee-1, the T-joint PAB ends with the front half over the
    # second tee's opening: the way back to tee-1's branch (t-joint-back) starts by
    # clamping that half, and there is no wall for it
    result = _survey(
        tmp_path,
        [
            _straight("before", "1.2 m"),
            _tee("t1", "left"),
            _straight("mid", "0.2 m"),
            _tee("t2", "right"),
            _straight("after", "0.8 m"),
        ],
    )
    why = result.why
    # before: 'no wall: bend_2 swung to 110.0°, past every wall-contact angle ...'
    assert "no wall:" not in why and "bend_2 swung" not in why
    assert "the robot stopped with its front half over an opening 0.2" in why
    assert "m after tee-1, which the step before carried it onto" in why
    assert any("tee-1's branch (left, 63 mm): not entered" in u for u in result.unexplored)
    segments = _written(tmp_path)
    assert [s["type"] for s in segments] == ["straight", "tee", "straight"]
    run_2 = float(segments[2]["length"].split()[0]) / 1000
    assert abs(run_2 - 0.2) < 0.03  # the line written up to the second tee


def test_a_navigation_s_last_step_openings_are_in_its_plain_json(tmp_path: Path) -> None:
    # NavigationResult.off_wall (the failed step's joints off the wall, where the survey
    # placed the tee it names) is in as_dict(), which gives all of the result
    import json

    navigator = pirate_bt.Step("straight", distance=3.0, stop_at_feature=True)

    class _ToTheTee:
        def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
            return navigator if obs.step == 0 else None

    result = pirate_bt.navigate(_ToTheTee(), sim="t-joint")
    assert result.succeeded, result.why
    assert result.off_wall and result.off_wall[-1].back_m is None  # stopped over it
    data = json.loads(json.dumps(result.as_dict()))
    assert data["off_wall"] == [o.to_json() for o in result.off_wall]
