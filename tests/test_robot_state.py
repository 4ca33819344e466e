"""State snapshots and commands: raw <-> SI through the description's conversions."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pirate_bt.errors import InputError
from pirate_bt.robot import (
    CommandCodec,
    ControlMode,
    MotorCommand,
    RawSetpoint,
    RobotDescription,
    StateBuilder,
    load_robot,
)

REPO = Path(__file__).resolve().parent.parent
ROBOTS = {
    "default": load_robot(),
    "rear-imu": load_robot(REPO / "hardware/variants/pirate-rear-imu.yaml"),
    "long": load_robot(REPO / "hardware/variants/pirate-long.yaml"),
}


@st.composite
def raw_frames(draw: st.DrawFn, robot: RobotDescription) -> list[int]:
    return [
        draw(st.integers(c.conversion.raw[0], c.conversion.raw[1])) for c in robot.state_channels()
    ]


@pytest.mark.parametrize("name", sorted(ROBOTS))
@given(data=st.data())
def test_every_sensor_round_trips_raw_si_raw(name: str, data: st.DataObject) -> None:
    robot = ROBOTS[name]
    builder = StateBuilder(robot)
    raw = data.draw(raw_frames(robot))
    state = builder.build(raw, stamp_s=1.0)
    values = {n: r.value for n, r in state.readings.items()}
    assert builder.encode(values) == raw


@pytest.mark.parametrize("name", sorted(ROBOTS))
@given(data=st.data())
def test_every_motor_mode_round_trips_raw_si_raw(name: str, data: st.DataObject) -> None:
    robot = ROBOTS[name]
    codec = CommandCodec(robot)
    slot = data.draw(st.sampled_from(robot.setpoint_slots()))
    mode = data.draw(st.sampled_from(slot.motor.modes.available()))
    conversion = slot.motor.modes.get(mode)
    assert conversion is not None
    raw = data.draw(st.integers(*conversion.raw))
    command = codec.to_si(RawSetpoint(slot.board, slot.slot, mode, raw))
    back = codec.to_raw(command)
    assert abs(back.raw_value - raw) <= 1
    assert (back.board, back.slot, back.mode) == (slot.board, slot.slot, mode)


def test_role_views_and_freshness() -> None:
    robot = ROBOTS["default"]
    builder = StateBuilder(robot)
    values = {c.name: 0.0 for c in robot.state_channels()}
    values.update({"bend_1_angle": 1.5, "bend_3_spring": 10.0, "rotation_angle": -0.5})
    values.update({"imu.pitch": 0.2, "bend_2_drive.velocity": 0.08, "front_tilt_angle": 1.0})
    first = builder.build(builder.encode(values), stamp_s=1.0)
    assert first.joint_angle_rad["bend_1"] == pytest.approx(1.5, abs=2e-3)
    assert first.clamp_force_n["bend_3"] == pytest.approx(10.0)
    assert first.rotation_rad == pytest.approx(-0.5, abs=2e-3)
    assert first.imu_rad["pitch"] == pytest.approx(0.2)
    assert first.drive_velocity_mps["bend_2_drive"] == pytest.approx(0.08)
    assert first.front_tilt_rad == pytest.approx(1.0, abs=2e-3)
    assert first.camera_pan_rad == pytest.approx(0.0)
    # The bridge flags bend_1_angle as not fresh: the old reading and its old stamp stay.
    raw = builder.encode(values)
    raw[[c.name for c in robot.state_channels()].index("bend_1_angle")] = None
    second = builder.build(raw, stamp_s=1.5, previous=first)
    assert second.readings["bend_1_angle"].stamp_s == 1.0
    assert second.age_s("bend_1_angle", now_s=2.0) == pytest.approx(1.0)
    assert second.age_s("never_reported", now_s=2.0) == float("inf")
    assert second.oldest_stamp(["bend_1_angle", "bend_3_spring"]) == 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        second.stamp_s = 3.0  # type: ignore[misc]


def test_wrong_frame_length_is_refused() -> None:
    with pytest.raises(ValueError, match="expected 28 raw values"):
        StateBuilder(ROBOTS["default"]).build([0, 1], stamp_s=0.0)


def test_commands_saturate_and_reject_unknowns() -> None:
    codec = CommandCodec(ROBOTS["default"])
    raw = codec.to_raw(MotorCommand("bend_1_drive", ControlMode.VELOCITY, 99.0))
    assert raw.raw_value == 1200  # saturated to the raw range, never wrapped
    with pytest.raises(InputError, match="unknown motor"):
        codec.to_raw(MotorCommand("warp_drive", ControlMode.PWM, 0.1))
    with pytest.raises(InputError, match="has no torque mode"):
        codec.to_raw(MotorCommand("front_leds", ControlMode.TORQUE, 0.1))
    with pytest.raises(InputError, match="no motor at board 99"):
        codec.to_si(RawSetpoint(99, 0, ControlMode.PWM, 0))


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_a_command_that_is_not_a_number_is_refused_by_name(value: float) -> None:
    # NaN has no nearest raw value and infinity is no quantity to saturate: the caller
    # gets the library's InputError naming the motor, not a bare ValueError/OverflowError
    codec = CommandCodec(ROBOTS["default"])
    with pytest.raises(InputError, match=r"motor 'bend_1_drive': velocity value .* is not finite"):
        codec.to_raw(MotorCommand("bend_1_drive", ControlMode.VELOCITY, value))
