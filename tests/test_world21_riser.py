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
