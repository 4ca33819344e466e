"""The drive's sensing stops that back a survey with no map: off an opening the front
half stopped over (``front_opening_cleared``), on a heading change (``until: turned``,
``stop_when_turned``), and the distance driven written back (``travelled_key``).

Split from tests/test_primitives.py, whose rig (a fake port, the real supervisor) it uses.
"""

from __future__ import annotations

import math
import random

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.behaviours.drive import SLOPE_WINDOW_TICKS
from pirate_bt.behaviours.primitives import Clamp, ClampParams, Drive, DriveParams
from pirate_bt.robot import Half
from pirate_bt.robot.commands import ControlMode
from tests.test_primitives import DT, ROBOT, Rig, blocked, clean_blackboard, drive_rig

__all__ = ["clean_blackboard"]  # the autouse fixture, in force here too


def front_over_an_opening() -> Rig:
    """Where a ``front_opening`` stop leaves the robot: both halves asked to clamp, the
    rear clamped, bend_1 swung out over the opening (the supervisor lets it drive)."""
    rig = Rig()
    for half in (Half.REAR, Half.FRONT):
        assert rig.run(rig.node(Clamp, ClampParams(half=half, torque=0.7))) == Status.SUCCESS
    rig.port.set(bend_1_angle=math.radians(110), bend_1_spring=0.0)
    return rig


def test_drive_back_off_an_opening_until_no_front_joint_is_off_the_wall() -> None:
    rig = front_over_an_opening()
    params = DriveParams(velocity=0.04, reverse=True, until="front_opening_cleared")
    node = rig.node(Drive, params)
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    assert rig.port.values["bend_1_drive.velocity"] < 0
    # back at the wall behind the opening's near edge (within the contact angles)
    rig.port.clamp_half(Half.FRONT, 0.7)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "front_opening_cleared"
    assert "front half off the opening" in node.feedback_message


def test_drive_off_an_opening_fails_at_once_when_the_front_is_at_the_wall() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.04, reverse=True, until="front_opening_cleared"))
    assert rig.run(node) == Status.FAILURE
    assert "front half not over an opening" in node.feedback_message
    # it never asked the wheels to turn
    assert not any(c.value for c in rig.port.sent if c.motor.endswith("_drive"))


def test_drive_off_an_opening_gives_up_after_max_distance() -> None:
    rig = front_over_an_opening()
    params = DriveParams(
        velocity=0.08, reverse=True, until="front_opening_cleared", max_distance=0.1
    )
    node = rig.node(Drive, params)
    assert rig.run(node) == Status.FAILURE
    assert "no feature (front_opening_cleared) within 0.1 m" in node.feedback_message


def _heading(rig: Rig, pitch_deg: float, yaw_deg: float) -> None:
    rig.port.set(imu__pitch=math.radians(pitch_deg), imu__yaw=math.radians(yaw_deg))


@pytest.mark.parametrize(("pitch", "yaw"), [(0.0, 12.0), (0.0, -12.0), (12.0, 0.0), (-12.0, 0.0)])
def test_drive_until_turned_ends_on_a_heading_change_either_way(pitch: float, yaw: float) -> None:
    rig = drive_rig()
    _heading(rig, 0.0, 170.0)  # across the yaw's wrap: only the change counts
    params = DriveParams(velocity=0.04, until="turned", turn_angle=math.radians(8))
    node = rig.node(Drive, params)
    rig.run(node, ticks=10)
    _heading(rig, 0.0, 174.0)  # half the threshold: still running
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    _heading(rig, pitch, 170.0 + yaw)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "turned"
    assert "turned 12.0°" in node.feedback_message


def test_drive_until_turned_needs_the_change_two_ticks_running() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.04, until="turned"))
    rig.run(node, ticks=5)
    _heading(rig, 0.0, 20.0)  # one reading off (noise, a bad frame)
    node.tick_once()
    _heading(rig, 0.0, 0.0)
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    _heading(rig, 0.0, 20.0)
    assert rig.run(node) == Status.SUCCESS


def test_drive_until_turned_gives_up_after_max_distance() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="turned", max_distance=0.2))
    assert rig.run(node) == Status.FAILURE
    assert "no feature (turned) within 0.2 m" in node.feedback_message


def test_drive_until_blocked_stops_when_turned() -> None:
    # the turn into a tee's branch: the front half is in once the robot turns; the rear
    # half, holding, must stop before it reaches the branch's opening
    rig = drive_rig()
    _heading(rig, 0.0, 170.0)
    params = DriveParams(
        velocity=0.08, until="blocked", stop_when_turned=True, turn_angle=math.radians(8)
    )
    node = rig.node(Drive, params)
    rig.run(node, ticks=10)
    _heading(rig, 0.0, 176.0)
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    _heading(rig, 0.0, 182.0)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "turned"
    assert "turned 12.0°" in node.feedback_message
    last = rig.port.batches[-1]
    assert all(c.mode is ControlMode.VELOCITY and c.value == 0.0 for c in last)
    # blocked before it turned: done as ever
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="blocked", stop_when_turned=True))
    rig.run(node, ticks=10)
    blocked(rig)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "blocked"


def test_drive_until_blocked_ignores_a_turn_without_stop_when_turned() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, until="blocked", max_distance=0.2))
    rig.run(node, ticks=10)
    _heading(rig, 0.0, 40.0)
    assert rig.run(node) == Status.FAILURE
    assert "no feature (blocked) within 0.2 m" in node.feedback_message


