"""One meaning of "clamped": the simulator and the supervisor agree at the threshold.

The simulator holds a half when every joint presses with at least the robot
description's ``clamp.min_torque``; the supervisor reads the spring sensors
through the wire's raw encoding and must call the half clamped exactly then.
"""

from __future__ import annotations

import pytest

from pirate_bt.pipes import load_network
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, RobotDescription
from pirate_bt.robot.state import StateBuilder
from pirate_bt.safety import ClampState
from pirate_bt.safety.checks import classify_half
from pirate_bt.sim import PipeRobotModel

ROBOT = load_robot()
DT = 0.01


def _both_sides(robot: RobotDescription, torque_nm: float) -> tuple[bool, ClampState]:
    """Clamp the rear half with ``torque_nm`` in the simulator; (sim's truth, supervisor's view)."""
    model = PipeRobotModel(robot, load_network("straight"))
    for module in robot.bend_modules(Half.REAR):
        model.command(
            MotorCommand(robot.joint_motor(module.name).name, ControlMode.TORQUE, torque_nm)
        )
    for _ in range(150):
        model.step(DT)
    # Through the wire: SI -> raw integers -> SI, as the supervisor would see it.
    builder = StateBuilder(robot)
    state = builder.build(builder.encode(model.readings()), model.time_s)
    return model.truth().halves[Half.REAR].clamped, classify_half(robot, state, Half.REAR)


@pytest.mark.parametrize(
    ("factor", "clamped"),
    [(1.0, True), (1.0 - 0.01, False), (1.0 + 0.01, True), (0.9, False), (2.0, True)],
)
def test_simulator_and_supervisor_agree_around_the_threshold(factor: float, clamped: bool) -> None:
    torque = ROBOT.clamp.min_torque * factor
    sim_holds, seen = _both_sides(ROBOT, torque)
    assert sim_holds is clamped
    assert (seen is ClampState.CLAMPED) is clamped, seen
    assert ROBOT.clamp.holds(torque) is clamped


def test_the_threshold_comes_from_the_robot_description() -> None:
    # Another robot with a higher minimum torque: both sides move with it.
    data = ROBOT.model_dump()
    data["clamp"]["min_torque"] = 0.5
    other = RobotDescription.model_validate(data)
    assert other.clamp.holding_force_n == pytest.approx(0.5 / other.clamp.lever_arm)
    sim_holds, seen = _both_sides(other, 0.45)  # holds on the bundled robot, not on this one
    assert not sim_holds
    assert seen is not ClampState.CLAMPED
    assert ROBOT.clamp.holds(0.45)


def test_the_supervisor_no_longer_calls_a_weak_press_clamped() -> None:
    # 0.9 x min torque was "clamped" for the supervisor and not for the simulator.
    force = 0.9 * ROBOT.clamp.holding_force_n
    assert not ROBOT.clamp.holds_force(force)
    assert ROBOT.clamp.holds_force(ROBOT.clamp.holding_force_n)
