"""Turns whose roll the robot's IMU reads otherwise than the map's frame has it.

A network's rolls are in the pipe's own frame, carried along without twisting; the
robot aligns a half on a turn by its IMU, which reads roll from gravity's up. After a
bend at a roll other than up, down, left or right the pipe slopes, and its frame is
twisted off gravity's: a bend at roll 135 deg leaves the pipe going down at 45 deg
with its "up" 45 deg off. The next bend (roll -120 deg in the map) is at roll -165 deg
by the IMU; a bend up after a bend right on a 20 deg slope is at roll 20 deg by the
IMU. The planner gave the bend PAB the map's roll: the front half was aligned
45 deg off the bend's plane, the rear half blocked, and a mission on an exact map
stopped on a "map disagreement". A tee's branch there cannot be turned into by the
T-joint PAB (it turns at -90 or +90 deg by the IMU): driving the rear half, clamped,
on over the opening let the robot slide down the 45 deg pipe. It is refused now.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import pytest
import yaml

import pirate_bt
from pirate_bt import Step
from pirate_bt.errors import ConfigurationError, InputError, LinkError, LocatedError
from pirate_bt.pipes.asbuilt import insert_tee
from pirate_bt.task.explore_frame import imu_side
from pirate_bt.task.navigate_result import FailedStep, unrecovered
from pirate_bt.task.navigators import GoalNavigator

NETS = Path(__file__).parent / "data" / "networks"
ROLLS = NETS / "probe8-rolls.yaml"
ROLL_TEE = NETS / "probe8-roll-tee.yaml"
TEE_ROLL = NETS / "probe8-tee-roll.yaml"
SLOPE_SIDE = NETS / "probe8-slope-side.yaml"


def _no_violation(counters: Any) -> None:
    """No violation at all: a robot put in on these networks' 20 deg first straight is
    held until its first clamp (docs/simulator.md, *Falling*; before 74fdbff it slid
    there, one ``sliding`` in every count)."""
    assert counters.violation_kinds == {}, counters
    assert counters.damage == 0, counters


def _turns(network: Path) -> dict[str, tuple[float, float]]:
    path = pirate_bt.load_network(network).main_path()
    return {
        p.segment: (math.degrees(p.roll_rad), math.degrees(p.imu_roll_rad))
        for p in path.pieces
        if p.is_turn or p.opening_m is not None
    }


def test_the_imu_reads_a_turn_s_roll_from_gravity_s_up() -> None:
    turns = _turns(ROLLS)
    assert turns["b1"] == pytest.approx((135.0, 135.0))  # after a level run: the same
    assert turns["b2"] == pytest.approx((-120.0, -165.0))  # the pipe's frame is twisted
    for name in ("lab", "riser", "bend-down"):  # level, sloped and vertical runs: the same
        path = pirate_bt.load_network(name).main_path()
        for piece in path.pieces:
            assert piece.imu_roll_rad == piece.roll_rad


def _route(tmp_path: Path, network: Path, *lines: str) -> Path:
    route = tmp_path / "probe.route"
    route.write_text("\n".join([f"network {network}", *lines, ""]), encoding="utf-8")
    return route


@pytest.mark.parametrize(
    ("network", "imu_rolls"),
    [
        (ROLLS, [135.0, -165.0]),  # after a bend at roll 135 deg: going down at 45 deg
        (SLOPE_SIDE, [90.0, 20.0]),  # a bend up after a bend right on a 20 deg slope
    ],
)
def test_a_bend_in_a_twisted_frame_is_passed_on_its_imu_roll(
    tmp_path: Path, network: Path, imu_rolls: list[float]
) -> None:
    route = _route(tmp_path, network, "at the bend turn", "at the bend turn")
    plan = pirate_bt.plan_route(route)
    rolls = [math.degrees(p.params["roll"]) for p in plan.pabs if p.pab == "bend"]
    assert rolls == pytest.approx(imu_rolls)
    result = pirate_bt.simulate_mission(plan)
    assert result.succeeded, result.why
    _no_violation(result.counters)
    assert result.truth_m is not None
    assert abs(result.belief_m - result.truth_m) < 0.05


def test_a_branch_the_t_joint_pab_cannot_turn_into_is_refused_at_planning(
    tmp_path: Path,
) -> None:
    route = _route(tmp_path, ROLL_TEE, "at the bend turn", "at the T-joint go right")
    with pytest.raises(LocatedError) as caught:
        pirate_bt.plan_route(route)
    text = str(caught.value)
    assert text.startswith(f"{route}:3:1: 'at the T-joint go right' cannot be planned")
    assert "at roll 45 deg by the IMU" in text
    # straight through it is planned, and runs
    route = _route(tmp_path, ROLL_TEE, "at the bend turn", "at the T-joint go straight")
    assert pirate_bt.plan_route(route).pabs


@pytest.mark.parametrize(
    ("network", "says"),
    [
        (TEE_ROLL, "branches roll 45 deg, and the T-joint PAB turns left or right only"),
        (ROLL_TEE, "branches right in the pipe's frame, at roll 45 deg by the IMU"),
    ],
)
def test_a_goal_behind_such_a_branch_is_refused_before_anything_moves(
    network: Path, says: str
) -> None:
    with pytest.raises(ValueError, match="'br' cannot be reached: the T-joint 't1' ") as caught:
        GoalNavigator("br").check_map(pirate_bt.load_network(network))
    assert says in str(caught.value)
    # before: Step('t-joint', direction=None) from the goal navigator, exit 1 after connecting
    with pytest.raises(InputError, match="cannot be reached"):
        pirate_bt.navigate("goal", sim=network, map=network, params={"segment": "br"})
    GoalNavigator("c" if network == ROLL_TEE else "b").check_map(pirate_bt.load_network(network))


# -- a step's own failure after a disagreement not recovered from --------------------

RISER2 = NETS / "probe8-riser2.yaml"


def test_a_failure_before_belief_and_map_agree_again_names_the_disagreement_first() -> None:
    # a tee nobody drew in the level run before the riser: the goal navigator goes on
    # from the belief with the front half over its opening, and the next step's first
    # clamp finds no wall; the why began with that "no wall", the tee after it
    spec = pirate_bt.load_network(RISER2).spec
    truth = insert_tee(spec, "level", 0.6, "left")
    result = pirate_bt.navigate("goal", sim=truth, map=RISER2, params={"segment": "upper"})
    assert not result.succeeded
    assert result.why.startswith("belief and map disagree: an opening was felt at 0.6"), result.why
    assert "(step 1, Step('bend', direction='up')); navigator 'goal' went on from it" in result.why
    assert ", and then: step 2 (Step('bend', direction='up')) failed: no wall: " in result.why
    assert result.failing_node is not None and "01 approach" in result.failing_node
    assert result.counters.violations == 0


def test_only_an_unrecovered_disagreement_comes_before_a_step_s_own_failure() -> None:
    gone = FailedStep(2, Step("bend", direction="up"), "belief and map disagree: ...", "n")
    assert unrecovered([gone], fixed_after=0, error=None)
    assert unrecovered([gone], fixed_after=1, error=None)  # the fix was before it
    assert not unrecovered([gone], fixed_after=3, error=None)  # belief and map agreed again
    assert not unrecovered([], fixed_after=0, error=None)
    assert not unrecovered([gone], fixed_after=0, error=LinkError("link lost"))


# -- a survey writes what it found in the network's frame ----------------------------

SIDE_UP = NETS / "probe8-slope-side-gup.yaml"
SIDE_TEE = NETS / "probe8-slope-side-tee.yaml"


def _surveyed(truth: Path, tmp_path: Path) -> dict[str, Any]:
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=truth, output=out)
    _no_violation(result.navigation.counters)
    return {
        str(s["id"]): s for s in _flat(yaml.safe_load(out.read_text(encoding="utf-8"))["segments"])
    }


def _flat(segments: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for s in segments:
        out.append(s)
        out.extend(_flat((s.get("branch") or {}).get("segments") or []))
    return out


def test_a_bend_the_imu_found_up_in_a_twisted_frame_is_written_with_its_roll(
    tmp_path: Path,
) -> None:
    # a bend right on a 20 deg slope twists the frame 20 deg: the bend toward gravity's
    # up after it is at roll -20 deg in the frame; it was written 'direction: up', and a
    # mission planned on the survey aligned the bend PAB 20 deg off and stopped
    found = _surveyed(SIDE_UP, tmp_path)
    assert found["bend-2"].get("direction") is None
    assert found["bend-2"]["roll"] == "-20.000 deg"
    assert found["bend-1"]["direction"] == "right"  # a level frame: the word, as before
    route = _route(tmp_path, tmp_path / "surveyed.yaml", "at the bend turn right")
    route.write_text(route.read_text() + "at the bend turn\nforward to the end\n")
    result = pirate_bt.simulate_mission(route, truth=SIDE_UP)
    assert result.succeeded, result.why


def test_a_branch_the_imu_found_left_in_a_twisted_frame_is_written_with_its_roll(
    tmp_path: Path,
) -> None:
    found = _surveyed(SIDE_TEE, tmp_path)
    assert found["tee-1"]["branch"].get("direction") is None
    assert found["tee-1"]["branch"]["roll"] == "-110.000 deg"
    # a route's 'go left' names it (as the IMU reads it), and the T-joint PAB turns left
    route = _route(tmp_path, tmp_path / "surveyed.yaml", "at the bend turn right")
    route.write_text(route.read_text() + "at the T-joint go left\n")
    plan = pirate_bt.plan_route(route)
    assert [p.params for p in plan.pabs if p.pab == "t-joint"] == [{"direction": "left"}]
    # a second insertion reads the stub's side back as the IMU will find it
    data = yaml.safe_load((tmp_path / "surveyed.yaml").read_text(encoding="utf-8"))
    data["segments"][3]["branch"]["segments"] = []
    assert imu_side(data["segments"], 0.051, data["segments"][3]) == "left"


def test_go_to_a_segment_behind_a_branch_the_pab_cannot_take_is_refused(tmp_path: Path) -> None:
    # it was planned straight through the tee, and a mission "reached" 'br' in the main line
    route = _route(tmp_path, TEE_ROLL, "go to br")
    with pytest.raises(LocatedError, match=r":2:1: 'go to br' cannot be planned: the T-joint"):
        pirate_bt.plan_route(route)


def test_a_navigator_s_missing_or_unknown_parameter_is_named_with_those_it_takes() -> None:
    # it was "GoalNavigator.__init__() missing 1 required positional argument: 'segment'"
    with pytest.raises(InputError) as caught:
        pirate_bt.load_navigator("goal")
    assert str(caught.value) == (
        "navigator 'goal' needs the parameter 'segment' (params={'segment': ...};"
        " it takes: segment)"
    )
    with pytest.raises(InputError, match=r"'segmnt' \(it takes: segment\)$"):
        pirate_bt.load_navigator("goal", {"segmnt": "upper"})


def test_a_turn_the_pipe_does_not_have_is_named_past_where_the_pab_was_to_end(
    tmp_path: Path,
) -> None:
    # the riser goes on 1.4 m past its drawn top bend and ends: the bend PAB's search
    # drove on to the cap; the why said the robot was blocked "at what the map has as
    # bend 'top'", 1.3 m below where it was
    route = _route(tmp_path, RISER2, "at the bend turn up", "at the bend turn down")
    result = pirate_bt.simulate_mission(route, truth=NETS / "probe8-riser2-notop.yaml")
    assert not result.succeeded and result.counters.violations == 0
    assert result.why.startswith("map disagreement at 4.24 m (believed): the pipe blocked the")
    assert ", 0.54 m beyond where the PAB through what the map has as bend 'top' was to" in (
        result.why
    )


def test_a_route_navigator_s_steps_are_named_by_the_route_s_lines(tmp_path: Path) -> None:
    # they were named by the step's number as a line of '<navigator route>': the first
    # step's refusal read '<navigator route>:1:1' for the route's line 2, and its PABs
    # '(line 1)', the route's network line
    route = _route(tmp_path, RISER2, "at the bend turn left")
    result = pirate_bt.navigate("route", sim=RISER2, map=RISER2, params={"route": route})
    assert not result.succeeded and result.steps == 0
    assert f"{route}:2:1: 'at the bend turn left' does not fit the network" in result.why
    route = _route(tmp_path, RISER2, "at the bend turn up", "pause 1 s")
    result = pirate_bt.navigate("route", sim=RISER2, map=RISER2, params={"route": route})
    assert result.succeeded, result.why
    assert [p.label for p in result.pabs] == [
        "01 approach 0.43 m (line 2)",
        "02 bend up (foot) (line 2)",
        "01 pause 1 s (line 3)",
    ]


# -- a survey backs through a tee in a steep pipe (2026-11-29) ------------------------

RISER_TEE = NETS / "probe8-riser-tee-51.yaml"


def test_a_survey_backs_through_a_steep_tee_to_its_branch_in_one_insertion(
    tmp_path: Path,
) -> None:
    # backing straight through the tee in the riser to reach its branch let the rear
    # half's joints reach the opening before the front half held, and the robot slid,
    # until the PAB counted its way across from the opening's edge; the survey had left
    # such a branch to a second insertion meanwhile
    result = pirate_bt.survey(sim=RISER_TEE, output=tmp_path / "s.yaml")
    assert result.navigation.succeeded, result.navigation.why
    assert result.navigation.counters.violations == 0, result.navigation.counters
    assert result.unexplored == []
    assert result.counts()["tee"] == 1 and result.counts()["straight"] >= 3


# -- network add-tee ---------------------------------------------------------------


def test_a_tee_added_takes_the_pipe_s_diameter_there_and_a_taken_id_is_named() -> None:
    spec = pirate_bt.load_network("lab").spec
    added = insert_tee(spec, "run-e", 0.5)  # behind the reducer to 55 mm
    (tee,) = [s for s in added.segments if s.id == "extra-tee"]
    assert tee.length == pytest.approx(3 * 0.055)  # was 3 x the network's 63 mm
    taken = "the network 'lab' has a segment 'tee-1' already"
    with pytest.raises(ConfigurationError, match=re.escape(taken)):
        insert_tee(spec, "run-c", 1.5, tee_id="tee-1")
    with pytest.raises(ConfigurationError, match=re.escape("a segment 'run-c-after' already")):
        insert_tee(spec, "run-c", 1.5, tee_id="run-c-after")
