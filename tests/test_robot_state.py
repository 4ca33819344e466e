"""State snapshots and commands: raw <-> SI through the description's conversions."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import py_trees
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pirate_bt.clock import SimClock
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
from pirate_bt.robot.state import RobotState
from pirate_bt.trace import TickExtras, TraceRecorder
from pirate_bt.trace.records import state_layout

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


def _flattened(state: RobotState) -> tuple[tuple[str | None, ...], tuple[object, ...]]:
    """The views flattened from the mappings themselves (the trace's own way)."""
    return state_layout(dataclasses.replace(state))


@pytest.mark.parametrize("name", sorted(ROBOTS))
@given(data=st.data())
def test_the_row_a_builder_makes_is_the_views_flattened(name: str, data: st.DataObject) -> None:
    # RobotState.row is what the trace records each tick: it must be the views, in
    # their order, whichever channels have reported; with a view's channel missing the
    # builder makes none (the trace flattens the views itself).
    robot = ROBOTS[name]
    builder = StateBuilder(robot)
    raw: list[int | None] = list(data.draw(raw_frames(robot)))
    missing = data.draw(st.sets(st.integers(0, len(raw) - 1), max_size=4))
    for index in missing:
        raw[index] = None
    state = builder.build(raw, stamp_s=2.0)
    views = {
        *state.joint_angle_rad.values(),
        *state.clamp_force_n.values(),
        *state.imu_rad.values(),
        *state.drive_velocity_mps.values(),
        *state.motor_current_a.values(),
    }
    assert views <= {reading.value for reading in state.readings.values()}
    entries = sum(map(len, (state.joint_angle_rad, state.clamp_force_n, state.imu_rad)))
    entries += len(state.drive_velocity_mps) + len(state.motor_current_a)
    every = builder.build([c.conversion.zero_raw for c in robot.state_channels()], 2.0)
    full = sum(map(len, (every.joint_angle_rad, every.clamp_force_n, every.imu_rad)))
    full += len(every.drive_velocity_mps) + len(every.motor_current_a)
    if state.row is None:
        assert entries < full, "every view is whole, yet no row"
    else:
        assert entries == full
        assert state.row == _flattened(state)
        assert state.row[1][-4:] == (
            state.rotation_rad,
            state.camera_tilt_rad,
            state.camera_pan_rad,
            state.front_tilt_rad,
        )


def test_the_row_is_shared_layout_and_left_out_of_equality_and_replace() -> None:
    robot = ROBOTS["default"]
    builder = StateBuilder(robot)
    values = {c.name: 0.25 for c in robot.state_channels()}
    first = builder.build(builder.encode(values), stamp_s=1.0)
    second = builder.build(builder.encode(values), stamp_s=1.0)
    assert first.row is not None and second.row is not None
    assert first.row[0] is second.row[0]  # one layout object: a trace compares by identity
    assert first == second
    moved = dataclasses.replace(first, rotation_rad=1.0)
    assert moved.row is None  # a changed copy never carries the old values
    assert _flattened(moved)[1][-4] == 1.0
    assert "row" not in repr(first)
    # A view channel not yet reported: the views skip it and no row is made.
    raw = builder.encode(values)
    raw[builder.channel_names.index("bend_2_spring")] = None
    partial = builder.build(raw, stamp_s=1.0)
    assert partial.row is None
    assert "bend_2" not in partial.clamp_force_n and "bend_1" in partial.clamp_force_n
    assert builder.from_readings(partial.readings, 1.5).row is None


def test_a_trace_records_the_same_from_the_row_as_from_the_views(tmp_path: Path) -> None:
    robot = ROBOTS["default"]
    builder = StateBuilder(robot)
    names = builder.channel_names
    states = []
    previous = None
    for n in range(12):
        values = {name: 0.01 * n * (i % 3) for i, name in enumerate(names)}
        raw = builder.encode(values)
        if n in (4, 5):
            raw[names.index("imu.pitch")] = None  # not fresh: kept with its old stamp
        previous = builder.build(raw, stamp_s=0.05 * n, previous=previous)
        states.append(previous)
    assert all(s.row is not None for s in states)
    lines = []
    for variant, snapshots in (
        ("row", states),
        ("views", [dataclasses.replace(s) for s in states]),
    ):
        tree = py_trees.trees.BehaviourTree(py_trees.behaviours.Running("idle"))
        path = tmp_path / f"{variant}.jsonl"
        clock = SimClock()
        with TraceRecorder(path, tree, clock=clock) as recorder:
            for snapshot in snapshots:
                clock.advance(0.05)
                tree.tick()
                recorder.record_tick(TickExtras(state=snapshot))
        lines.append([line for line in path.read_text().splitlines() if '"tick"' in line])
    assert len(lines[0]) == 12
    assert sum('"state":' in line for line in lines[0]) >= 10  # the state moved each tick
    assert lines[0] == lines[1]
