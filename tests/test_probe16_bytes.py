"""Probe 16: bytes no frame should contain, from the bridge to the host's link, and a
bridge written from docs/protocol.md alone (section 2: the host speaks to it; the page
claimed a lone 0x00 before every ``HELLO``, while a mid-session ``HELLO`` goes without
one: the page now says so).

1. A line flooded with bytes that make no good frame (a bridge at another baud rate,
   noise, a flood of 0xFF between frames) ended the link with *nothing heard from the
   bridge for 0.510 s*, as if the bridge were silent: 561 unreadable frames had come in
   those 0.5 s. The link's ``LinkLost`` now says what came instead (*no good frame from
   the bridge for 0.510 s: 561 unreadable frames (cobs 510, short 51) in 2346 bytes*),
   counted since the last good frame only; a silent line is still *nothing heard*.
"""

from __future__ import annotations

import binascii
import struct

import pytest
from session_wire import CODEC, Wire, reply, state

from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkLost, LinkTimeout, ProtocolMismatch
from pirate_bt.link.codec import Ack, AckStatus, BridgeFlags, Heartbeat, MsgType
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.requests import Outcome
from pirate_bt.link.testing import MemoryLink, memory_pair
from pirate_bt.robot import ControlMode, load_robot

# -- 1. a flooded line is not a silent one -------------------------------------------------

_GARBAGE = b"\x11\x22\x33\x00" * 3 + b"\xff" * 300 + b"\x00"  # 3 cobs, 1 oversize


def _flood(wire: Wire, batch: bytes, polls: int = 60) -> LinkLost:
    with pytest.raises(LinkLost) as caught:
        for _ in range(polls):
            wire.far.write(batch)
            wire.poll(0.01)
    return caught.value


def test_a_flood_of_unreadable_frames_is_named_not_taken_for_silence() -> None:
    wire = Wire(hello=reply())
    wire.answer(state(1))
    wire.poll(0.01)
    text = str(_flood(wire, _GARBAGE))
    assert "nothing heard" not in text, text
    assert text.startswith("no good frame from the bridge for 0.5"), text
    # 51 batches of 4 unreadable frames each, by reason, and every byte of them
    assert "204 unreadable frames (cobs 153, oversize 51)" in text, text
    assert f"in {51 * len(_GARBAGE)} bytes" in text, text
    # the next call says the same, not "nothing heard"
    with pytest.raises(LinkLost, match=r"^no good frame from the bridge for over 0\.5 s: 204 "):
        wire.session.poll()


def test_bytes_with_no_delimiter_at_all_are_named() -> None:
    wire = Wire(hello=reply())
    text = str(_flood(wire, b"\x55" * 100))  # a bridge at another baud rate, say
    assert "nothing heard" not in text, text
    assert "oversize" in text, text  # 255 bytes without a delimiter make a bad frame


def test_a_line_of_zeros_is_named_as_bytes_not_as_silence() -> None:
    wire = Wire(hello=reply())
    text = str(_flood(wire, b"\x00" * 20))  # a line held in break reads as 0x00s
    assert text.endswith(": 1020 bytes that made no frame"), text


def test_the_hosts_own_frames_echoed_back_are_named_an_echo() -> None:
    wire = Wire(hello=reply())
    echo = CODEC.encode(Heartbeat(5))
    text = str(_flood(wire, echo))
    assert "of the host's own frames (an echo" in text, text


def test_garbage_before_the_last_good_frame_is_not_counted() -> None:
    wire = Wire(hello=reply())
    for _ in range(5):
        wire.far.write(_GARBAGE)
        wire.poll(0.01)
    assert wire.session.line_noise().startswith("20 unreadable frames (cobs 15, oversize 5)")
    wire.answer(state(1))  # a good frame: what came before it does not count
    wire.poll(0.01)
    assert wire.session.line_noise() == ""
    with pytest.raises(LinkLost, match=r"^nothing heard from the bridge for 0\.5"):
        for _ in range(60):
            wire.poll(0.01)


# -- 2. a bridge written from docs/protocol.md alone -------------------------------------------


def _cobs(body: bytes) -> bytes:
    """docs/protocol.md, Framing: blocks of a code byte and code-1 data bytes."""
    out, block = bytearray(), bytearray()
    for b in body:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block.clear()
            continue
        block.append(b)
        if len(block) == 254:
            out += b"\xff" + block
            block.clear()
            if len(out) == len(body) + 1:  # a full block ends the body: nothing more
                return bytes(out)
    return bytes(out + bytes([len(block) + 1]) + block)


def _uncobs(data: bytes) -> bytes:
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        out += data[i + 1 : i + code]
        i += code
        if code != 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


