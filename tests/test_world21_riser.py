"""Vertical pipes and faults in them: what the run says and where it leaves the robot
(world probe of the twenty-first session)."""

from __future__ import annotations

import math

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Supervisor
from pirate_bt.safety.supervisor_hold import why_half_holds_nothing
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


def test_a_stalled_joint_of_the_holding_half_in_a_riser_is_not_said_to_be_over_an_opening() -> None:
    # up riser.yaml's foot bend: the front half alone holds in the riser while the rear
    # comes through, and bend_1's motor stalls at the wall: the front lets go. There is
    # no tee anywhere in this riser
    result = pirate_bt.simulate_mission("riser", faults="motor_stall:bend_1_joint@20s+2s")
    assert result.status == "failure" and result.safe_state
    assert result.why.startswith("steep_pipe_unclamped: no half holds the robot"), result.why
    # was: 'front bend_1 off the wall at 83.1° with its spring at 0.0 N, over an opening'
    assert "over an opening" not in result.why, result.why
    assert "front bend_1 presses 0.0 N at 83.1°, stopped at the wall (a stalled joint motor?)" in (
        result.why
    )
    assert result.counters.damage == 0


def test_a_joint_swung_past_its_partner_is_still_over_an_opening() -> None:
    clock = SimClock(10.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR, 0.7)
    port.free_half(Half.FRONT, math.radians(40))
    port.set_pitch(math.radians(90))
    sup = Supervisor(port, clock)
    sup.tick()
    wall = ROBOT.clamp.contact_angle(0.063)
    # the rear's first joint swings on past the wall (one 10 ms state at 90°/s)
    port.set(bend_3_angle=wall + math.radians(0.8), bend_3_spring=0.0)
    clock.advance(0.05)
    sup.tick()
    why = sup.safe_state_reason
    assert why is not None
    assert why.endswith(
        "rear bend_3 off the wall at 83.9° with its spring at 0.0 N, over an opening"
    )
    state = port.state()
    assert state is not None
    # the same joint stopped at its partner's angle, pressing nothing: stalled
    port.set(bend_3_angle=wall, bend_3_spring=0.0)
    clock.advance(0.05)
    state = port.state()
    assert state is not None
    from pirate_bt.safety.checks import half_states

    kind = half_states(ROBOT, state, {})[Half.REAR]
    said = why_half_holds_nothing(ROBOT, state, Half.REAR, kind)
    assert (
        said == "rear bend_3 presses 0.0 N at 83.1°, stopped at the wall (a stalled joint motor?)"
    )


def test_a_joint_stalled_while_its_half_is_steered_is_let_go_before_it_over_torques() -> None:
    # the bend PAB steers the rear half through the bend (position setpoints) while
    # bend_3's motor is stalled: its position loop saturates at the stall torque
    result = pirate_bt.simulate_mission("bend-right", faults="motor_stall:bend_3_joint@32s+2s")
    # was: 'mission completed: 4 PABs, ...; but the simulator counted 1 damage
    # (over_torque:bend_3_joint)', exit 0
    assert result.status == "failure" and result.safe_state
    assert result.counters.damage == 0, result.counters.damage_kinds
    assert result.why.startswith(
        "joint_stalled: bend_3_joint does not move toward its setpoint: at 21.6°, asked 36.0°,"
    ), result.why
    assert result.why.endswith("(a stalled joint motor?): the supervisor lets it go")
    failed = [p for p in result.pabs if p.outcome == "failure"]
    assert failed and failed[0].kind == "bend", [(p.kind, p.outcome) for p in result.pabs]


def _steered() -> tuple[FakePort, Supervisor, SimClock]:
    """The front half clamped, the rear free, and bend_3 sent 4° from where it reads
    (in position mode, as a PAB steers a half)."""
    from pirate_bt.safety.commands import Bend

    clock = SimClock(10.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.FRONT, 0.7)
    port.free_half(Half.REAR, 0.0)
    sup = Supervisor(port, clock)
    sup.tick()
    assert sup.command(Bend("bend_3", math.radians(4))).ok
    return port, sup, clock


def test_a_joint_still_short_of_its_setpoint_is_let_go() -> None:
    from pirate_bt.robot.description import ControlMode

    port, sup, clock = _steered()
    for _ in range(2):
        clock.advance(0.05)
        sup.tick()
        assert not sup.in_safe_state  # still for less than 0.1 s
    clock.advance(0.05)
    sup.tick()
    assert sup.safe_state_reason == (
        "joint_stalled: bend_3_joint does not move toward its setpoint: at 0.0°, asked 4.0°,"
        " for 0.10 s (a stalled joint motor?): the supervisor lets it go"
    )
    assert port.setpoints["bend_3_joint"] == (ControlMode.TORQUE, 0.0)


def test_a_joint_that_follows_or_presses_the_wall_is_not_taken_for_stalled() -> None:
    port, sup, clock = _steered()
    for angle in (1.0, 2.0, 3.0):  # it follows
        port.set(bend_3_angle=math.radians(angle))
        clock.advance(0.05)
        sup.tick()
    # the wall stops it short of its setpoint: it presses the wall
    port.set(bend_3_spring=10.0)
    for _ in range(6):
        clock.advance(0.05)
        sup.tick()
    # within the angle tolerance of its setpoint, pressing nothing
    port.set(bend_3_angle=math.radians(3.0), bend_3_spring=0.0)
    for _ in range(6):
        clock.advance(0.05)
        sup.tick()
    assert not sup.in_safe_state, sup.safe_state_reason
