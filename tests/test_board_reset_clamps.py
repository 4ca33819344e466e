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


@pytest.mark.parametrize("second", ["board_reset:22@2.2s+0.5s", "board_reset:22@2s+0.5s"])
def test_two_overlapping_resets_of_one_board_give_the_clamp_back_after_the_last(
    second: str,
) -> None:
    # The second reset's start held the board's setpoints again while its motors were
    # already off (nothing), and the first reset's end brought the board back while the
    # second still ran: the clamp never came back (a robot in a riser slid 0.62 m).
    clock = SimClock()
    faults = ["board_reset:22@2s+0.5s", second]
    with Simulator("straight", ROBOT, clock=clock, faults=faults) as sim:
        clamp = [MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.7) for i in (1, 2)]
        for command in clamp:
            sim.model.command(command)
        clock.advance(2.6)  # the first reset is over; the second (if later) is not
        if second.startswith("board_reset:22@2.2s"):
            assert sim.model.setpoint("bend_1_joint") is None  # still rebooting
        clock.advance(0.5)  # both are over
        assert sim.model.setpoint("bend_1_joint") == clamp[0]
        assert sim.truth().halves[Half.FRONT].clamped
        ends = [e.detail for e in sim.events() if e.detail == "end board_reset 22"]
        assert len(ends) == 2


def test_a_stall_overlapped_by_another_of_the_same_motor_lasts_until_the_last_ends() -> None:
    # the first stall's end freed the wheel while the second still ran
    clock = SimClock()
    stalls = ["motor_stall:bend_1_drive@1s+1s", "motor_stall:bend_1_drive@1.5s+1s"]
    with Simulator("straight", ROBOT, clock=clock, faults=stalls) as sim:
        for i in (1, 2, 3, 4):
            sim.model.command(MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.7))
        clock.advance(0.5)
        sim.model.command(MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.02))
        clock.advance(1.7)  # 2.2 s: the first stall is over, the second goes on
        assert sim.model.readings()["bend_1_drive.velocity"] == 0.0
        clock.advance(0.5)  # 2.7 s: both are over
        assert sim.model.readings()["bend_1_drive.velocity"] > 0.01


def test_a_link_loss_overlapped_by_another_sends_nothing_until_the_last_ends() -> None:
    clock = SimClock()
    with Simulator(
        "straight", ROBOT, clock=clock, faults=["link_loss@1s+1s", "link_loss@1.5s+1s"]
    ) as sim:
        clock.advance(2.1)
        sent = sim.bridge.state_frames_sent
        clock.advance(0.3)  # 2.4 s: the first loss is over, the second goes on
        assert sim.bridge.state_frames_sent == sent
        clock.advance(0.3)  # 2.7 s: both are over
        assert sim.bridge.state_frames_sent > sent
