"""The host's setpoint table on the wire: keep entries carry 0, refused entries do not return.

Found by a bridge written from docs/protocol.md alone: ``keep`` entries of a board in
``TIMEOUT`` carried the table's raw values (``ff bc 02``), and the stop after a bulk the
bridge refused still carried the refused entry. Checked here on the host's bytes.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkError, ProtocolMismatch
from pirate_bt.link import FrameCodec, MsgType, RobotLink, wrap_link
from pirate_bt.link.codec import BulkSetpoints, FrameDecoder, Message, Nack, NackCode
from pirate_bt.link.framing import cobs_decode
from pirate_bt.link.messages import BoardStatus
from pirate_bt.link.testing import MemoryLink, memory_pair
from pirate_bt.pipes.model import FaultSpec
from pirate_bt.robot import ControlMode, MotorCommand, load_robot
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
SLOT = {s.motor.name: s.index for s in ROBOT.setpoint_slots()}
KEEP = b"\xff\x00\x00"
DRIVES = [m.name for m in ROBOT.drive_motors()]


class Tap:
    """The bridge's end of the line: records the host's frames and may refuse some itself."""

    def __init__(self, port: MemoryLink) -> None:
        self.port = port
        self.frames: list[Message] = []
        self.refuse: Callable[[Message], NackCode | None] = lambda msg: None
        self._decoder = FrameDecoder(CODEC)

    def read_available(self) -> bytes:
        passed = []
        for msg in self._decoder.feed(self.port.read_available()):
            assert not isinstance(msg, Exception), msg
            self.frames.append(msg)
            code = self.refuse(msg)
            if code is None:
                passed.append(CODEC.encode(msg))
            else:  # answered here; the bridge never sees it
                self.port.write(CODEC.encode(Nack(msg.seq, msg.TYPE, code)))
        return b"".join(passed)

    def write(self, data: bytes) -> None:
        self.port.write(data)

    def bulks(self) -> list[BulkSetpoints]:
        return [m for m in self.frames if isinstance(m, BulkSetpoints)]


def connect() -> tuple[RobotLink, Tap, BridgeOnPort, SimClock]:
    clock = SimClock()
    host, far = memory_pair()
    tap = Tap(far)
    bridge = BridgeOnPort(tap, bridge_for(ROBOT))
    clock.add_listener(bridge.step)
    return wrap_link(host, ROBOT, clock), tap, bridge, clock


def entry(bulk: BulkSetpoints, motor: str) -> bytes:
    """A motor's 3 bytes in the bulk's body, as the host wrote them."""
    body = cobs_decode(CODEC.encode(bulk)[:-1])
    i = 5 + 3 * SLOT[motor]
    return body[i : i + 3]


def test_keep_entries_of_a_board_in_timeout_carry_raw_value_zero() -> None:
    link, tap, bridge, clock = connect()
    link.send_and_wait(
        [
            MotorCommand("bend_1_joint", ControlMode.POSITION, 0.3),
            MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05),
        ]
    )
    acked = tap.bulks()[-1]
    assert entry(acked, "bend_1_joint")[0] == 2 and entry(acked, "bend_1_joint") != b"\x02\x00\x00"
    assert entry(acked, "bend_1_drive")[0] == 3 and entry(acked, "bend_1_drive") != b"\x03\x00\x00"
    fault = FaultSpec(kind="board_reset", target="22", at=clock.now(), duration=1.0)
    bridge.bridge.schedule([fault])
    clock.advance(0.05)
    link.poll()
    latest = link.session.latest_state()
    assert latest is not None
    assert latest[0].board_status[ROBOT.board_ids().index(22)] & BoardStatus.TIMEOUT
    link.send_and_wait([MotorCommand(d, ControlMode.VELOCITY, 0.0) for d in DRIVES[1:]])
    stop = tap.bulks()[-1]
    # was ff xx xx with the table's raw values (700, 800 in the report)
    assert entry(stop, "bend_1_joint") == KEEP
    assert entry(stop, "bend_1_drive") == KEEP
    assert all(entry(stop, d) == b"\x03\x00\x00" for d in DRIVES[1:])


def test_the_session_sends_every_keep_entry_with_raw_value_zero() -> None:
    link, tap, _bridge, clock = connect()
    n = CODEC.layout.n_motors
    link.session.send_bulk([None] * n, [700] * n)
    clock.advance(0.02)
    link.poll()
    bulk = tap.bulks()[-1]
    assert bulk.raw_values == (0,) * n
    assert all(entry(bulk, m) == KEEP for m in SLOT)


def refuse_front_tilt(msg: Message) -> NackCode | None:
    if isinstance(msg, BulkSetpoints) and msg.modes[SLOT["front_tilt"]] is ControlMode.POSITION:
        return NackCode.BAD_MODE
    return None


def test_a_refused_entry_is_not_carried_by_the_next_bulk() -> None:
    link, tap, _bridge, _clock = connect()
    link.send_and_wait([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)])
    tap.refuse = refuse_front_tilt
    with pytest.raises(LinkError, match="nacked BAD_MODE"):
        link.send_and_wait([MotorCommand("front_tilt", ControlMode.POSITION, 0.16)])
    link.send_and_wait([MotorCommand(d, ControlMode.VELOCITY, 0.0) for d in DRIVES])
    refused, stop = tap.bulks()[-2:]
    assert entry(refused, "front_tilt")[0] == 2
    assert entry(stop, "front_tilt") == KEEP  # was front_tilt position:102 again
    assert all(entry(stop, d) == b"\x03\x00\x00" for d in DRIVES)
    assert stop.seq == refused.seq + 1


def test_the_supervisors_stop_after_a_refusal_does_not_carry_it() -> None:
    """The supervisor's path: send() without waiting, the NACK heard by poll(), which
    reports the refusal (LinkError; the next send() did until 2026-12-01); the send
    after it is the stop."""
    link, tap, _bridge, clock = connect()
    link.send_and_wait([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)])
    tap.refuse = refuse_front_tilt
    link.send([MotorCommand("front_tilt", ControlMode.POSITION, 0.16)])
    clock.advance(0.01)
    with pytest.raises(LinkError, match=r"refused \(BAD_MODE\)"):
        link.poll()
    stop = [MotorCommand(d, ControlMode.VELOCITY, 0.0) for d in DRIVES]
    link.send(stop)
    clock.advance(0.03)
    link.poll()
    sent = tap.bulks()[-1]
    assert entry(sent, "front_tilt") == KEEP
    assert all(entry(sent, d) == b"\x03\x00\x00" for d in DRIVES)
    assert link.session.take_failures() == []  # the stop was not refused


def test_an_acknowledged_value_stays_after_a_later_refusal() -> None:
    link, tap, _bridge, _clock = connect()
    link.send_and_wait([MotorCommand("front_tilt", ControlMode.TORQUE, 0.2)])
    held = entry(tap.bulks()[-1], "front_tilt")
    tap.refuse = lambda msg: (
        NackCode.OUT_OF_RANGE
        if isinstance(msg, BulkSetpoints) and msg.modes[SLOT["bend_2_drive"]] is not None
        else None
    )
    with pytest.raises(LinkError, match="nacked OUT_OF_RANGE"):
        link.send_and_wait([MotorCommand("bend_2_drive", ControlMode.VELOCITY, 0.05)])
    tap.refuse = lambda msg: None
    link.send_and_wait([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.0)])
    last = tap.bulks()[-1]
    assert entry(last, "front_tilt") == held  # acknowledged before: still in the table
    assert entry(last, "bend_2_drive") == KEEP  # refused: back to keep


def test_a_latched_bridge_refusing_a_stop_does_not_bring_back_an_older_value() -> None:
    """ESTOP_LATCHED refuses every entry: the drive's stop goes back to keep (what the
    bridge holds after its e-stop: velocity 0), never to the acknowledged 0.05 m/s."""
    link, tap, bridge, _clock = connect()
    link.send_and_wait([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)])
    bridge.bridge.set_estop_input(True)
    with pytest.raises(LinkError, match="nacked ESTOP_LATCHED"):
        link.send_and_wait([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.0)])
    bridge.bridge.set_estop_input(False)
    link.reset_estop()
    link.send_and_wait([MotorCommand("front_tilt", ControlMode.TORQUE, 0.2)])
    assert entry(tap.bulks()[-1], "bend_1_drive") == KEEP
    assert bridge.bridge.model.setpoint("bend_1_drive") == MotorCommand(
        "bend_1_drive", ControlMode.VELOCITY, 0.0
    )


@pytest.mark.parametrize(
    ("code", "message"),
    [
        (NackCode.NOT_READY, r"the bridge refused HELLO \(NOT_READY\)"),
        # refused under 1.2 and again under 1.1: the layout, not the version (2026-11-29)
        (
            NackCode.BAD_LAYOUT,
            r"refused the layout digest 0x[0-9a-f]{8} \(BAD_LAYOUT\) with protocol 1\.2 and"
            r" again with 1\.1: it was built for another robot description",
        ),
    ],
)
def test_a_nack_to_hello_is_named_for_what_it_is(code: NackCode, message: str) -> None:
    clock = SimClock()
    host, far = memory_pair()
    tap = Tap(far)
    tap.refuse = lambda msg: code if msg.TYPE is MsgType.HELLO else None
    bridge = BridgeOnPort(tap, bridge_for(ROBOT))
    clock.add_listener(bridge.step)
    with pytest.raises(ProtocolMismatch, match=message) as info:
        wrap_link(host, ROBOT, clock)
    if code is NackCode.NOT_READY:
        assert "layout" not in str(info.value).split(":")[0]
        assert "another robot description" not in str(info.value)


def test_a_stop_refused_at_close_sends_the_estop() -> None:
    """A bus fault: the bridge refuses every setpoint (BUS_ERROR), so the drives' stop
    at close is refused and the robot may be left driving; the host used to log a
    warning and close. It now sends the e-stop, which the bridge always takes."""
    from pirate_bt.link.messages import EStop

    link, tap, bridge, _clock = connect()
    link.send_and_wait([MotorCommand(d, ControlMode.VELOCITY, 0.05) for d in DRIVES])
    tap.refuse = lambda msg: NackCode.BUS_ERROR if isinstance(msg, BulkSetpoints) else None
    link.close()
    bridge.bridge.receive(tap.read_available())  # what was on the wire as it closed
    assert any(isinstance(m, EStop) for m in tap.frames), [type(m).__name__ for m in tap.frames]
    # the bridge applied its stop category: the drives are stopped
    assert bridge.bridge.model.setpoint("bend_1_drive") == MotorCommand(
        "bend_1_drive", ControlMode.VELOCITY, 0.0
    )


def test_a_stop_at_close_on_a_latched_bridge_sends_nothing_more() -> None:
    from pirate_bt.link.messages import EStop

    link, tap, bridge, clock = connect()
    link.send_and_wait([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)])
    bridge.bridge.set_estop_input(True)
    clock.advance(0.05)
    link.poll()  # the host has heard the latch
    before = sum(isinstance(m, EStop) for m in tap.frames)
    link.close()
    tap.read_available()
    assert sum(isinstance(m, EStop) for m in tap.frames) == before
