"""The static limits at their edges: what passes exactly at a limit, what a clip sends, what
a rate limit measures from.

Written with the mutation run (docs/testing.md). Each test states a rule an operator
relies on: a command exactly at a limit goes out unchanged (limits are inclusive); a
reversal of the wheels is a speed-up; a rate limit counts from the last setpoint of the
same mode, else from the measured value, over at most ``safety.rate_window``.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.robot import ControlMode, Half, MotorCommand, load_robot
from pirate_bt.robot.description import RobotDescription
from pirate_bt.safety import (
    Bend,
    Clamp,
    Drive,
    Outcome,
    Raw,
    Reason,
    Rotate,
    Source,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()
WINDOW = ROBOT.safety.rate_window
DRIVE_LIMITS = ROBOT.motor("bend_1_drive").limits
ROTATE_LIMITS = ROBOT.motor("rotate").limits
TILT_LIMITS = ROBOT.motor("front_tilt").limits
JOINT_LIMITS = ROBOT.motor("bend_1_joint").limits
ACCEL_STEP = DRIVE_LIMITS.acceleration.max * WINDOW  # type: ignore[union-attr]
V_MAX = DRIVE_LIMITS.velocity.max  # type: ignore[union-attr]
ROTATE_RATE = ROTATE_LIMITS.angular_velocity.max  # type: ignore[union-attr]
TILT_RATE = TILT_LIMITS.angular_velocity.max  # type: ignore[union-attr]
JOINT_RATE = JOINT_LIMITS.angular_velocity.max  # type: ignore[union-attr]


@pytest.fixture
def clock() -> SimClock:
    return SimClock(100.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    return FakePort(ROBOT, clock)


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


def wheels(port: FakePort, velocity_mps: float) -> None:
    for motor in ROBOT.drive_motors():
        port.set(**{f"{motor.name}.velocity": velocity_mps})


def robot_variant(tmp_path: Path, *edits: tuple[str, str]) -> RobotDescription:
    """The bundled robot with its description text edited (each edit must apply)."""
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "variant.yaml"
    path.write_text(text)
    return load_robot(path)


def ramp(sup: Supervisor, clock: SimClock, target_mps: float) -> None:
    """Drive up to ``target_mps`` within the acceleration limit, one window at a time."""
    v = 0.0
    while v != target_mps:
        v = min(v + ACCEL_STEP, target_mps) if target_mps > 0 else max(v - ACCEL_STEP, target_mps)
        assert sup.command(Drive(v)).outcome is Outcome.PASS
        clock.advance(1.0)  # more than a window: a whole window's step (exactly) is allowed


# -- a command exactly at a limit passes unchanged -----------------------------------------


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_drive_exactly_at_the_speed_limit_passes_unclipped(
    sup: Supervisor, port: FakePort, clock: SimClock, sign: float
) -> None:
    port.clamp_half(Half.REAR)
    ramp(sup, clock, sign * (V_MAX - ACCEL_STEP / 2))
    v = sup.command(Drive(sign * V_MAX))
    assert v.outcome is Outcome.PASS, v
    assert [c.value for c in v.sent] == [sign * V_MAX] * len(ROBOT.drive_motors())


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_speed_up_exactly_at_the_acceleration_limit_passes_unclipped(
    sup: Supervisor, port: FakePort, sign: float
) -> None:
    port.clamp_half(Half.REAR)
    v = sup.command(Drive(sign * ACCEL_STEP))
    assert v.outcome is Outcome.PASS, v
    assert {c.value for c in v.sent} == {sign * ACCEL_STEP}


@pytest.mark.parametrize("torque", [JOINT_LIMITS.torque.max, -JOINT_LIMITS.torque.max])  # type: ignore[union-attr]
def test_a_torque_exactly_at_the_limit_passes(
    sup: Supervisor, port: FakePort, torque: float
) -> None:
    """The torque limit refuses (its policy), but not a torque exactly at it."""
    port.clamp_half(Half.FRONT)
    v = sup.command(Raw(MotorCommand("bend_3_joint", ControlMode.TORQUE, torque)))
    assert v.outcome is Outcome.PASS, v
    assert v.sent == (MotorCommand("bend_3_joint", ControlMode.TORQUE, torque),)
    assert sup.command(Clamp(Half.REAR, abs(torque))).outcome is Outcome.PASS


@pytest.mark.parametrize("edge", [ROTATE_LIMITS.angle.max, ROTATE_LIMITS.angle.min])  # type: ignore[union-attr]
def test_a_rotation_exactly_at_its_range_passes(
    sup: Supervisor, port: FakePort, edge: float
) -> None:
    """The rotation range refuses (its policy), but not a target exactly at its end."""
    port.clamp_half(Half.REAR)
    port.set(rotation_angle=edge * 0.99)
    v = sup.command(Rotate(edge))
    assert v.outcome is Outcome.PASS, v
    assert v.sent[0].value == edge


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_rotation_step_exactly_at_the_rate_limit_passes(
    sup: Supervisor, port: FakePort, sign: float
) -> None:
    port.clamp_half(Half.REAR)
    step = sign * ROTATE_RATE * WINDOW
    v = sup.command(Rotate(step))
    assert v.outcome is Outcome.PASS, v
    assert v.sent[0].value == step


# -- what a clip sends and says --------------------------------------------------------------


def test_a_tilt_below_its_range_is_clipped_to_the_lower_end(
    sup: Supervisor, port: FakePort
) -> None:
    low = TILT_LIMITS.angle.min  # type: ignore[union-attr]
    port.set_tilt(low + math.radians(5))
    v = sup.command(Tilt(math.radians(-120)))
    assert v.outcome is Outcome.CLIP and v.clips == (Reason.ANGLE_LIMIT,)
    assert v.sent[0].value == low
    assert v.detail == (
        f"front_tilt: angle {math.radians(-120):g} outside [{low:g}, {-low:g}], clipped to {low:g}"
    )


def test_a_clip_lists_every_limit_it_applied_in_order(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    v = sup.command(Drive(0.2))
    assert v.outcome is Outcome.CLIP
    assert v.reason is Reason.VELOCITY_LIMIT
    # each wheel's motor clipped twice, in the order the limits apply
    n = len(ROBOT.drive_motors())
    assert v.clips == (Reason.VELOCITY_LIMIT, Reason.ACCELERATION_LIMIT) * n
    assert [c.value for c in v.sent] == [ACCEL_STEP] * n
    first, second = v.detail.split("; ")[:2]
    assert (
        first == f"bend_1_drive: velocity 0.2 outside [{-V_MAX:g}, {V_MAX:g}], clipped to {V_MAX:g}"
    )
    assert second.startswith("bend_1_drive: velocity change from 0 in 0.1 s: target 0.1 outside")
    assert second.endswith(f"clipped to {ACCEL_STEP:g}")
    assert v.detail.count("; ") == 2 * n - 1


def test_an_angle_clip_and_a_rate_clip_together(port: FakePort, clock: SimClock) -> None:
    high = TILT_LIMITS.angle.max  # type: ignore[union-attr]
    port.set_tilt(math.radians(60))
    v = Supervisor(port, clock).command(Tilt(math.radians(120)))
    assert v.clips == (Reason.ANGLE_LIMIT, Reason.ANGULAR_RATE_LIMIT)
    assert v.sent[0].value == pytest.approx(math.radians(60) + TILT_RATE * WINDOW)
    port.set_tilt(high - math.radians(5))
    v = Supervisor(port, clock).command(Tilt(math.radians(120)))
    assert v.clips == (Reason.ANGLE_LIMIT,) and v.sent[0].value == high


def test_a_refusing_limit_names_the_motor_and_the_range(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    v = sup.command(Rotate(math.radians(179)))
    hi = ROTATE_LIMITS.angle.max  # type: ignore[union-attr]
    assert v.refused and v.reason is Reason.ANGLE_LIMIT
    assert v.detail == f"rotate: angle {math.radians(179):g} outside [{-hi:g}, {hi:g}]"
    assert v.sent == ()


def test_a_refused_speed_is_not_then_checked_for_acceleration(
    tmp_path: Path, clock: SimClock
) -> None:
    robot = robot_variant(
        tmp_path,
        ("velocity: {max: 100 mm/s, policy: clip}", "velocity: {max: 100 mm/s, policy: refuse}"),
    )
    port = FakePort(robot, clock)
    port.clamp_half(Half.REAR)
    sup = Supervisor(port, clock)
    v = sup.command(Drive(0.2))
    assert v.refused and v.reason is Reason.VELOCITY_LIMIT and v.clips == ()
    assert v.detail == "bend_1_drive: velocity 0.2 outside [-0.1, 0.1]"


# -- the acceleration limit: a reversal is a speed-up, slowing down never limited -----------


def test_a_reversal_is_limited_like_a_speed_up(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    """+0.05 m/s told to go -0.05 m/s in one window: the wheels stop (slowing down is
    free), and the speed-up the other way counts from +0.05 m/s, one step: 0.05 - step
    is still forward, so the reversal is clipped to a stop (it was clipped to 0.05 -
    step, forward, until the twenty-second session: tests/test_world22_reversal.py)."""
    port.clamp_half(Half.REAR)
    ramp(sup, clock, 0.05)
    v = sup.command(Drive(-0.05))
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ACCELERATION_LIMIT
    assert [c.value for c in v.sent] == [0.0] * len(v.sent)


def test_slowing_down_and_holding_speed_are_never_limited(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    port.clamp_half(Half.REAR)
    assert sup.command(Drive(0.0)).outcome is Outcome.PASS  # at rest, stay at rest
    clock.advance(1.0)
    ramp(sup, clock, 0.08)
    same = sup.command(Drive(0.08))  # the same instant: no time to change speed at all
    assert same.outcome is Outcome.PASS
    assert sup.command(Drive(0.0)).outcome is Outcome.PASS
    assert sup.command(Drive(0.0)).sent[0].value == 0.0


def test_the_acceleration_limit_counts_from_the_measured_wheel_speed(
    sup: Supervisor, port: FakePort
) -> None:
    """No setpoint yet: the wheels' measured speed is where a speed-up starts."""
    port.clamp_half(Half.REAR)
    wheels(port, 0.05)
    v = sup.command(Drive(0.05 + ACCEL_STEP))
    assert v.outcome is Outcome.PASS, v
    wheels(port, -0.05)
    sup2 = Supervisor(port, sup.clock)
    v = sup2.command(Drive(0.05))
    assert v.outcome is Outcome.CLIP
    assert [c.value for c in v.sent] == [0.0] * len(v.sent)  # a reversal: stopped first
    assert "velocity change from -0.05 in" in v.detail


