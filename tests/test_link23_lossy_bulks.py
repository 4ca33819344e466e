"""A setpoint table lost on every try on a lossy line goes again (session 23).

A ``BULK_SETPOINTS`` carries the whole table of absolute setpoints, so one unanswered
on all of its tries can be sent again with a new seq: the run goes on. Before, the next
send raised *... BulkSetpoints seq N not acknowledged after 4 tries, though the bridge's
STATE frames still arrive (does it hear the host?)* and the run stopped (the T-joint PAB
at drop 20 %, corrupt 5 %, dup 5 %, seed 17). A bridge that never takes a bulk is still
reported, after a bounded number of tables sent again.
"""

from __future__ import annotations

import math

import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkError
from pirate_bt.link import FrameCodec, RobotLink, wrap_link
from pirate_bt.link.codec import BulkSetpoints, FrameDecoder, Heartbeat
from pirate_bt.link.resend import MAX_BULK_RESENDS
from pirate_bt.link.testing import MemoryLink, memory_pair
from pirate_bt.robot import ControlMode, MotorCommand, load_robot
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
JOINT = MotorCommand("bend_1_joint", ControlMode.POSITION, math.radians(10))


class LossyTap:
    """The bridge's end of the line: swallows the first ``lose`` BULK_SETPOINTS frames
    (every try of one bulk, say), passes everything else."""

    def __init__(self, port: MemoryLink, lose: int, heartbeats_lost_every: int = 0) -> None:
        self.port = port
        self.lose = lose
        self.every = heartbeats_lost_every  # and every n-th HEARTBEAT (0: none)
        self.heartbeats = 0
        self.blackout = False  # every frame of the host's lost
        self.lost: list[int] = []
        self.passed: list[int] = []
        self._decoder = FrameDecoder(CODEC)

    def read_available(self) -> bytes:
        out = []
        for msg in self._decoder.feed(self.port.read_available()):
            assert not isinstance(msg, Exception), msg
            if self.blackout:
                if isinstance(msg, BulkSetpoints):
                    self.lost.append(msg.seq)
                continue
            if isinstance(msg, BulkSetpoints):
                if len(self.lost) < self.lose:
                    self.lost.append(msg.seq)
                    continue
                self.passed.append(msg.seq)
            elif isinstance(msg, Heartbeat) and self.every:
                self.heartbeats += 1
                if self.heartbeats % self.every == 0:
                    continue
            out.append(CODEC.encode(msg))
        return b"".join(out)

    def write(self, data: bytes) -> None:
        self.port.write(data)


def _connect(lose: int, every: int = 0) -> tuple[RobotLink, LossyTap, SimClock]:
    clock = SimClock()
    host, far = memory_pair()
    tap = LossyTap(far, lose, every)
    bridge = BridgeOnPort(tap, bridge_for(ROBOT))
    clock.add_listener(bridge.step)
    return wrap_link(host, ROBOT, clock), tap, clock


def _run(link: RobotLink, clock: SimClock, seconds: float) -> None:
    for _ in range(round(seconds / 0.01)):
        clock.advance(0.01)
        link.poll()


def test_a_table_lost_on_every_try_goes_again_and_the_link_goes_on() -> None:
    link, tap, clock = _connect(lose=4)  # the four tries of the first bulk
    link.send([JOINT])
    _run(link, clock, 0.6)
    assert len(tap.lost) == 4 and len(set(tap.lost)) == 1  # one bulk, every try lost
    assert tap.passed and tap.passed[0] != tap.lost[0]  # the table again, a new seq
    held = link.setpoint_applied("bend_1_joint")
    assert held is not None and held.mode is ControlMode.POSITION
    assert math.degrees(held.value) == pytest.approx(10, abs=0.2)
    # was: LinkError '1 earlier request(s) failed; last: BulkSetpoints seq 2 not
    # acknowledged after 4 tries, though the bridge's STATE frames still arrive ...'
    link.send([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.0)])
    link.close()


def test_a_table_lost_while_the_bridge_s_watchdog_tripped_goes_again_once_it_hears() -> None:
    # every frame of the host lost for 0.55 s: the bulk's tries given up (238 ms), its
    # table sent again and given up too, by then with the bridge's watchdog tripped
    # (250 ms); was: the next send raised '... not acknowledged after 4 tries' (the lab
    # mission at drop 20 %, seed 0)
    link, tap, clock = _connect(lose=0)
    _run(link, clock, 0.1)
    tap.blackout = True
    link.send([JOINT])
    _run(link, clock, 0.55)
    stats = link.session.stats()
    assert stats.watchdog and stats.connected  # the bridge heard nothing: not yet again
    assert len(set(tap.lost)) == 2
    tap.blackout = False
    _run(link, clock, 0.3)
    held = link.setpoint_applied("bend_1_joint")
    assert held is not None and math.degrees(held.value) == pytest.approx(10, abs=0.2)
    link.send([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.0)])
    link.close()


def test_a_bridge_that_never_takes_a_bulk_is_still_reported() -> None:
    link, tap, clock = _connect(lose=10**6)
    link.send([JOINT])
    # reported at the poll that gives the last table up (at the next send until 2026-12-01)
    with pytest.raises(LinkError, match=r"BulkSetpoints seq \d+ not acknowledged after 4 tries"):
        _run(link, clock, 0.3 * (MAX_BULK_RESENDS + 1) + 0.1)
    assert len(set(tap.lost)) == MAX_BULK_RESENDS + 1  # the table sent again, then no more
    link.close()


def test_a_bulk_given_up_on_a_line_that_loses_heartbeats_too_names_the_loss() -> None:
    # was: '... not acknowledged after 4 tries, though the bridge's STATE frames still
    # arrive (does it hear the host?)', where the bridge answered heartbeats meanwhile
    link, _tap, clock = _connect(lose=10**6, every=2)
    link.send([JOINT])
    with pytest.raises(LinkError) as exc:
        _run(link, clock, 0.3 * (MAX_BULK_RESENDS + 1) + 0.1)
    text = str(exc.value)
    assert "not acknowledged after 4 tries: the link loses frames (meanwhile" in text, text
    assert "heartbeats went unanswered" in text and "so it hears the host" in text, text
    assert "does it hear the host?" not in text
    link.close()


def test_the_t_joint_pab_on_a_link_losing_a_quarter_of_its_frames_goes_on() -> None:
    # was: 'link error while sending: 1 earlier request(s) failed; last: BulkSetpoints
    # seq 137 not acknowledged after 4 tries, though the bridge's STATE frames still
    # arrive (does it hear the host?)', the tree idle 8 s on a rotation never applied
    result = pirate_bt.simulate_tree(
        "t-joint",
        network="t-joint",
        params={"direction": "left"},
        faults="drop=0.2,corrupt=0.05,dup=0.05",
        seed=17,
    )
    assert result.status == "success", result.why
    assert result.counters.damage == 0
