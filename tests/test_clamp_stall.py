"""A timed ``motor_stall`` of a clamping (bend) joint.

A bend joint that stalls stops pressing its wheels on the wall, so its half lets go.
When the stall ends the motor follows its latest setpoint again, as a real motor
does, and the half clamps again if it is still commanded to. The simulator used to
leave it limp for good: the joint had settled before the stall and, with nothing of
its setpoint changed since, was never stepped again.
"""

from __future__ import annotations

from pathlib import Path

from pirate_bt import simulate_mission
from pirate_bt.clock import SimClock
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half
from pirate_bt.sim import Simulator

ROBOT = load_robot()
LAB = Path(__file__).resolve().parent.parent / "scenarios" / "lab.route"


def _clamp_both(sim: Simulator) -> None:
    for i in (1, 2, 3, 4):
        sim.model.command(MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.7))


def test_the_clamp_comes_back_when_the_stall_ends() -> None:
    clock = SimClock()
    with Simulator(
        "straight", ROBOT, clock=clock, faults=["motor_stall:bend_3_joint@2s+1s"]
    ) as sim:
        _clamp_both(sim)
        clock.advance(1.9)
        assert sim.truth().halves[Half.REAR].clamped
        clock.advance(0.3)  # 0.2 s into the stall: the joint presses on nothing
        assert not sim.truth().halves[Half.REAR].clamped
        assert sim.truth().halves[Half.FRONT].clamped  # the other half is not touched
        clock.advance(1.0)  # the stall is over: the joint follows its setpoint again
        assert sim.truth().halves[Half.REAR].clamped
        assert sim.truth().halves[Half.REAR].normal_force_n > 0


def test_a_setpoint_given_during_the_stall_is_followed_when_it_ends() -> None:
    clock = SimClock()
    with Simulator(
        "straight", ROBOT, clock=clock, faults=["motor_stall:bend_4_joint@1s+1s"]
    ) as sim:
        clock.advance(1.2)  # stalled from the start: the rear half has never clamped
        for i in (3, 4):
            sim.model.command(MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.7))
        clock.advance(0.5)
        assert not sim.truth().halves[Half.REAR].clamped
        clock.advance(2.0)
        assert sim.truth().halves[Half.REAR].clamped


def test_a_mission_goes_on_after_a_short_stall_of_a_clamp_joint() -> None:
    # bend_1's joint stalls for 1 s while the first straight drives: the front half
    # let go for good, so the next PAB's clamp timed out and the mission failed at 87 s
    mission = simulate_mission(LAB, faults="motor_stall:bend_1_joint@20s+1s")
    assert mission.succeeded, mission.why
