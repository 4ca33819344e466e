"""Localisation: odometry drifts, features snap it back; disagreements with the map are caught.

These tests drive a synthetic robot along the map (its IMU reads the pipe's
direction at the rotational module, its wheels over-read by a slip factor), so
they check the localiser alone; the mission tests check it on the simulator.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.pipes import Network, load_network
from pirate_bt.pipes import Path as PipePath
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.loader import load_robot
from pirate_bt.robot.state import RobotState
from pirate_bt.task.localise import DRIFT_PER_M, FIX_BOUND_M, Localiser, imu_tangent
from pirate_bt.task.planner import MissionPlan, load_network_for, plan_route
from pirate_bt.task.route import load_route, parse_route

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def robot() -> RobotDescription:
    return load_robot()


def _state(
    robot: RobotDescription, path: PipePath, s_m: float, t_s: float, v_mps: float
) -> RobotState:
    imu_offset = sum(m.length for m in robot.modules[:3]) + robot.modules[3].length / 2
    tangent = path.tangent_at(max(s_m - imu_offset, 0.0))
    pitch = math.asin(max(-1.0, min(1.0, tangent[2])))
    yaw = math.atan2(tangent[1], tangent[0]) if abs(tangent[2]) < 1 - 1e-9 else 0.0
    drives = {m.name: v_mps for m in robot.drive_motors()}
    return RobotState(
        stamp_s=t_s,
        readings={},
        imu_rad={"roll": 0.0, "pitch": pitch, "yaw": yaw},
        drive_velocity_mps=drives,
    )


def drive(
    loc: Localiser,
    robot: RobotDescription,
    world: PipePath,
    start_m: float,
    end_m: float,
    slip: float = 0.0,
    speed_mps: float = 0.08,
    dt_s: float = 0.05,
) -> list[tuple[float, float, float]]:
    """Drive the truth from start to end; wheels read (1 + slip) x the true speed."""
    s, t = start_m, 0.0
    out: list[tuple[float, float, float]] = []
    truth = {"s": s}
    loc._truth = lambda: truth["s"]
    loc.update(_state(robot, world, s, t, 0.0))
    while s < end_m and loc.mismatch is None:
        s = min(s + speed_mps * dt_s, end_m)
        t += dt_s
        truth["s"] = s
        loc.update(_state(robot, world, s, t, speed_mps * (1 + slip)))
        out.append((s, loc.belief_m, loc.since_fix_m))
    return out


def lab_plan(robot: RobotDescription) -> MissionPlan:
    route = load_route(REPO / "scenarios" / "lab.route")
    return plan_route(route, load_network_for(route, None), robot)


@pytest.mark.parametrize("slip", [0.0, 0.015, -0.015])
def test_belief_error_stays_within_the_stated_bounds(robot: RobotDescription, slip: float) -> None:
    plan = lab_plan(robot)
    loc = Localiser(plan, robot)
    samples = drive(loc, robot, plan.path, plan.start_m, plan.end_m, slip=slip)
    assert loc.mismatch is None
    assert [f.feature for f in loc.fixes] == ["bend-a", "bend-b", "bend-c", "bend-d", "bend-e"]
    for fix in loc.fixes:
        assert fix.error_after_m is not None
        assert abs(fix.error_after_m) <= FIX_BOUND_M, fix
    for truth, belief, since in samples:
        assert abs(belief - truth) <= FIX_BOUND_M + DRIFT_PER_M * since + 1e-9
    if slip:
        # Without the fixes the error would have grown to slip x distance.
        assert abs(slip) * plan.path.length_m > 0.3
        assert max(abs(f.correction_m) for f in loc.fixes) > 0.05


def test_a_turn_where_the_map_has_none_is_a_mismatch(robot: RobotDescription) -> None:
    plan = plan_route(parse_route("forward 3 m\n", "s.route"), load_network("straight"), robot)
    world = load_network("bend-up").main_path()  # the real pipe bends up at 2 m
    loc = Localiser(plan, robot)
    drive(loc, robot, world, plan.start_m, plan.end_m)
    assert loc.mismatch is not None and "the map has no turn" in loc.mismatch


def test_a_turn_the_map_has_but_the_robot_never_felt_is_a_mismatch(
    robot: RobotDescription,
) -> None:
    plan = plan_route(
        parse_route("at the bend turn up\nforward 1 m\n", "b.route"), load_network("bend-up"), robot
    )
    world = load_network("straight").main_path()  # no bend at all
    loc = Localiser(plan, robot)
    drive(loc, robot, world, plan.start_m, world.length_m)  # past the matcher's reach
    assert loc.mismatch is not None and "no turn was felt" in loc.mismatch
    assert "'bend'" in loc.mismatch


def test_imu_tangent() -> None:
    assert imu_tangent({}) is None
    t = imu_tangent({"pitch": math.pi / 2, "yaw": 0.0})
    assert t is not None and t[2] == pytest.approx(1.0)


def test_values_for_the_trace(robot: RobotDescription) -> None:
    plan = lab_plan(robot)
    loc = Localiser(plan, robot, truth=lambda: plan.start_m + 0.01)
    loc.update(None)
    values = loc.values()
    assert values["task.belief_m"] == pytest.approx(plan.start_m)
    assert values["task.error_m"] == pytest.approx(-0.01)


def test_a_turn_into_a_branch_is_a_fix(robot: RobotDescription) -> None:
    route = load_route(REPO / "scenarios" / "lab-service.route")
    plan = plan_route(route, load_network_for(route, None), robot)
    loc = Localiser(plan, robot)
    drive(loc, robot, plan.path, plan.start_m, plan.end_m, slip=0.02)
    assert loc.mismatch is None
    assert [f.feature for f in loc.fixes] == ["bend-a", "tee-1"]
    assert all(abs(f.error_after_m or 0.0) <= FIX_BOUND_M for f in loc.fixes)


# -- the sequence matcher -----------------------------------------------------------------


def _bend_right_world(before_m: float, direction: str = "right") -> PipePath:
    """``bend-right`` as built: the straight before the bend ``before_m`` long."""
    spec = load_network("bend-right").spec
    before, bend, after = spec.segments
    segments = [
        before.model_copy(update={"length": before_m}),
        bend.model_copy(update={"direction": direction}),
        after,
    ]
    return Network(spec.model_copy(update={"segments": segments})).main_path()


def _bend_right_plan(robot: RobotDescription) -> MissionPlan:
    route = parse_route("forward 1 m\nat the bend turn right\nforward 1 m\n", "b.route")
    return plan_route(route, load_network("bend-right"), robot)


@pytest.mark.parametrize("before_m", [2.5, 2.8])
def test_the_next_turn_in_order_is_accepted_further_than_drawn(
    robot: RobotDescription, before_m: float
) -> None:
    plan = _bend_right_plan(robot)
    world = _bend_right_world(before_m)  # drawn 2 m: the bend is 25 % or 40 % further
    loc = Localiser(plan, robot)
    drive(loc, robot, world, plan.start_m, world.length_m - 1.0)
    assert loc.mismatch is None
    (fix,) = loc.fixes
    assert fix.feature == "bend"
    # the belief is put back on the map's bend: the correction is what the map is off
    assert fix.correction_m == pytest.approx(2.0 - before_m, abs=0.05)
    assert fix.confidence < 0.5
    assert fix.drift_per_m == pytest.approx(fix.correction_m / fix.since_fix_m)
    if before_m == 2.8:
        # beyond the map's tolerance: the distance window alone calls it a disagreement
        alone = Localiser(plan, robot, sequence_fraction=0.0)
        drive(alone, robot, world, plan.start_m, world.length_m - 1.0)
        assert alone.mismatch is not None and "no turn was felt" in alone.mismatch


def test_a_fix_where_the_map_has_it_is_confident(robot: RobotDescription) -> None:
    plan = _bend_right_plan(robot)
    loc = Localiser(plan, robot)
    drive(loc, robot, plan.path, plan.start_m, plan.end_m)
    (fix,) = loc.fixes
    assert fix.confidence > 0.9 and abs(fix.drift_per_m) < 0.02


@pytest.mark.parametrize(("built", "said"), [("left", "left"), ("up", "up"), ("down", "down")])
def test_a_turn_in_another_direction_is_a_named_disagreement_at_once(
    robot: RobotDescription, built: str, said: str
) -> None:
    plan = _bend_right_plan(robot)
    world = _bend_right_world(2.0, built)  # in its place, but the wrong way
    loc = Localiser(plan, robot)
    drive(loc, robot, world, plan.start_m, world.length_m - 1.0)
    assert loc.mismatch is not None
    assert f"turned {said} by" in loc.mismatch and "'bend' turning right" in loc.mismatch
    d = loc.disagreement
    assert d is not None and d.feature == "bend" and d.sensed is not None
    assert d.sensed.startswith(f"a turn {said} of ")
    assert "the map's turn goes right" in d.evidence
    assert not loc.fixes
    # found in the turn, not after it
    assert d.belief_m < plan.path.next_turn(0.0).end_m + 0.6  # type: ignore[union-attr]


def test_a_turn_too_far_from_the_maps_for_its_order_is_a_disagreement(
    robot: RobotDescription,
) -> None:
    plan = _bend_right_plan(robot)
    world = _bend_right_world(0.9)  # drawn 2 m: the bend is more than a third nearer
    loc = Localiser(plan, robot)
    drive(loc, robot, world, plan.start_m, world.length_m)
    assert loc.mismatch is not None and "where the map has no turn within" in loc.mismatch
    assert loc.disagreement is not None and loc.disagreement.feature == "bend"


def test_blocked_where_the_map_has_no_turn_is_a_disagreement(robot: RobotDescription) -> None:
    plan = _bend_right_plan(robot)
    loc = Localiser(plan, robot)
    drive(loc, robot, plan.path, plan.start_m, 1.2)
    loc.blocked(10.0)  # 0.8 m before the bend: further than the reach
    assert loc.mismatch is not None and "the pipe blocked the robot at" in loc.mismatch
    d = loc.disagreement
    assert d is not None and d.feature == "bend" and d.sensed is not None
    near = Localiser(plan, robot)
    drive(near, robot, plan.path, plan.start_m, 1.9)
    near.blocked(10.0)  # at the bend (the map's or a little before): what a bend does
    assert near.mismatch is None