def test_stop_when_turned_needs_pitch_and_yaw() -> None:
    rig = drive_rig()
    del rig.port.values["imu.yaw"]
    node = rig.node(Drive, DriveParams(velocity=0.08, until="blocked", stop_when_turned=True))
    assert rig.run(node) == Status.FAILURE
    assert "no IMU pitch and yaw: cannot tell a turn (stop_when_turned)" in node.feedback_message


def test_drive_until_turned_needs_pitch_and_yaw() -> None:
    rig = drive_rig()
    del rig.port.values["imu.yaw"]
    node = rig.node(Drive, DriveParams(velocity=0.08, until="turned"))
    assert rig.run(node) == Status.FAILURE
    assert "no IMU pitch and yaw" in node.feedback_message


def test_drive_writes_how_far_it_went_and_a_drive_back_reads_it() -> None:
    rig = drive_rig()
    bb = py_trees.blackboard.Blackboard
    bb.set("/went", 9.0)
    out = rig.node(
        Drive, DriveParams(velocity=0.08, until="turned", max_distance=0.2, travelled_key="went")
    )
    out.tick_once()
    assert bb.get("/went") == 0.0  # written as it starts: never a previous drive's
    assert rig.run(out) == Status.FAILURE  # it wrote the distance all the same
    went = bb.get("/went")
    assert went == pytest.approx(0.2, abs=0.01) and went >= 0.2
    back = rig.node(Drive, DriveParams(velocity=0.08, reverse=True, distance_key="went"))
    start = rig.clock.now()
    assert rig.run(back) == Status.SUCCESS
    assert rig.clock.now() - start == pytest.approx(went / 0.08, rel=0.1)
    # backwards too it writes a distance, never negative
    again = rig.node(
        Drive, DriveParams(velocity=0.08, reverse=True, distance=0.1, travelled_key="/went")
    )
    assert rig.run(again) == Status.SUCCESS
    assert bb.get("/went") == pytest.approx(0.1, abs=0.01)


def test_drive_writes_how_far_it_went_when_interrupted() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=2.0, travelled_key="went"))
    rig.run(node, ticks=21)
    node.stop(Status.INVALID)
    went = py_trees.blackboard.Blackboard.get("/went")
    assert 0.05 < went < 0.2
    assert rig.port.values["bend_1_drive.velocity"] == 0.0


def test_travelled_key_is_a_blackboard_write() -> None:
    assert Drive.blackboard_writes(DriveParams(velocity=0.08, distance=1.0)) == ()
    params = DriveParams(velocity=0.08, distance=1.0, travelled_key="/went")
    assert Drive.blackboard_writes(params) == ("went",)


def test_drive_stops_where_the_slope_changes() -> None:
    rig = drive_rig()
    _heading(rig, 2.0, 30.0)
    params = DriveParams(velocity=0.08, distance=2.0, stop_at_change=True)
    node = rig.node(Drive, params)
    rig.run(node, ticks=20)
    _heading(rig, 2.2, 30.0)  # under 0.25 deg: the same slope
    rig.run(node, ticks=40)
    assert node.status == Status.RUNNING
    _heading(rig, 2.5, 30.0)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "slope" and "the slope changed" in node.feedback_message
    last = rig.port.batches[-1]
    assert all(c.mode is ControlMode.VELOCITY and c.value == 0.0 for c in last)


def test_imu_noise_does_not_end_a_drive_but_a_small_slope_change_does() -> None:
    rig = drive_rig()
    rng = random.Random(7)
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=20.0, stop_at_change=True))
    for _ in range(3000):  # 30 s of 0.11 deg noise (SensorNoise.typical) on a 3 deg slope
        _heading(rig, 3.0 + math.degrees(rng.gauss(0.0, 0.002)), 0.0)
        rig.run(node, ticks=1)
    assert node.status == Status.RUNNING
    ticks = 0
    while node.status == Status.RUNNING and ticks < 100:  # 3.0 to 2.7 deg: 0.3 deg
        _heading(rig, 2.7 + math.degrees(rng.gauss(0.0, 0.002)), 0.0)
        rig.run(node, ticks=1)
        ticks += 1
    assert node.sensed == "slope"
    assert ticks <= SLOPE_WINDOW_TICKS + 3  # felt within a window and the settle ticks
    # and placed where it began, not where it was felt
    step_m = 0.08 * DT
    assert node.sensed_back_m == pytest.approx(ticks * step_m, abs=2.5 * step_m)


def test_drive_stops_where_a_leading_joint_reads_another_diameter() -> None:
    rig = drive_rig()
    clamp = ROBOT.clamp
    d0 = rig.port.diameter_m
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=2.0, stop_at_change=True))
    rig.run(node, ticks=10)
    rig.port.set(bend_1_angle=clamp.contact_angle(d0 - 0.001))  # 1 mm: not yet
    rig.run(node, ticks=10)
    assert node.status == Status.RUNNING
    rig.port.set(bend_1_angle=clamp.contact_angle(d0 - 0.008))  # down a cone
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed == "diameter"


def test_drive_without_stop_at_change_drives_through_changes() -> None:
    rig = drive_rig()
    node = rig.node(Drive, DriveParams(velocity=0.08, distance=0.3))
    rig.run(node, ticks=10)
    _heading(rig, 5.0, 0.0)
    assert rig.run(node) == Status.SUCCESS
    assert node.sensed is None


def test_stop_at_change_is_for_a_distance_drive() -> None:
    params = DriveParams(velocity=0.08, until="blocked", stop_at_change=True)
    problems = Drive.check_limits(params, ROBOT)
    assert any("stop_at_change: only with until: distance" in p for p in problems)
