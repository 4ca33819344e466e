"""A board that comes back from a reset gets its bend setpoints from the bridge again.

The firmware bridge hands every board its setpoints at every exchange
(firmware/piratebay/poller.c), so a board that rebooted holds its clamp again as soon
as it answers. The simulated bridge switched the board's motors off and left them off
until the host commanded them again: a half left limp after every board reset.
"""

from __future__ import annotations

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half
from pirate_bt.sim import Simulator

ROBOT = load_robot()


def test_the_clamp_comes_back_when_the_board_answers_again() -> None:
    clock = SimClock()
    faults = ["board_reset:22@2s+0.5s"]  # board 22: bend_1's joint and drive
    with Simulator("straight", ROBOT, clock=clock, faults=faults) as sim:
        clamp = [MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.7) for i in (1, 2)]
        drive = MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.0)
        for command in [*clamp, drive]:
            sim.model.command(command)
        clock.advance(1.9)
        assert sim.truth().halves[Half.FRONT].clamped
        clock.advance(0.3)  # 0.2 s into the reset: the board's motors are off
        assert sim.model.setpoint("bend_1_joint") is None
        assert not sim.truth().halves[Half.FRONT].clamped
        clock.advance(1.0)  # the board answers again: the bridge's setpoint is back
        assert sim.model.setpoint("bend_1_joint") == clamp[0]
        assert sim.model.setpoint("bend_1_drive") == drive
        assert sim.truth().halves[Half.FRONT].clamped


def test_a_stop_during_the_reset_is_what_the_board_gets_for_its_drive() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, faults=["board_reset:22@1s+0.5s"]) as sim:
        clamp = MotorCommand("bend_1_joint", ControlMode.TORQUE, 0.7)
        sim.model.command(clamp)
        sim.model.command(MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.03))
        clock.advance(1.2)
        sim.bridge.set_estop_input(True)  # the bridge's stop, while the board reboots
        clock.advance(1.0)
        assert sim.model.setpoint("bend_1_drive") == MotorCommand(
            "bend_1_drive", ControlMode.VELOCITY, 0.0
        )
        assert sim.model.setpoint("bend_1_joint") == clamp  # the clamp keeps its own


def test_a_stop_reaches_the_other_boards_while_one_reboots() -> None:
    import pirate_bt
    from pirate_bt.errors import LinkError

    drives = ["bend_1_drive", "bend_2_drive", "bend_3_drive", "bend_4_drive"]
    with pirate_bt.connect("straight", faults="board_reset:22@5s") as robot:
        result = robot.run("straight", params={"distance": "1 m"})  # driving at 5 s
        assert result.why.startswith("stale data: bend_1_angle")
        sim = robot.simulator
        assert sim is not None
        robot.clock.advance(0.02)
        robot.supervisor.port.poll()
        # was 0.08 m/s on boards 23, 25 and 26 for as long as the host kept the link
        # alive: the whole stop was refused (BUS_ERROR) for board 22's entry in it
        stopped = [sim.model.setpoint(name) for name in drives[1:]]
        assert all(c is not None and c.value == 0.0 for c in stopped), stopped
        assert sim.model.setpoint("bend_1_drive") is None  # the rebooting board's: off
        with pytest.raises(LinkError, match="board 22 is not answering the bridge"):
            robot.supervisor._port.send(  # around the supervisor, on purpose
                [MotorCommand("bend_1_joint", ControlMode.TORQUE, 0.7)]
            )