def test_without_a_wheel_reading_a_speed_up_counts_from_rest(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.REAR)
    for motor in ROBOT.drive_motors():
        del port.values[f"{motor.name}.velocity"]
    v = sup.command(Drive(0.08))
    assert v.outcome is Outcome.CLIP
    assert {c.value for c in v.sent} == {ACCEL_STEP}


# -- rate limits: from what, over how long -------------------------------------------------


def test_the_rate_limit_counts_the_time_since_the_last_setpoint(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    port.clamp_half(Half.REAR)
    assert sup.command(Rotate(0.05)).outcome is Outcome.PASS
    clock.advance(WINDOW / 2)
    v = sup.command(Rotate(1.0))
    assert v.sent[0].value == pytest.approx(0.05 + ROTATE_RATE * WINDOW / 2)
    assert "in 0.05 s" in v.detail
    clock.advance(60.0)  # a long pause counts as one window, no more
    v = sup.command(Rotate(1.0))
    assert v.sent[0].value == pytest.approx(0.05 + ROTATE_RATE * WINDOW * 1.5)
    assert "in 0.1 s" in v.detail


def test_no_time_no_step(sup: Supervisor, port: FakePort) -> None:
    """Two setpoints in the same instant: the second may not move the joint at all."""
    port.clamp_half(Half.REAR)
    assert sup.command(Rotate(0.05)).outcome is Outcome.PASS
    v = sup.command(Rotate(0.06))
    assert v.outcome is Outcome.CLIP and v.sent[0].value == 0.05


def test_a_rate_limit_after_a_mode_change_counts_from_the_measured_angle(
    sup: Supervisor, port: FakePort
) -> None:
    """After a clamp (torque), an unclamp (position) starts where the joints are."""
    port.clamp_half(Half.FRONT)
    assert sup.command(Clamp(Half.REAR, 0.6)).ok
    port.clamp_half(Half.REAR)
    at_wall = port.values["bend_3_angle"]
    v = sup.command(Unclamp(Half.REAR))
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ANGULAR_RATE_LIMIT
    assert [c.value for c in v.sent] == [pytest.approx(at_wall - JOINT_RATE * WINDOW)] * 2


@pytest.mark.parametrize(
    ("setup", "command", "motor_limit_rate", "measured"),
    [
        ("rotation_angle", Rotate(0.0), ROTATE_RATE, 1.0),
        ("front_tilt_angle", Tilt(0.0), TILT_RATE, math.radians(60)),
        ("bend_1_angle", Bend("bend_1", 0.0), JOINT_RATE, 1.0),
    ],
)
def test_a_first_setpoint_is_rate_limited_from_the_measured_value(
    sup: Supervisor,
    port: FakePort,
    setup: str,
    command: Rotate | Tilt | Bend,
    motor_limit_rate: float,
    measured: float,
) -> None:
    port.clamp_half(Half.REAR)
    if setup != "rotation_angle":
        port.free_half(Half.FRONT)
    port.set(**{setup: measured})
    v = sup.command(command)
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ANGULAR_RATE_LIMIT, v
    assert v.sent[0].value == pytest.approx(measured - motor_limit_rate * WINDOW)


CAMERA_RATE = (
    "angle: {min: -90 deg, max: 90 deg, policy: clip}\n      - slot: 1",
    "angle: {min: -90 deg, max: 90 deg, policy: clip}\n"
    "          angular_velocity: {max: 10 deg/s, policy: clip}\n      - slot: 1",
)
PAN_RATE = (
    "angle: {min: -90 deg, max: 90 deg, policy: clip}\n    sensors:",
    "angle: {min: -90 deg, max: 90 deg, policy: clip}\n"
    "          angular_velocity: {max: 20 deg/s, policy: clip}\n    sensors:",
)


@pytest.mark.parametrize(
    ("motor", "channel", "rate"),
    [("camera_tilt", "camera_tilt_angle", 10), ("camera_pan", "camera_pan_angle", 20)],
)
def test_camera_rate_limits_count_from_the_measured_camera_angle(
    tmp_path: Path, clock: SimClock, motor: str, channel: str, rate: float
) -> None:
    robot = robot_variant(tmp_path, CAMERA_RATE, PAN_RATE)
    port = FakePort(robot, clock)
    sup = Supervisor(port, clock)
    port.set(**{channel: 1.0})
    v = sup.command(Raw(MotorCommand(motor, ControlMode.POSITION, 0.0)))
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ANGULAR_RATE_LIMIT
    assert v.sent[0].value == pytest.approx(1.0 - math.radians(rate) * WINDOW)


def test_a_camera_may_be_pointed_before_any_state_arrives(clock: SimClock) -> None:
    """Cameras and lights move nothing a safety rule is about: no state needed."""

    class Silent(FakePort):
        def state(self) -> None:  # type: ignore[override]
            return None

    sup = Supervisor(Silent(ROBOT, clock), clock)
    sup.set_mode(sup.mode.MANUAL)
    v = sup.command(
        Raw(MotorCommand("camera_pan", ControlMode.POSITION, 0.5)), source=Source.OPERATOR
    )
    assert v.outcome is Outcome.PASS, v
    assert v.sent == (MotorCommand("camera_pan", ControlMode.POSITION, 0.5),)


def test_every_limit_s_message_names_the_motor_the_quantity_and_the_bounds(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    port.clamp_half(Half.FRONT)
    over = sup.command(Raw(MotorCommand("bend_3_joint", ControlMode.TORQUE, 0.9)))
    assert over.refused and over.reason is Reason.TORQUE_LIMIT
    assert over.detail == "bend_3_joint: torque 0.9 outside [-0.8, 0.8]"
    port.clamp_half(Half.REAR)
    port.free_half(Half.FRONT)
    step = sup.command(Rotate(1.0))
    hi = ROTATE_RATE * WINDOW
    assert step.detail == (
        f"rotate: angle step from 0 in 0.1 s: target 1 outside [{-hi:g}, {hi:g}], clipped to {hi:g}"
    )
    speed = sup.command(Drive(0.08))
    assert speed.detail.split("; ")[0] == (
        f"bend_1_drive: velocity change from 0 in 0.1 s: target 0.08 outside"
        f" [{-ACCEL_STEP:g}, {ACCEL_STEP:g}], clipped to {ACCEL_STEP:g}"
    )


@pytest.mark.parametrize(
    ("edit", "command", "reason"),
    [
        (
            (
                "angular_velocity: {max: 60 deg/s, policy: clip}",
                "angular_velocity: {max: 60 deg/s, policy: refuse}",
            ),
            Rotate(1.0),
            Reason.ANGULAR_RATE_LIMIT,
        ),
        (
            (
                "acceleration: {max: 400 mm/s^2, policy: clip}",
                "acceleration: {max: 400 mm/s^2, policy: refuse}",
            ),
            Drive(0.08),
            Reason.ACCELERATION_LIMIT,
        ),
    ],
)
def test_rate_limits_refuse_when_their_policy_says_so(
    tmp_path: Path,
    clock: SimClock,
    edit: tuple[str, str],
    command: Rotate | Drive,
    reason: Reason,
) -> None:
    robot = robot_variant(tmp_path, edit)
    port = FakePort(robot, clock)
    port.clamp_half(Half.REAR)
    sup = Supervisor(port, clock)
    v = sup.command(command)
    assert v.refused and v.reason is reason and port.sent == []
