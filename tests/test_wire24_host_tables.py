"""The host's decoder and session against hostile byte streams, table by table.

Every single-byte corruption of a valid frame of each type the bridge sends, a table
of two-byte corruptions, truncations, frames glued together, delimiters only, 1 MB
of noise, a valid CRC over nonsense, a type the host never sends or receives, a
replayed old frame, an answer to a request never made, a second HELLO_REPLY, STATE
sequence numbers that wrap or jump. The contract (docs/protocol.md, Bad frames):
the decoder gives back only messages and :class:`~pirate_bt.errors.FrameError`,
never raises, holds at most one frame's bytes; the session raises nothing, counts
every bad frame in ``crc_errors`` and takes no damaged ``STATE`` as the robot's.
"""

from __future__ import annotations

import random
import struct

import pytest
from session_wire import CODEC, Wire, counters, reply, state

from pirate_bt.errors import FrameError
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BridgeHeartbeat,
    FrameDecoder,
    Message,
    MsgType,
    Nack,
    NackCode,
)
from pirate_bt.link.framing import MAX_WIRE_BYTES, cobs_encode, crc16
from pirate_bt.link.inbound import UNMATCHED_KEPT

FRAMES: dict[str, Message] = {
    "state": state(40, ack_seq=3, flags=BridgeFlags.WATCHDOG),
    "ack": Ack(5, MsgType.SETPOINT, AckStatus.APPLIED),
    "nack": Nack(5, MsgType.SETPOINT, NackCode.BAD_MODE),
    "hello_reply": reply(1),
    "counters": counters(6, rx_frames=9),
    "bridge_heartbeat": BridgeHeartbeat(41, BridgeFlags.NONE),
}


def corrupted(wire: bytes) -> list[bytes]:
    """Single-byte changes of ``wire`` at every position but its delimiter (every value
    in a short frame; a long one's each way to a delimiter, a code or a flipped bit) and
    a table of two-byte ones."""
    out = []
    n = len(wire) - 1
    for i in range(n):
        every = range(256) if n < 16 else {0, 1, 0xFF, wire[i] ^ 0x01, wire[i] ^ 0x80}
        for value in sorted(every):
            if value != wire[i]:
                out.append(wire[:i] + bytes([value]) + wire[i + 1 :])
    for i in range(n):
        for j in range(i + 1, n):
            damaged = bytearray(wire)
            damaged[i] ^= 0x01
            damaged[j] ^= 0x80
            out.append(bytes(damaged))
    return out


def raw_frame(version: int, kind: int, seq: int, arg: int, payload: bytes) -> bytes:
    """A frame with a good CRC over whatever it is given."""
    body = bytes([version, kind]) + struct.pack("<HB", seq, arg) + payload
    return cobs_encode(body + struct.pack("<H", crc16(body))) + b"\x00"


@pytest.mark.parametrize("name", sorted(FRAMES))
def test_no_damaged_frame_decodes_to_another_message_and_none_raises(name: str) -> None:
    msg = FRAMES[name]
    wire = CODEC.encode(msg)
    decoder = FrameDecoder(CODEC)
    for damaged in corrupted(wire):
        decoder.reset()
        out = decoder.feed(damaged + b"\x00")  # a flush: a zero put inside splits it
        assert out, damaged.hex()
        for item in out:
            # a change of the arg byte of a frame that ignores it reads the same message
            assert isinstance(item, FrameError) or item == msg, (damaged.hex(), item)


def test_truncations_glued_frames_and_delimiters_only_are_errors_or_nothing() -> None:
    decoder = FrameDecoder(CODEC)
    wire = CODEC.encode(FRAMES["state"])
    for k in range(1, len(wire) - 1):
        got = decoder.feed(wire[:k] + b"\x00")
        assert len(got) == 1 and isinstance(got[0], FrameError), k
    glued = decoder.feed(wire[:-1] + wire)  # a lost delimiter: one bad frame
    assert len(glued) == 1 and isinstance(glued[0], FrameError)
    assert decoder.feed(b"\x00" * 100_000) == []
    assert decoder.feed(wire) == [FRAMES["state"]]  # the next frame is read


def test_a_megabyte_of_noise_never_raises_and_holds_at_most_one_frame() -> None:
    rng = random.Random(24)
    decoder = FrameDecoder(CODEC)
    noise = rng.randbytes(1 << 20)
    kinds: set[str] = set()
    i = 0
    while i < len(noise):
        step = rng.choice((1, 7, 300, 4096))
        for item in decoder.feed(noise[i : i + step]):
            assert isinstance(item, FrameError | Message)
            if isinstance(item, FrameError):
                kinds.add(item.reason)
        assert decoder.pending_bytes < MAX_WIRE_BYTES
        i += step
    assert kinds <= {"oversize", "cobs", "short", "crc", "version", "type", "length", "value"}
    wire = CODEC.encode(FRAMES["ack"])
    assert decoder.feed(b"\x00" + wire)[-1] == FRAMES["ack"]  # after what the 0x00 ended


