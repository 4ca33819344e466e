"""Localisation: odometry drifts, features snap it back; disagreements with the map are caught.

These tests drive a synthetic robot along the map (its IMU reads the pipe's
direction at the rotational module, its wheels over-read by a slip factor), so
they check the localiser alone; the mission tests check it on the simulator.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.pipes import Path as PipePath
from pirate_bt.pipes import load_network
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
    drive(loc, robot, world, plan.start_m, plan.end_m)
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
