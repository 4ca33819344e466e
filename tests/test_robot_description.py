"""The robot description: the default robot, variants, role queries, wire layout."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.resources import default_robot_path
from pirate_bt.robot import Half, MotorFunction, Role, SensorKind, load_robot

REPO = Path(__file__).resolve().parent.parent

# DOMAIN.md's board table: board -> (module, motor0, motor1, sensor0, sensor1)
BOARD_TABLE = {
    20: ("front", MotorFunction.CAMERA_TILT, MotorFunction.CAMERA_PAN, "angle", "angle"),
    21: ("front", MotorFunction.TILT, MotorFunction.LEDS, "angle", None),
    22: ("bend_1", MotorFunction.BEND, MotorFunction.DRIVE, "angle", "spring"),
    23: ("bend_2", MotorFunction.BEND, MotorFunction.DRIVE, "angle", "spring"),
    24: ("rotational", None, MotorFunction.DRIVE, "imu", None),
    25: ("rotational", MotorFunction.ROTATE, MotorFunction.DRIVE, "angle", None),
    26: ("bend_3", MotorFunction.BEND, MotorFunction.DRIVE, "angle", "spring"),
    27: ("bend_4", MotorFunction.BEND, MotorFunction.DRIVE, "angle", "spring"),
    28: ("rear", None, MotorFunction.LEDS, "angle", None),
}


def test_default_robot_matches_the_domain_board_table() -> None:
    robot = load_robot()
    assert sorted(b.id for b in robot.boards) == sorted(BOARD_TABLE)
    for board in robot.boards:
        module, m0, m1, s0, s1 = BOARD_TABLE[board.id]
        assert board.module == module
        motors = {m.slot: m.function for m in board.motors}
        sensors = {s.slot: str(s.kind) for s in board.sensors}
        assert (motors.get(0), motors.get(1)) == (m0, m1), board.id
        assert (sensors.get(0), sensors.get(1)) == (s0, s1), board.id
    assert [m.name for m in robot.modules] == [
        "front", "bend_1", "bend_2", "rotational", "bend_3", "bend_4", "rear"
    ]  # fmt: skip


def test_roles_find_hardware_without_board_numbers() -> None:
    robot = load_robot()
    assert [m.name for m in robot.bend_modules(Half.FRONT)] == ["bend_1", "bend_2"]
    assert [m.name for m in robot.bend_modules(Half.REAR)] == ["bend_3", "bend_4"]
    assert robot.joint_motor("bend_3").name == "bend_3_joint"
    assert robot.board_of("bend_3_joint").id == 26
    assert robot.rotate_motor().function is MotorFunction.ROTATE
    assert robot.rotational_module().role is Role.ROTATIONAL
    assert len(robot.drive_motors()) == 6
    assert robot.sensor_of("bend_2", SensorKind.SPRING).name == "bend_2_spring"
    assert robot.module_of("rotation_angle").name == "rotational"
    assert Half.FRONT.other is Half.REAR
    with pytest.raises(KeyError, match="has no drive motor"):
        robot.motor_of("front", MotorFunction.DRIVE)


def test_clamp_parameters_and_contact_angle_interpolation() -> None:
    clamp = load_robot().clamp
    assert (clamp.nominal_band.min, clamp.nominal_band.max) == (1.4, 1.74)
    low, high = clamp.contact_angle(0.063), clamp.contact_angle(0.080)
    assert low == pytest.approx(1.45) and high == pytest.approx(1.58)
    assert low < clamp.contact_angle(0.070) < high
    assert clamp.contact_angle(0.010) == clamp.contact_angles[0].angle
    assert clamp.contact_angle(1.0) == clamp.contact_angles[-1].angle


def test_limits_are_si_with_policies() -> None:
    joint = load_robot().joint_motor("bend_1")
    assert joint.limits.angle is not None and joint.limits.torque is not None
    assert joint.limits.angle.max == pytest.approx(math.radians(110))
    assert joint.limits.torque.max == pytest.approx(0.8)
    assert joint.limits.torque.policy == "refuse"
    assert joint.limits.angle.policy == "clip"


def test_wire_layout_fits_and_is_stable() -> None:
    robot = load_robot()
    channels = robot.state_channels()
    assert [c.index for c in channels] == list(range(len(channels)))
    assert channels[0].board == 20 and channels[-1].name == "rear_angle"
    assert len(robot.setpoint_slots()) == 16
    assert robot.layout_digest() == load_robot().layout_digest()
    assert len(robot.digest()) == 64


@pytest.mark.parametrize(
    ("path", "extra_channels", "extra_motors"),
    [
        ("hardware/variants/pirate-rear-imu.yaml", ["rear_imu.roll", "rear_imu.yaw"], 0),
        ("hardware/variants/pirate-long.yaml", ["bend_5_angle", "bend_6_spring"], 4),
    ],
)
def test_variants_load_and_extend_the_layout(
    path: str, extra_channels: list[str], extra_motors: int
) -> None:
    base = load_robot()
    robot = load_robot(REPO / path)
    names = [c.name for c in robot.state_channels()]
    assert set(extra_channels) <= set(names)
    assert len(robot.setpoint_slots()) == len(base.setpoint_slots()) + extra_motors
    assert robot.layout_digest() != base.layout_digest()


def test_long_variant_has_a_rear_half_of_four_bend_modules() -> None:
    robot = load_robot(REPO / "hardware/variants/pirate-long.yaml")
    assert [m.name for m in robot.bend_modules(Half.REAR)] == [
        "bend_3", "bend_4", "bend_5", "bend_6"
    ]  # fmt: skip
    assert robot.joint_motor("bend_6").name == "bend_6_joint"


def test_bundled_default_is_found() -> None:
    assert default_robot_path().is_file()