NONSENSE = {
    "a type nobody sends": raw_frame(1, 0x42, 7, 0, b"\x01\x02"),
    "version 2": raw_frame(2, MsgType.ACK, 5, 0, bytes([MsgType.SETPOINT, 0])),
    "a state one byte short": raw_frame(
        1, MsgType.STATE, 41, 0, CODEC.encode_payload(FRAMES["state"])[1][:-1]
    ),
    "an ack of an unknown status": raw_frame(1, MsgType.ACK, 5, 0, bytes([MsgType.SETPOINT, 9])),
    "a nack of no code": raw_frame(1, MsgType.NACK, 5, 0, bytes([MsgType.SETPOINT, 0])),
    "counters of 2 boards": raw_frame(1, MsgType.COUNTERS, 6, 0, bytes(20 + 26)),
    "a heartbeat with a payload": raw_frame(1, MsgType.BRIDGE_HEARTBEAT, 42, 0, b"\xff"),
}


@pytest.mark.parametrize("name", sorted(NONSENSE))
def test_a_good_crc_over_nonsense_is_one_bad_frame_to_the_session(name: str) -> None:
    wire = Wire()
    wire.answer(state(40))
    wire.poll(0.001)
    before = wire.session.stats().crc_errors
    wire.far.write(NONSENSE[name])
    wire.poll(0.001)
    stats = wire.session.stats()
    assert stats.crc_errors == before + 1
    assert stats.connected
    latest = wire.session.latest_state()
    assert latest is not None and latest[0].seq == 40


def test_every_damaged_state_is_counted_once_and_none_is_taken() -> None:
    wire = Wire()
    wire.answer(state(40))
    wire.poll(0.001)
    good = CODEC.encode(state(41, ack_seq=0, flags=BridgeFlags.ESTOP))
    bad = 0
    for damaged in corrupted(good)[::7]:  # every 7th: 1 in 7 of each position's values
        parts = [p for p in (damaged + b"\x00").split(b"\x00")[:-1] if p]
        bad += len(parts)
        wire.far.write(damaged + b"\x00")
        wire.session.poll()
        latest = wire.session.latest_state()
        assert latest is not None and latest[0].seq == 40, damaged.hex()
    stats = wire.session.stats()
    assert stats.crc_errors == bad
    assert not stats.estopped  # the ESTOP flag of a damaged frame was never believed


def test_a_host_frame_from_the_bridge_is_named_an_echo_not_taken() -> None:
    wire = Wire()
    wire.answer(state(40))
    wire.poll(0.001)
    wire.far.write(raw_frame(1, MsgType.SETPOINT, 7, 22, b"\x01\x03\x00\x00"))
    wire.poll(0.001)
    stats = wire.session.stats()
    assert "1 of the host's own frames (an echo" in stats.line_noise
    assert stats.connected and stats.failed == 0


def test_replays_jumps_wraps_and_answers_to_nothing_never_raise() -> None:
    wire = Wire()
    wire.answer(state(65534))
    wire.poll(0.001)
    wire.answer(state(65535), state(0), state(1))  # the bridge's counter wraps
    wire.poll(0.001)
    latest = wire.session.latest_state()
    assert latest is not None and latest[0].seq == 1
    wire.answer(state(65535))  # a replayed old STATE
    wire.poll(0.001)
    latest = wire.session.latest_state()
    assert latest is not None and latest[0].seq == 1
    dups = wire.session.stats().duplicates
    assert dups >= 1
    # answers to requests never made, a second unasked HELLO_REPLY of the same boot
    wire.answer(Ack(900, MsgType.SETPOINT, AckStatus.APPLIED), Nack(901, MsgType.ESTOP, 1))
    wire.answer(reply(1), reply(1))
    wire.poll(0.001)
    assert wire.session.stats().connected
    assert wire.session.stats().failed == 0
    # a flood of them is counted, and what the session keeps of them stays bounded
    before = wire.session.stats().duplicates
    for seq in range(1000, 3000):
        wire.answer(Ack(seq, MsgType.SETPOINT, AckStatus.APPLIED))
    wire.poll(0.001)
    assert wire.session.stats().duplicates == before + 2000
    assert wire.session.answers_unasked_since(0.0) == UNMATCHED_KEPT
