"""A board the bridge reports in ``TIMEOUT``: a command for it waits for its return while
its readings are fresh, and is refused once they are all stale (pirate_bt/link/away.py).

The link refused a command for such a board at once. The bridge marks a board
``TIMEOUT`` after one missed exchange and its retry, so one lost reply on the RS485 bus
ended a run whose tree happened to send to that board in the next state period (exit
3, *link error while sending*), and a board that stayed away ended a run with exit 3 or
1 (*stale data*) depending on whether the tree sent to it before its readings went
stale.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkError
from pirate_bt.link import RobotLink, wrap_link
from pirate_bt.link.codec import BulkSetpoints, FrameCodec, FrameDecoder
from pirate_bt.link.testing import MemoryLink, memory_pair
from pirate_bt.pipes.model import FaultSpec
from pirate_bt.robot import ControlMode, MotorCommand, load_robot
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
SLOT = {s.motor.name: s.index for s in ROBOT.setpoint_slots()}
STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"


class Tap:
    """The bridge's end of the line, recording the host's bulks."""

    def __init__(self, port: MemoryLink) -> None:
        self.port = port
        self.bulks: list[BulkSetpoints] = []
        self._decoder = FrameDecoder(CODEC)

    def read_available(self) -> bytes:
        data = self.port.read_available()
        self.bulks += [m for m in self._decoder.feed(data) if isinstance(m, BulkSetpoints)]
        return data

    def write(self, data: bytes) -> None:
        self.port.write(data)


def connect() -> tuple[RobotLink, Tap, BridgeOnPort, SimClock]:
    clock = SimClock()
    host, far = memory_pair()
    tap = Tap(far)
    bridge = BridgeOnPort(tap, bridge_for(ROBOT))
    clock.add_listener(bridge.step)
    return wrap_link(host, ROBOT, clock), tap, bridge, clock


def away(bridge: BridgeOnPort, clock: SimClock, seconds: float) -> None:
    """Board 22 misses its polls for ``seconds`` from now (a lost reply, a reboot)."""
    fault = FaultSpec(kind="board_reset", target="22", at=clock.now(), duration=seconds)
    bridge.bridge.schedule([fault])


def run(link: RobotLink, clock: SimClock, seconds: float) -> None:
    """Polls and reads the state every 5 ms, as a supervisor's ticks do."""
    for _ in range(round(seconds / 0.005)):
        clock.advance(0.005)
        link.poll()
        link.state()


def until_away(link: RobotLink, clock: SimClock) -> None:
    """Run until the newest STATE reports board 22 in TIMEOUT."""
    for _ in range(10):
        run(link, clock, 0.005)
        if link.session.boards_away():
            return
    raise AssertionError("board 22 never reported in TIMEOUT")


def drive(value: float) -> list[MotorCommand]:
    return [MotorCommand("bend_1_drive", ControlMode.VELOCITY, value)]  # board 22


def test_a_command_for_a_board_missing_one_poll_goes_out_when_it_is_back() -> None:
    link, tap, bridge, clock = connect()
    link.send_and_wait(drive(0.05))
    run(link, clock, 0.05)
    away(bridge, clock, 0.015)  # one STATE in TIMEOUT: one lost reply and its retry
    until_away(link, clock)
    link.send(drive(0.02))  # was LinkError: board 22 is not answering the bridge
    clock.advance(0.001)  # the bridge reads it
    assert tap.bulks[-1].modes[SLOT["bend_1_drive"]] is None  # keep, while it is away
    run(link, clock, 0.05)
    last = tap.bulks[-1]
    assert last.modes[SLOT["bend_1_drive"]] is ControlMode.VELOCITY
    assert last.raw_values[SLOT["bend_1_drive"]] == link._commands.to_raw(drive(0.02)[0]).raw_value
    setpoint = bridge.bridge.model.setpoint("bend_1_drive")
    assert setpoint is not None and setpoint.value == pytest.approx(0.02, abs=1e-3)
    assert link.session.take_failures() == []


def test_send_and_wait_waits_for_the_board_to_come_back() -> None:
    link, _tap, bridge, clock = connect()
    run(link, clock, 0.05)
    away(bridge, clock, 0.04)
    until_away(link, clock)
    link.send_and_wait(drive(0.03))
    setpoint = bridge.bridge.model.setpoint("bend_1_drive")
    assert setpoint is not None and setpoint.value == pytest.approx(0.03, abs=1e-3)


def test_a_board_away_with_every_reading_stale_is_refused() -> None:
    link, _tap, bridge, clock = connect()
    run(link, clock, 0.05)
    away(bridge, clock, 1.0)
    run(link, clock, 0.05)
    with pytest.raises(LinkError, match=r"board 22 is not answering .* were not delivered"):
        link.send_and_wait(drive(0.03))  # waited for its return, not for ever
    assert clock.now() < 0.25
    run(link, clock, 0.05)
    with pytest.raises(LinkError, match=r"board 22 is not answering the bridge \(TIMEOUT"):
        link.send(drive(0.03))
    link.send([MotorCommand("bend_2_drive", ControlMode.VELOCITY, 0.0)])  # others go on


def _first_send_to_board_22_after(start_s: float) -> float:
    with pirate_bt.connect("straight") as robot:
        robot.run(STRAIGHT, params={"distance": "1 m"})
        return min(
            v.stamp_s
            for v in robot.supervisor.verdicts
            if v.sent and v.stamp_s > start_s and any(c.motor == "bend_1_drive" for c in v.sent)
        )


def test_the_exit_of_a_board_reset_does_not_depend_on_when_the_tree_sends() -> None:
    sent_s = _first_send_to_board_22_after(1.0)
    # the board goes away 15 ms before the tree's next command for it (exit 3 before),
    # and 55 ms before (its readings stale by then: exit 1)
    for before in (0.015, 0.055):
        faults = f"board_reset:22@{sent_s - before:.3f}s"
        result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"}, faults=faults)
        assert (result.exit_code, result.why[:20]) == (1, "stale data: bend_1_a"), result.why
    # and one lost reply there ends nothing (exit 3 before)
    faults = f"board_reset:22@{sent_s - 0.015:.3f}s+0.01s"
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"}, faults=faults)
    assert result.exit_code == 0, result.why
