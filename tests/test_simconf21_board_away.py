"""The simulated bridge and a PICO board it does not hear for 100 ms, as the firmware is.

docs/board-bus.md: the bridge takes a board it has had no good reply from for more than
100 ms (``BOARD_AWAY_MS`` in firmware/piratebay/poller.c) as stopped on its own, as on its
``OWN_STOP``: the stop category to the whole robot, once an absence, so a board that
answers again gets the stop setpoints (its drive braked, its clamp back), never the ones
it had. The simulated bridge's ``board_reset`` (1.5 s) kept the rest of the robot driving
and handed the board its old drive setpoint back at its end.

The bridge in process, in virtual time; what each motor is told is read off the model.
"""

from __future__ import annotations

import pytest

from pirate_bt.link import (
    BoardStatus,
    BulkSetpoints,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    State,
)
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import CommandCodec, MotorCommand
from pirate_bt.robot.description import ControlMode, MotorFunction
from pirate_bt.sim.bridge import SimBridge
from pirate_bt.sim.bridge_port import bridge_for

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
COMMANDS = CommandCodec(ROBOT)
SLOTS = ROBOT.setpoint_slots()
BOARDS = ROBOT.board_ids()
AWAY = 22  # bend_1: its clamp joint and a drive
SPEED = 0.05  # m/s, every drive
CLAMP = 1.2  # rad, every bend joint


class Host:
    """A host that keeps the link alive (a heartbeat every 20 ms) while time passes."""

    def __init__(self, bridge: SimBridge) -> None:
        self.bridge = bridge
        self.now_s = 0.0
        self.seq = 0
        self.decoder = FrameDecoder(CODEC)
        self.state: State | None = None

    def send(self, make: type[Hello] | type[EStopReset] | type[Heartbeat]) -> None:
        self.seq += 1
        if make is Hello:
            self.bridge.receive(CODEC.encode(Hello(self.seq, CODEC.layout.digest)))
        else:
            self.bridge.receive(CODEC.encode(make(self.seq)))

    def bulk(self, told: dict[str, MotorCommand]) -> None:
        """Every motor named in ``told`` gets its setpoint, the others keep."""
        modes: list[ControlMode | None] = []
        raws: list[int] = []
        for slot in SLOTS:
            command = told.get(slot.motor.name)
            if command is None:
                modes.append(None)
                raws.append(0)
            else:
                modes.append(command.mode)
                raws.append(COMMANDS.to_raw(command).raw_value)
        self.seq += 1
        self.bridge.receive(CODEC.encode(BulkSetpoints(self.seq, tuple(modes), tuple(raws))))

    def wait(self, seconds: float) -> None:
        for _ in range(round(seconds / 0.02)):
            self.send(Heartbeat)
            self.now_s += 0.02
            self.bridge.advance_to(self.now_s)
            for item in self.decoder.feed(self.bridge.read()):
                if isinstance(item, State):
                    self.state = item


def motors(function: MotorFunction, *, but: int | None = None) -> list[str]:
    return [s.motor.name for s in SLOTS if s.motor.function is function and s.board != but]


def told(bridge: SimBridge, names: list[str]) -> dict[str, MotorCommand | None]:
    return {name: bridge.model.setpoint(name) for name in names}


def driving(speed: float, *, but: int | None = None) -> dict[str, MotorCommand]:
    return {
        name: MotorCommand(name, ControlMode.VELOCITY, speed)
        for name in motors(MotorFunction.DRIVE, but=but)
    }


@pytest.fixture
def host() -> Host:
    """A session, released, every clamp joint at CLAMP and every drive at SPEED."""
    host = Host(bridge_for(ROBOT))
    host.send(Hello)
    host.send(EStopReset)
    clamps = {
        name: MotorCommand(name, ControlMode.POSITION, CLAMP) for name in motors(MotorFunction.BEND)
    }
    host.bulk({**clamps, **driving(SPEED)})
    host.wait(0.1)
    drives = motors(MotorFunction.DRIVE)
    assert told(host.bridge, drives) == {name: velocity(name, SPEED) for name in drives}
    return host


def reset_board(host: Host, board: int, seconds: float) -> None:
    host.bridge.schedule(
        [FaultSpec(kind="board_reset", target=str(board), at=host.now_s, duration=seconds)]
    )


def velocity(name: str, value: float) -> MotorCommand:
    return MotorCommand(name, ControlMode.VELOCITY, value)


def test_a_board_away_past_100_ms_stops_the_robot_and_keeps_the_clamps(host: Host) -> None:
    bends = told(host.bridge, motors(MotorFunction.BEND))
    others = motors(MotorFunction.DRIVE, but=AWAY)
    reset_board(host, AWAY, 1.5)
    host.wait(0.2)
    assert told(host.bridge, others) == {name: velocity(name, 0.0) for name in others}
    assert told(host.bridge, motors(MotorFunction.BEND, but=AWAY)) == {
        name: command for name, command in bends.items() if not name.startswith("bend_1")
    }
    assert host.state is not None
    assert all(status & BoardStatus.MOTORS_OFF for status in host.state.board_status)
    # once an absence: the host drives the others again (the board away keeps), and
    # nothing stops them a second time while it stays away
    host.bulk(driving(SPEED, but=AWAY))
    host.wait(0.5)
    assert told(host.bridge, others) == {name: velocity(name, SPEED) for name in others}


def test_a_board_back_after_its_absence_gets_the_stop_not_its_old_drive(host: Host) -> None:
    clamp = host.bridge.model.setpoint("bend_1_joint")
    reset_board(host, AWAY, 1.5)
    host.wait(0.2)
    host.bulk(driving(SPEED, but=AWAY))  # the host drives the others on
    host.wait(1.5)  # the board answers again
    assert host.bridge.model.setpoint("bend_1_drive") == velocity("bend_1_drive", 0.0)
    assert host.bridge.model.setpoint("bend_1_joint") == clamp  # its clamp comes back
    assert host.state is not None
    index = BOARDS.index(AWAY)
    assert not host.state.board_status[index] & BoardStatus.TIMEOUT


def test_a_board_away_for_less_than_100_ms_stops_nothing(host: Host) -> None:
    reset_board(host, AWAY, 0.06)
    host.wait(0.5)
    drives = motors(MotorFunction.DRIVE)
    assert told(host.bridge, drives) == {name: velocity(name, SPEED) for name in drives}


def test_a_stop_while_a_board_reboots_leaves_its_motors_off_until_it_answers(
    host: Host,
) -> None:
    reset_board(host, AWAY, 1.5)
    host.wait(0.4)  # the robot stopped for it
    assert host.bridge.model.setpoint("bend_1_drive") is None  # rebooting: off
    assert host.bridge.model.setpoint("bend_1_joint") is None