class DocBridge:
    """The bridge side of the wire, from docs/protocol.md only: framing, CRC, HELLO,
    ESTOP_RESET, HEARTBEAT, BULK_SETPOINTS and a STATE every 10 ms."""

    def __init__(self, clock: SimClock, far: MemoryLink) -> None:
        self.robot = load_robot()
        self.far, self.buf, self.seq, self.ack_seq = far, b"", 0, 0
        self.flags = 0x01 | 0x08  # boots latched, NO_SESSION
        self.heard: list[tuple[int, int, int, bytes]] = []
        self.first = b""  # the first bytes the host wrote
        self.next_state_s = clock.now()
        clock.add_listener(self.step)

    def send(self, kind: int, seq: int, arg: int, payload: bytes) -> None:
        body = bytes([1, kind]) + struct.pack("<HB", seq, arg) + payload
        body += struct.pack("<H", binascii.crc_hqx(body, 0))
        self.far.write(_cobs(body) + b"\x00")

    def step(self, now: float) -> None:
        data = self.far.read_available()
        self.first = self.first or data
        self.buf += data
        *frames, self.buf = self.buf.split(b"\x00")
        for raw in frames:
            if raw:
                self.take(_uncobs(raw))
        while now >= self.next_state_s:
            self.next_state_s += 0.010
            self.state()

    def take(self, body: bytes) -> None:
        assert struct.unpack("<H", body[-2:])[0] == binascii.crc_hqx(body[:-2], 0)
        version, kind, seq, arg = struct.unpack("<BBHB", body[:5])
        payload = body[5:-2]
        assert version == 1
        self.heard.append((kind, seq, arg, payload))
        if kind == 0x01:  # HELLO: uint32 digest, uint8 minor
            digest, minor = struct.unpack("<IB", payload)
            self.flags &= ~0x08
            n_ch, n_m = len(self.robot.state_channels()), len(self.robot.setpoint_slots())
            reply = struct.pack("<IBBHHBHB", digest, n_ch, n_m, 250, 0x0102, minor, 7, 1)
            self.send(0x81, seq, self.flags, reply)
        elif kind in (0x04, 0x06):  # HEARTBEAT, ESTOP_RESET: ACK APPLIED
            if kind == 0x06:
                self.flags &= ~0x01
            self.send(0x83, seq, 0, bytes([kind, 0]))
        elif kind == 0x03:  # BULK_SETPOINTS: the next STATE's ack_seq
            self.ack_seq = seq

    def state(self) -> None:
        channels = self.robot.state_channels()
        boards = self.robot.board_ids()
        fresh = b"\xff" * ((len(channels) + 7) // 8)
        status = bytes([0x11] * ((len(boards) + 1) // 2))  # ONLINE, every board
        values = struct.pack(f"<{len(channels)}h", *range(len(channels)))
        self.seq = (self.seq + 1) & 0xFFFF
        self.send(
            0x82, self.seq, self.flags, struct.pack("<H", self.ack_seq) + fresh + status + values
        )


def test_the_host_talks_to_a_bridge_written_from_the_protocol_page() -> None:
    clock = SimClock(1.0)
    host, far = memory_pair()
    peer = DocBridge(clock, far)
    link = wrap_link(host, peer.robot, clock, reset_wait_s=0.0)
    clock.advance(0.05)
    link.poll()
    assert peer.first[:1] == b"\x00"  # a lone delimiter flushes a half frame first
    kinds = [k for k, *_ in peer.heard]
    assert kinds[:2] == [0x01, 0x06], kinds  # HELLO, then the release of the boot latch
    _, _, _, hello = peer.heard[0]
    assert hello == struct.pack("<IB", peer.robot.layout_digest(), 2)
    state = link.state()
    assert state is not None and not link.health().estopped
    assert link.health().crc_errors == 0
    link.close()


# -- 3. a NACK with a code the protocol does not have -----------------------------------------


def _raw_nack(seq: int, kind: int, code: int) -> bytes:
    body = bytes([1, 0x84]) + struct.pack("<HB", seq, 0) + bytes([kind, code])
    return _cobs(body + struct.pack("<H", binascii.crc_hqx(body, 0))) + b"\x00"


def test_a_setpoint_refused_with_an_unknown_nack_code_is_a_protocol_mismatch() -> None:
    wire = Wire(hello=reply())
    req = wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, 5)
    wire.far.write(_raw_nack(req.seq, 0x02, 42))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(0.01)
    text = str(caught.value)
    assert text.startswith("the bridge answered SETPOINT seq 2 with an unknown NACK code 42:")
    assert "protocol mismatch" in text and "(the protocol's NACK codes are 1 to 10)" in text
    assert req.tries == 1  # not sent again into a timeout


def test_an_unknown_nack_code_answering_nothing_in_flight_is_only_counted() -> None:
    wire = Wire(hello=reply())
    wire.far.write(_raw_nack(40, 0x02, 42))
    wire.poll(0.01)
    assert wire.session.stats().crc_errors == 1
    wire.session.ensure_alive()


def test_a_hello_answered_with_an_unknown_nack_code_is_named_at_connect() -> None:
    clock = SimClock(1.0)
    host, far = memory_pair()
    hellos = []

    def answer(_now: float) -> None:
        for raw in far.read_available().split(b"\x00"):
            if raw:
                body = _uncobs(raw)
                hellos.append(body[1])
                far.write(_raw_nack(struct.unpack("<H", body[2:4])[0], body[1], 42))

    clock.add_listener(answer)
    with pytest.raises(ProtocolMismatch) as caught:
        wrap_link(host, load_robot(), clock, reset_wait_s=0.0)
    text = str(caught.value)
    assert text.startswith("the bridge answered HELLO with an unknown NACK code 42"), text
    assert "baud rate" not in text and "did not answer" not in text
    assert hellos == [0x01]  # answered at once: not asked 16 times


def test_a_port_sending_only_zeros_at_connect_is_not_said_to_send_no_delimiter() -> None:
    clock = SimClock(1.0)
    host, far = memory_pair()
    clock.add_listener(lambda _now: (far.read_available(), far.write(b"\x00" * 8)))
    with pytest.raises(LinkTimeout) as caught:
        wrap_link(host, load_robot(), clock, reset_wait_s=0.0)
    text = str(caught.value)
    assert "none a good frame (0x00 bytes, no frame between them)" in text, text
    assert "no delimiter" not in text


# -- 5. a supervised run over a flooded line ----------------------------------------------------


def test_a_supervised_run_names_a_flooded_line_not_silence() -> None:
    # The link's own LinkLost named the flood (section 1), but the supervisor, which
    # stops first (max_link_silence is shorter than the link's timeout), still said
    # "link_silent: nothing heard from the bridge": LinkHealth now carries the noise.
    from pirate_bt.safety import Supervisor

    clock = SimClock(1.0)
    host, far = memory_pair()
    peer = DocBridge(clock, far)
    link = wrap_link(host, peer.robot, clock, reset_wait_s=0.0)
    sup = Supervisor(link, clock)
    for _ in range(5):
        clock.advance(0.05)
        sup.tick()
    assert sup.safe_state_reason is None and link.health().line_noise == ""
    clock.remove_listener(peer.step)  # the bridge now sends only bytes that make no frame
    for _ in range(10):
        far.write(_GARBAGE)
        clock.advance(0.05)
        sup.tick()
    reason = sup.safe_state_reason
    assert reason is not None and reason.startswith(
        "link_silent: no good frame from the bridge for 0."
    ), reason
    assert "unreadable frames (cobs " in reason and "oversize" in reason, reason
    assert "nothing heard" not in reason
    link.close()


def test_a_silent_line_is_still_nothing_heard_for_the_supervisor() -> None:
    from pirate_bt.safety import Supervisor

    clock = SimClock(1.0)
    host, far = memory_pair()
    peer = DocBridge(clock, far)
    link = wrap_link(host, peer.robot, clock, reset_wait_s=0.0)
    sup = Supervisor(link, clock)
    for _ in range(5):
        clock.advance(0.05)
        sup.tick()
    clock.remove_listener(peer.step)
    for _ in range(10):
        clock.advance(0.05)
        sup.tick()
    reason = sup.safe_state_reason
    assert reason is not None and "nothing heard from the bridge for 0." in reason, reason
    link.close()


# -- 6. a STATE from before the release of the latch, delivered after its ACK -------------------


def _released(flags: BridgeFlags = BridgeFlags.ESTOP) -> Wire:
    wire = Wire(hello=reply(flags=flags))
    wire.answer(state(1, flags=flags))
    wire.poll(0.01)
    assert wire.session.stats().estopped
    reset = wire.session.estop_reset()
    wire.poll(0.001)
    (msg,) = wire.sent()
    wire.answer(Ack(msg.seq, MsgType.ESTOP_RESET, AckStatus.APPLIED))
    wire.poll(0.001)
    assert reset.outcome is Outcome.ACKED and not wire.session.stats().estopped
    return wire


def test_a_state_from_before_the_release_does_not_latch_the_host_again() -> None:
    # A line that reorders (a relay, jitter) delivered a STATE sent before the release
    # after its ACK: its ESTOP flag was taken as a new latch, and the supervisor then
    # latched the bridge for real (probe 16, 'delay=30ms,jitter=10ms' seed 1)
    wire = _released()
    wire.answer(state(2, flags=BridgeFlags.ESTOP))
    wire.poll(0.01)
    assert not wire.session.stats().estopped
    wire.answer(state(3))  # the bridge's own word: released
    wire.poll(0.01)
    assert not wire.session.stats().estopped
    # a latch after a STATE that showed it released is believed at once
    wire.answer(state(4, flags=BridgeFlags.ESTOP))
    wire.poll(0.01)
    assert wire.session.stats().estopped


def test_a_latch_the_bridge_keeps_after_the_release_is_believed_from_the_third_state() -> None:
    wire = _released()
    seen = []
    for seq in (2, 3, 4):
        wire.answer(state(seq, flags=BridgeFlags.ESTOP))
        wire.poll(0.01)
        seen.append(wire.session.stats().estopped)
    assert seen == [False, False, True]


def test_the_host_s_own_e_stop_after_a_release_is_believed_at_once() -> None:
    wire = _released()
    stop = wire.session.estop()
    wire.poll(0.001)
    wire.answer(state(2, flags=BridgeFlags.ESTOP))
    wire.poll(0.001)
    assert wire.session.stats().estopped
    wire.answer(Ack(stop.seq, MsgType.ESTOP, AckStatus.APPLIED))
    wire.poll(0.001)
    assert wire.session.stats().estopped
