"""The supervisor's checks: each limit and invariant once refusing, once passing."""

from __future__ import annotations

import math
from typing import Any

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import CommandRefused, EStopLatched
from pirate_bt.robot import ControlMode, Half, MotorCommand, load_robot
from pirate_bt.robot.description import RobotDescription, SensorKind
from pirate_bt.safety import (
    Bend,
    Clamp,
    ClampState,
    Drive,
    MoveFrontClear,
    Outcome,
    Raw,
    Reason,
    Rotate,
    Source,
    Stop,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


@pytest.fixture
def robot() -> RobotDescription:
    return ROBOT


@pytest.fixture
def clock() -> SimClock:
    return SimClock(100.0)


@pytest.fixture
def port(robot: RobotDescription, clock: SimClock) -> FakePort:
    return FakePort(robot, clock)


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


def both_clamped(port: FakePort) -> None:
    port.clamp_half(Half.FRONT)
    port.clamp_half(Half.REAR)


# -- static limits -------------------------------------------------------------


def test_clamp_torque_above_limit_is_refused(sup: Supervisor, port: FakePort) -> None:
    v = sup.command(Clamp(Half.REAR, 1.0))  # limit 0.8 N*m, policy refuse
    assert v.outcome is Outcome.REFUSE and v.reason is Reason.TORQUE_LIMIT
    assert port.sent == []


def test_clamp_torque_within_limit_passes(sup: Supervisor, port: FakePort) -> None:
    v = sup.command(Clamp(Half.REAR, 0.6))
    assert v.outcome is Outcome.PASS
    assert {c.motor for c in v.sent} == {"bend_3_joint", "bend_4_joint"}
    assert all(c.mode is ControlMode.TORQUE and c.value == 0.6 for c in v.sent)
    assert list(v.sent) == port.sent


def test_clamp_torque_below_minimum_is_refused(sup: Supervisor) -> None:
    v = sup.command(Clamp(Half.REAR, 0.1))
    assert v.reason is Reason.CLAMP_TORQUE_TOO_LOW


def test_drive_speed_above_limit_is_clipped(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    both_clamped(port)
    for _ in range(5):  # ramp up within the acceleration limit
        sup.command(Drive(0.2))
        clock.advance(0.1)
    v = sup.command(Drive(0.2))
    assert v.outcome is Outcome.CLIP and v.reason is Reason.VELOCITY_LIMIT
    assert all(c.value == pytest.approx(0.1) for c in v.sent)


def test_drive_speed_within_limits_passes(sup: Supervisor, port: FakePort) -> None:
    both_clamped(port)
    v = sup.command(Drive(0.02))
    assert v.outcome is Outcome.PASS
    assert len(v.sent) == len(ROBOT.drive_motors())


def test_drive_acceleration_is_clipped_and_slowing_down_is_not(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    both_clamped(port)
    v = sup.command(Drive(0.08))  # 0.08 m/s in one 0.1 s step > 0.4 m/s^2
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ACCELERATION_LIMIT
    assert v.sent[0].value == pytest.approx(0.04)
    clock.advance(0.01)
    assert sup.command(Drive(0.0)).outcome is Outcome.PASS


def test_angle_limit_refuse_policy(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    v = sup.command(Rotate(math.radians(179)))  # rotate: refuse beyond 175 deg
    assert v.reason is Reason.ANGLE_LIMIT and v.refused


def test_angle_limit_clip_policy(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    v = sup.command(Tilt(math.radians(120)))  # tilt: clip at 100 deg
    assert v.outcome is Outcome.CLIP
    assert Reason.ANGLE_LIMIT in v.clips


def test_angular_rate_is_clipped(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    v = sup.command(Rotate(1.0))  # 60 deg/s over 0.1 s = 0.105 rad
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ANGULAR_RATE_LIMIT
    assert v.sent[0].value == pytest.approx(math.radians(6))


def test_small_rotation_passes(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    v = sup.command(Rotate(0.05))
    assert v.outcome is Outcome.PASS


def test_not_finite_and_unknown_targets_are_refused(sup: Supervisor, port: FakePort) -> None:
    both_clamped(port)
    assert sup.command(Drive(math.nan)).reason is Reason.NOT_FINITE
    assert sup.command(Bend("front", 0.1)).reason is Reason.UNKNOWN_TARGET
    assert sup.command(Raw(MotorCommand("nope", ControlMode.PWM, 0))).reason is (
        Reason.UNKNOWN_TARGET
    )
    pwm = Raw(MotorCommand("bend_1_drive", ControlMode.PWM, 0.5))
    assert sup.command(pwm).reason is Reason.MODE_NOT_ALLOWED


def test_raw_commands_are_checked_like_the_others(sup: Supervisor, port: FakePort) -> None:
    sup.set_mode(sup.mode.MANUAL)
    over = Raw(MotorCommand("bend_1_joint", ControlMode.TORQUE, 0.9))
    assert sup.command(over, source=Source.OPERATOR).reason is Reason.TORQUE_LIMIT
    leds = Raw(MotorCommand("front_leds", ControlMode.PWM, 0.5))
    assert sup.command(leds, source=Source.OPERATOR).outcome is Outcome.PASS


# -- state invariants --------------------------------------------------------------


def test_unclamp_refused_when_other_half_is_free(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.FRONT)
    v = sup.command(Unclamp(Half.FRONT))
    assert v.reason is Reason.OTHER_HALF_NOT_CLAMPED


def test_unclamp_passes_when_other_half_is_clamped(sup: Supervisor, port: FakePort) -> None:
    both_clamped(port)
    v = sup.command(Unclamp(Half.FRONT))
    assert v.ok
    assert all(c.mode is ControlMode.POSITION for c in v.sent)


def test_bend_refused_when_other_half_is_free(sup: Supervisor, port: FakePort) -> None:
    v = sup.command(Bend("bend_1", 0.05))
    assert v.reason is Reason.OTHER_HALF_NOT_CLAMPED


def test_bend_passes_when_other_half_is_clamped(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    assert sup.command(Bend("bend_1", 0.05)).outcome is Outcome.PASS


def test_rotate_refused_with_both_halves_clamped(sup: Supervisor, port: FakePort) -> None:
    both_clamped(port)
    assert sup.command(Rotate(0.05)).reason is Reason.ROTATE_NEEDS_ONE_CLAMPED


def test_rotate_refused_with_no_half_clamped(sup: Supervisor) -> None:
    assert sup.command(Rotate(0.05)).reason is Reason.ROTATE_NEEDS_ONE_CLAMPED


def test_rotate_passes_with_exactly_one_half_clamped(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.FRONT)
    assert sup.command(Rotate(-0.05)).outcome is Outcome.PASS


def test_drive_refused_while_a_half_is_between(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    port.half_between(Half.FRONT)
    assert sup.command(Drive(0.02)).reason is Reason.HALF_TRANSITIONING


def test_drive_refused_while_a_commanded_clamp_has_not_closed(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.REAR)
    assert sup.command(Clamp(Half.FRONT, 0.5)).ok  # the fake state does not move
    assert sup.command(Drive(0.02)).reason is Reason.HALF_TRANSITIONING


def test_drive_passes_with_one_half_clamped_and_one_free(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    port.free_half(Half.FRONT, 0.5)  # steered, not pressing
    assert sup.command(Drive(0.02)).outcome is Outcome.PASS


def test_front_clamp_refused_until_front_module_is_clear(sup: Supervisor, port: FakePort) -> None:
    port.set_tilt(0.0)
    v = sup.command(Clamp(Half.FRONT, 0.5))
    assert v.reason is Reason.FRONT_NOT_CLEAR


def test_front_clamp_passes_with_front_module_clear(sup: Supervisor, port: FakePort) -> None:
    port.set_tilt(-ROBOT.clamp.front_clear_angle)
    assert sup.command(Clamp(Half.FRONT, 0.5)).outcome is Outcome.PASS


def test_front_module_may_not_swing_back_onto_a_clamped_front_half(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.FRONT)
    assert sup.command(Tilt(0.0)).reason is Reason.FRONT_NOT_CLEAR
    port.free_half(Half.FRONT)
    port.clamp_half(Half.REAR)
    assert sup.command(Tilt(ROBOT.clamp.front_clear_angle - 0.05)).ok
    assert sup.command(MoveFrontClear()).ok


def test_steep_pipe_refuses_releasing_the_last_clamp(sup: Supervisor, port: FakePort) -> None:
    port.set_pitch(math.radians(20))
    port.clamp_half(Half.FRONT)
    v = sup.command(Unclamp(Half.FRONT))
    assert v.reason is Reason.STEEP_PIPE_UNCLAMPED


def test_steep_pipe_refuses_motion_with_no_half_clamped(sup: Supervisor, port: FakePort) -> None:
    port.set_pitch(math.radians(-20))
    assert sup.command(Drive(0.02)).reason is Reason.STEEP_PIPE_UNCLAMPED
    assert sup.command(Clamp(Half.REAR, 0.5)).ok  # clamping is the way out


def test_steep_pipe_passes_with_the_other_half_holding(sup: Supervisor, port: FakePort) -> None:
    port.set_pitch(math.radians(20))
    both_clamped(port)
    assert sup.command(Unclamp(Half.FRONT)).ok


def test_level_pipe_allows_drive_with_no_half_clamped(sup: Supervisor) -> None:
    assert sup.command(Drive(0.02)).ok  # wheels may slip; nothing is damaged


# -- freshness and link ---------------------------------------------------------------


def test_stale_joint_reading_refuses(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    both_clamped(port)
    port.freeze("bend_2_angle")
    clock.advance(0.2)  # 10 x 10 ms period = 0.1 s allowed
    v = sup.command(Unclamp(Half.FRONT))
    assert v.reason is Reason.STALE_STATE and "bend_2_angle" in v.detail


def test_fresh_readings_pass(sup: Supervisor, port: FakePort, clock: SimClock) -> None:
    both_clamped(port)
    port.freeze("bend_2_angle")
    clock.advance(0.05)
    assert sup.command(Unclamp(Half.FRONT)).ok


def test_link_down_refuses(sup: Supervisor, port: FakePort) -> None:
    port.connected = False
    assert sup.command(Drive(0.01)).reason is Reason.LINK_DOWN


def test_silent_link_refuses_and_a_talking_one_passes(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    port.last_heard_s = clock.now()
    clock.advance(0.3)
    assert sup.command(Drive(0.01)).ok
    clock.advance(0.3)
    assert sup.command(Drive(0.01)).reason is Reason.LINK_SILENT


def test_send_failure_refuses_and_enters_safe_state(sup: Supervisor, port: FakePort) -> None:
    port.fail_send = True
    v = sup.command(Drive(0.01))
    assert v.reason is Reason.LINK_ERROR
    assert sup.in_safe_state


# -- how refusals surface ------------------------------------------------------------------


def test_require_raises_command_refused(sup: Supervisor) -> None:
    with pytest.raises(CommandRefused) as info:
        sup.require(Rotate(0.05))
    assert info.value.reason == "rotate_needs_one_clamped"


def test_require_raises_estop_latched(sup: Supervisor) -> None:
    sup.estop("test")
    with pytest.raises(EStopLatched):
        sup.require(Drive(0.01))


def test_check_is_a_dry_run(sup: Supervisor, port: FakePort) -> None:
    v = sup.check(Clamp(Half.REAR, 0.5))
    assert v.ok and v.sent and port.sent == [] and len(sup.verdicts) == 0


def test_stop_always_passes(sup: Supervisor, port: FakePort) -> None:
    port.connected = True
    port.set_pitch(1.0)
    port.freeze(*port.builder.channel_names)
    sup.set_mode(sup.mode.MANUAL)
    v = sup.command(Stop())
    assert v.outcome is Outcome.PASS
    assert all(c.value == 0.0 and c.mode is ControlMode.VELOCITY for c in v.sent)


def test_every_verdict_is_kept_with_tick_and_sequence(sup: Supervisor, port: FakePort) -> None:
    seen = []
    sup.add_listener(seen.append)
    sup.tick()
    sup.command(Clamp(Half.REAR, 0.5))
    sup.tick()
    sup.command(Rotate(0.05))
    assert [v.seq for v in seen] == [1, 2]
    assert [v.tick for v in sup.verdicts_since(2)] == [2]
    record = seen[1].to_record()
    assert record["outcome"] == "refuse" and record["reason"] == "rotate_needs_one_clamped"
    assert sup.verdicts.since(seq=1) == [seen[1]]


def test_front_module_may_not_swing_through_the_clamp_zone(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.FRONT)  # tilt starts at +clear
    assert sup.command(Tilt(-2.0)).reason is Reason.FRONT_NOT_CLEAR  # found by the property test
    assert sup.command(Tilt(1.5)).ok  # further out on the same side


# -- found by the simulator-backed property test and by its review ----------------


def _front_joint() -> str:
    return ROBOT.joint_motor(ROBOT.bend_modules(Half.FRONT)[0].name).name


@pytest.mark.parametrize("torque_nm", [0.2, -0.5])
def test_any_torque_on_a_front_joint_needs_the_front_module_clear(
    sup: Supervisor, port: FakePort, torque_nm: float
) -> None:
    # A torque-mode joint swings until the wall stops it and then presses, whatever the
    # size or sign of the torque: the front module must be clear first.
    port.clamp_half(Half.REAR)
    port.set_tilt(0.0)
    raw = Raw(MotorCommand(_front_joint(), ControlMode.TORQUE, torque_nm))
    assert sup.command(raw).reason is Reason.FRONT_NOT_CLEAR
    port.set_tilt(ROBOT.clamp.front_clear_angle)
    assert sup.command(raw).ok


def test_a_front_bend_to_the_wall_needs_the_front_module_clear(
    sup: Supervisor, port: FakePort
) -> None:
    port.clamp_half(Half.REAR)
    port.set_tilt(0.0)
    front = ROBOT.bend_modules(Half.FRONT)[0].name
    wall = min(p.angle for p in ROBOT.clamp.contact_angles)
    assert sup.check(Bend(front, wall)).reason is Reason.FRONT_NOT_CLEAR
    assert sup.check(Unclamp(Half.FRONT, -wall)).reason is Reason.FRONT_NOT_CLEAR
    assert sup.check(Bend(front, 0.6)).ok  # steering stays far from the wall


def test_a_torque_against_the_clamped_side_is_a_release(sup: Supervisor, port: FakePort) -> None:
    # The joint swings off the wall on its way to the other side: with nothing else
    # holding in a steep pipe the robot would fall.
    port.set_pitch(math.radians(90))
    port.clamp_half(Half.REAR)  # joints at +contact angle
    rear = ROBOT.joint_motor(ROBOT.bend_modules(Half.REAR)[0].name).name
    flip = Raw(MotorCommand(rear, ControlMode.TORQUE, -0.5))
    assert sup.check(flip).reason is Reason.STEEP_PIPE_UNCLAMPED
    assert sup.check(Raw(MotorCommand(rear, ControlMode.TORQUE, 0.5))).ok  # same side


def test_joints_at_the_wall_on_opposite_sides_do_not_clamp(sup: Supervisor, port: FakePort) -> None:
    port.clamp_half(Half.REAR)
    first, _ = (m.name for m in ROBOT.bend_modules(Half.REAR))
    port.set(**{ROBOT.sensor_of(first, SensorKind.ANGLE).name: -1.45})
    assert sup.half_states()[Half.REAR] is not ClampState.CLAMPED
    # the simulator would spin the robot: no half really holds
    assert sup.check(Rotate(0.1)).reason is Reason.ROTATE_NEEDS_ONE_CLAMPED


def test_a_clamp_that_swings_steered_joints_across_ends_clamped(
    sup: Supervisor, port: FakePort
) -> None:
    """Regression: a half steered one way (-40 deg for a down bend) and then clamped with
    a positive torque swings across, so the clamp is checked as a release on the way;
    once the sensors say clamped, the half is clamped - not 'transitioning' for ever,
    which refused every later release of the other half in the down bend."""
    port.clamp_half(Half.REAR)
    port.free_half(Half.FRONT, angle_rad=-0.7)
    port.set_pitch(math.radians(-24))  # down the bend: steep
    verdict = sup.clamp(Half.FRONT, 0.7)
    assert verdict.ok
    port.clamp_half(Half.FRONT, 0.7)
    assert sup.half_states()[Half.FRONT] is ClampState.CLAMPED
    assert sup.unclamp(Half.REAR).ok


def test_a_stop_goes_out_though_the_link_reports_an_earlier_failure_first(
    port: FakePort, clock: SimClock
) -> None:
    """The link raises for an earlier request's failure before it sends, so the stop
    of a robot whose drives are all on one board never went out (the board-by-board
    fallback needs two boards); the supervisor now asks again at once."""
    from pirate_bt.errors import LinkError

    class EarlierFailure(FakePort):
        pending = 1

        def send(self, commands: Any) -> None:
            if self.pending:
                self.pending -= 1
                raise LinkError("1 earlier request(s) failed; last: BulkSetpoints refused")
            super().send(commands)

    link = EarlierFailure(ROBOT, clock)
    sup = Supervisor(link, clock)
    sup.safe_state("test")
    drives = {m.name for m in ROBOT.drive_motors()}
    assert link.batches and {c.motor for c in link.batches[-1]} == drives
    assert all(c.value == 0.0 for c in link.batches[-1])
