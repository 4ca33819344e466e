"""The wire's rules at their edges: the CRC against every small error, COBS at its block
boundaries, sequence numbers half a circle apart, and what each refused frame says.

Written with the mutation run (docs/testing.md). The CRC tests are exhaustive where the
guarantee is: CRC-16 catches every error burst of up to 16 bits, so every single-byte
error anywhere in a body (header, payload or either CRC byte) must come back as a
``crc`` error; a weaker check (its low byte only, say) lets some through.
"""

from __future__ import annotations

import binascii
import dataclasses
import struct

import pytest

from pirate_bt.errors import FrameError
from pirate_bt.link import codec as c
from pirate_bt.robot import ControlMode, load_robot

ROBOT = load_robot()
LAYOUT = c.WireLayout.from_robot(ROBOT)
CODEC = c.FrameCodec(LAYOUT)
N_CH, N_M, N_B = LAYOUT.n_channels, LAYOUT.n_motors, LAYOUT.n_boards

SAMPLES: list[c.Message] = [
    c.State(513, c.BridgeFlags.ESTOP, 77, (1 << N_CH) - 1, (1,) * N_B, tuple(range(N_CH))),
    c.Ack(1000, c.MsgType.SETPOINT, c.AckStatus.APPLIED),
    c.Setpoint(4, 22, 1, ControlMode.VELOCITY, -300),
    c.BulkSetpoints(9, (ControlMode.VELOCITY,) * N_M, (5,) * N_M),
]


def body_of(msg: c.Message) -> bytes:
    return c.cobs_decode(CODEC.encode(msg)[:-1])


def feed_body(body: bytes) -> list[c.Message | FrameError]:
    return c.FrameDecoder(CODEC).feed(c.cobs_encode(body) + b"\x00")


def refusal(body: bytes) -> tuple[str, str]:
    with pytest.raises(FrameError) as caught:
        CODEC.decode_body(body)
    return caught.value.reason, caught.value.detail


def with_crc(body: bytes) -> bytes:
    return body + struct.pack("<H", binascii.crc_hqx(body, 0))


# -- the CRC -----------------------------------------------------------------------------------


@pytest.mark.parametrize("msg", SAMPLES, ids=lambda m: type(m).__name__)
def test_every_single_byte_error_in_a_body_is_a_crc_error(msg: c.Message) -> None:
    body = body_of(msg)
    CODEC._state_rest = b""  # white box: no STATE fast-path memory between frames
    for pos in range(len(body)):
        for err in range(1, 256):
            bad = bytearray(body)
            bad[pos] ^= err
            with pytest.raises(FrameError) as caught:
                CODEC.decode_body(bytes(bad))
            assert caught.value.reason == "crc", (pos, err)


@pytest.mark.parametrize("byte", [-2, -1], ids=["low byte", "high byte"])
def test_a_one_bit_error_in_either_crc_byte_is_refused(byte: int) -> None:
    for msg in SAMPLES:
        body = body_of(msg)
        for bit in range(8):
            bad = bytearray(body)
            bad[byte] ^= 1 << bit
            out = feed_body(bytes(bad))
            assert len(out) == 1 and isinstance(out[0], FrameError), (msg, bit)
            crc = struct.unpack_from("<H", bad, len(bad) - 2)[0]
            assert (out[0].reason, out[0].detail) == (
                "crc",
                f"CRC mismatch (frame says {crc:#06x})",
            )


def test_the_crc_is_xmodem_over_header_and_payload_little_endian() -> None:
    assert c.crc16(b"123456789") == 0x31C3
    assert c.crc16(b"") == 0
    body = body_of(c.Heartbeat(0x0102))
    assert body[:5] == bytes([1, c.MsgType.HEARTBEAT, 0x02, 0x01, 0])
    assert body[5:] == struct.pack("<H", binascii.crc_hqx(body[:5], 0))


# -- sequence numbers, line time ---------------------------------------------------------------


@pytest.mark.parametrize("base", [0, 1, 0x7FFF, 0x8000, 0xFFFE, 0xFFFF])
def test_seq_newer_is_half_the_circle_ahead(base: int) -> None:
    def ahead(k: int) -> int:
        return (base + k) & 0xFFFF

    assert not c.seq_newer(base, base)
    assert c.seq_newer(ahead(1), base)
    assert c.seq_newer(ahead(0x7FFF), base)
    assert not c.seq_newer(ahead(0x8000), base)
    assert not c.seq_newer(ahead(0xFFFF), base)
    assert not c.seq_newer(base, ahead(1))


def test_line_times() -> None:
    assert c.byte_time_s(115200) == 10.0 / 115200
    assert c.frame_time_s(256, 115200) == 256 * 10.0 / 115200
    assert c.frame_time_s(0, 9600) == 0.0
    assert c.MAX_WIRE_BYTES == 256 and c.MAX_PAYLOAD_BYTES == 247


# -- COBS at its block boundaries ----------------------------------------------------------------


def reference_cobs(data: bytes) -> bytes:
    """COBS by the textbook byte loop; a full last block gets no trailing 0x01."""
    out, block = bytearray(), bytearray()
    for byte in data:
        if byte == 0:
            out += bytes((len(block) + 1,)) + block
            block.clear()
        else:
            block.append(byte)
            if len(block) == 254:
                out += b"\xff" + block
                block.clear()
    if block or not data or data[-1] == 0:
        out += bytes((len(block) + 1,)) + block
    return bytes(out)


LENGTHS = [1, 2, 252, 253, 254, 255, 256, 507, 508, 509, 600]


@pytest.mark.parametrize("n", LENGTHS)
@pytest.mark.parametrize("shape", ["runs", "zero first", "zero last", "zero at 254", "all zero"])
def test_cobs_encodes_like_the_byte_loop_at_every_block_boundary(n: int, shape: str) -> None:
    data = bytearray((i % 255) + 1 for i in range(n))
    if shape == "zero first":
        data[0] = 0
    elif shape == "zero last":
        data[-1] = 0
    elif shape == "zero at 254" and n > 254:
        data[254] = 0
    elif shape == "all zero":
        data = bytearray(n)
    encoded = c.cobs_encode(bytes(data))
    assert encoded == reference_cobs(bytes(data))
    assert 0 not in encoded and c.cobs_decode(encoded) == bytes(data)


def test_cobs_of_nothing_is_one_code_byte() -> None:
    assert c.cobs_encode(b"") == b"\x01"
    assert c.cobs_decode(b"\x01") == b""


def test_a_receiver_accepts_a_trailing_empty_block() -> None:
    data = b"\x07" * 254
    assert c.cobs_decode(b"\xff" + data + b"\x01") == data
    assert c.cobs_decode(b"\xff" + data) == data


@pytest.mark.parametrize(
    ("encoded", "detail"),
    [
        (b"", "empty frame"),
        (b"\x02\x00", "zero byte inside frame"),
        (b"\x05\x01\x02", "block code 5 at 0 runs past the end (3 bytes)"),
        (b"\x02\x01\x09", "block code 9 at 2 runs past the end (3 bytes)"),
        (b"\xff" + b"\x01" * 10, "block code 255 at 0 runs past the end (11 bytes)"),
        (b"\x02\x01\xff" + b"\x01" * 3, "block code 255 at 2 runs past the end (6 bytes)"),
    ],
    ids=["empty", "zero", "past the end", "last block", "full block", "full block later"],
)
def test_bad_cobs_says_where(encoded: bytes, detail: str) -> None:
    with pytest.raises(FrameError) as caught:
        c.cobs_decode(encoded)
    assert (caught.value.reason, caught.value.detail) == ("cobs", detail)


# -- what a refused body says ---------------------------------------------------------------


def test_each_refusal_names_its_reason_and_what_was_wrong() -> None:
    hb = body_of(c.Heartbeat(3))
    assert refusal(hb[:6]) == ("short", "6 bytes, need at least 7")
    assert refusal(with_crc(bytes(253))) == ("oversize", "255-byte body (max 254)")
    assert refusal(with_crc(bytes([2]) + hb[1:5])) == ("version", "protocol version 2, expected 1")
    assert refusal(with_crc(bytes([1, 0x7F]) + hb[2:5])) == ("type", "unknown message type 0x7f")
    assert refusal(with_crc(hb[:5] + b"\x00")) == (
        "length",
        "HEARTBEAT payload 1 bytes, expected 0",
    )
    state = body_of(SAMPLES[0])
    assert refusal(with_crc(state[:-3])) == (
        "length",
        f"state payload {LAYOUT.state_payload_bytes - 1} bytes, layout needs"
        f" {LAYOUT.state_payload_bytes}",
    )
    bulk = body_of(SAMPLES[3])
    assert refusal(with_crc(bulk[:-3])) == (
        "length",
        f"bulk payload {LAYOUT.bulk_payload_bytes - 1} bytes, layout needs"
        f" {LAYOUT.bulk_payload_bytes}",
    )
    bad_mode = bytearray(bulk[:-2])
    bad_mode[5] = 0x42
    assert refusal(with_crc(bytes(bad_mode))) == ("value", "unknown mode code 66")
    setpoint = bytearray(body_of(SAMPLES[2])[:-2])
    setpoint[6] = 0x43
    assert refusal(with_crc(bytes(setpoint))) == ("value", "unknown mode code 67")
    ack = bytearray(body_of(SAMPLES[1])[:-2])
    ack[6] = 9
    assert refusal(with_crc(bytes(ack))) == ("value", "unknown ack status 9")
    nack = bytearray(body_of(c.Nack(3, 2, c.NackCode.BAD_SLOT))[:-2])
    nack[6] = 200
    assert refusal(with_crc(bytes(nack))) == ("value", "unknown nack code 200")
    counters = body_of(c.Counters(5, boards=(c.BoardCounters(20),)))[:-2]
    assert refusal(with_crc(counters[:-1])) == ("length", "counters payload of 32 bytes")
    assert refusal(with_crc(counters[:24])) == ("length", "counters payload of 19 bytes")


def test_a_frame_too_long_for_the_wire_is_oversize() -> None:
    with pytest.raises(FrameError) as caught:
        CODEC.decode(b"\x01" * 256)
    assert (caught.value.reason, caught.value.detail) == (
        "oversize",
        "256 bytes before the delimiter",
    )
    assert CODEC.decode(CODEC.encode(c.Heartbeat(1))[:-1]) == c.Heartbeat(1)


# -- every message type, each field where the codec puts it -------------------------------------


def test_each_message_decodes_from_its_own_fields() -> None:
    msgs: list[c.Message] = [
        c.Hello(7, 0xDEADBEEF, 2),
        c.HelloReply(8, 0x01020304, N_CH, N_M, 250, 0x0203, 2, 0x0405, 6, c.BridgeFlags.ESTOP),
        c.Setpoint(9, 22, 1, ControlMode.TORQUE, -5),
        c.BulkSetpoints(10, (None, *((ControlMode.POSITION,) * (N_M - 1))), tuple(range(N_M))),
        c.Heartbeat(11),
        c.EStop(12),
        c.EStopReset(13),
        c.CountersRequest(14),
        c.State(
            15, c.BridgeFlags.WATCHDOG, 3, 0b101, tuple(i % 16 for i in range(N_B)), (1,) * N_CH
        ),
        c.Ack(16, 3, c.AckStatus.DUPLICATE),
        c.Nack(17, 2, c.NackCode.ESTOP_LATCHED),
        c.Counters(18, 1, 2, 3, 4, 5, tuple(c.BoardCounters(20 + i, 6, 7, i) for i in range(N_B))),
        c.BridgeHeartbeat(19, c.BridgeFlags.NO_SESSION),
    ]
    for msg in msgs:
        body = body_of(msg)
        assert body[0] == 1 and body[1] == msg.TYPE
        assert struct.unpack_from("<H", body, 2)[0] == msg.seq
        decoded = CODEC.decode_body(body)
        assert type(decoded) is type(msg) and decoded == msg, msg
    # the header's arg: the board of a SETPOINT, the flags of STATE, HELLO_REPLY, heartbeat
    assert body_of(msgs[2])[4] == 22
    assert body_of(msgs[8])[4] == c.BridgeFlags.WATCHDOG
    assert body_of(msgs[1])[4] == c.BridgeFlags.ESTOP
    assert body_of(msgs[12])[4] == c.BridgeFlags.NO_SESSION
    assert all(body_of(m)[4] == 0 for m in (msgs[0], msgs[4], msgs[9], msgs[10], msgs[11]))


def test_a_state_is_read_right_after_one_that_differs_only_in_its_seq() -> None:
    """The STATE fast path (the same body but the seq) still checks the version byte."""
    first = SAMPLES[0]
    assert isinstance(first, c.State)
    decoder = c.FrameDecoder(c.FrameCodec(LAYOUT))
    assert decoder.feed(CODEC.encode(first)) == [first]
    again = c.State(
        first.seq + 1,
        *(
            getattr(first, f)
            for f in ("flags", "ack_seq", "fresh_mask", "board_status", "raw_values")
        ),
    )
    assert decoder.feed(CODEC.encode(again)) == [again]
    body = bytearray(body_of(again))
    body[0] = 2
    body[-2:] = struct.pack("<H", binascii.crc_hqx(bytes(body[:-2]), 0))
    out = decoder.feed(c.cobs_encode(bytes(body)) + b"\x00")
    assert len(out) == 1 and isinstance(out[0], FrameError) and out[0].reason == "version"


def test_status_caches_stay_bounded() -> None:
    codec = c.FrameCodec(LAYOUT)
    decoder = c.FrameDecoder(codec)
    for i in range(100):
        status = tuple((i >> k) & 1 for k in range(N_B))
        status = (i % 16, *status[1:])
        msg = c.State(i, c.BridgeFlags.NONE, 0, 0, status, (0,) * N_CH)
        assert decoder.feed(codec.encode(msg)) == [msg]
        assert len(codec._status_to_wire) <= 64 and len(codec._status_from_wire) <= 64


def test_encode_state_is_encode_of_the_state() -> None:
    codec = c.FrameCodec(LAYOUT)
    for seq, flags, status in (
        (1, c.BridgeFlags.NONE, (1,) * N_B),
        (2, c.BridgeFlags.NONE, (1,) * N_B),
        (0xFFFF, c.BridgeFlags.ESTOP, (2,) * N_B),
        (0, c.BridgeFlags.ESTOP, (2,) * N_B),
    ):
        args = (seq, flags, 5, 3, status, tuple(range(N_CH)))
        assert codec.encode_state(*args) == CODEC.encode(c.State(*args))
    for bad_seq in (-1, 0x10000):
        with pytest.raises(ValueError, match=f"^cannot encode state seq {bad_seq}$"):
            codec.encode_state(bad_seq, c.BridgeFlags.NONE, 0, 0, (1,) * N_B, (0,) * N_CH)


def test_out_of_range_fields_are_refused_with_the_message() -> None:
    with pytest.raises(ValueError, match=r"^cannot encode Heartbeat\(seq=70000\)"):
        CODEC.encode(c.Heartbeat(70000))
    with pytest.raises(ValueError, match=r"^cannot encode Ack\(seq=1, acked_type=300"):
        CODEC.encode(c.Ack(1, 300))
    with pytest.raises(ValueError, match=r"^cannot encode EStop\(seq=-1\)"):
        CODEC.encode(c.EStop(-1))
    with pytest.raises(ValueError, match=r"^bulk setpoint frame does not match the layout$"):
        CODEC.encode(c.BulkSetpoints(1, (None,) * N_M, (0,) * (N_M - 1)))
    with pytest.raises(ValueError, match=r"^state frame does not match the layout$"):
        CODEC.encode_payload(c.State(1, c.BridgeFlags.NONE, 0, 0, (1,) * (N_B + 1), (0,) * N_CH))
    with pytest.raises(ValueError, match=r"^board status 16 is not a nibble$"):
        CODEC.encode_payload(c.State(1, c.BridgeFlags.NONE, 0, 0, (16,) * N_B, (0,) * N_CH))
    boards = tuple(c.BoardCounters(i) for i in range(18))
    with pytest.raises(ValueError, match=r"^18 boards do not fit one counters frame$"):
        CODEC.encode(c.Counters(1, boards=boards))
    assert CODEC.encode(c.Counters(1, boards=boards[:17]))


# -- the streaming decoder -------------------------------------------------------------------------


def test_an_overlong_frame_is_reported_once_and_the_next_one_read() -> None:
    decoder = c.FrameDecoder(CODEC)
    out = decoder.feed(b"\x01" * 255)
    assert out == [] and decoder.pending_bytes == 255  # at the limit: still a frame
    out = decoder.feed(b"\x01")
    assert [(e.reason, e.detail) for e in out if isinstance(e, FrameError)] == [
        ("oversize", "more than 255 bytes without a delimiter")
    ]
    assert decoder.pending_bytes == 0
    assert decoder.feed(b"\x01" * 500) == []  # still the same frame: nothing more reported
    hb = CODEC.encode(c.Heartbeat(4))
    assert decoder.feed(b"\x01\x00" + hb) == [c.Heartbeat(4)]  # the rest dropped, then resync


def test_a_frame_that_ends_over_the_limit_is_oversize() -> None:
    decoder = c.FrameDecoder(CODEC)
    out = decoder.feed(b"\x01" * 200)
    out += decoder.feed(b"\x01" * 56 + b"\x00")
    assert [(e.reason, e.detail) for e in out if isinstance(e, FrameError)] == [
        ("oversize", "256 bytes before the delimiter")
    ]
    whole = decoder.feed(b"\x01" * 256 + b"\x00")
    assert [(e.reason, e.detail) for e in whole if isinstance(e, FrameError)] == [
        ("oversize", "256 bytes before the delimiter")
    ]


def test_reset_forgets_a_partial_or_overlong_frame() -> None:
    hb = CODEC.encode(c.Heartbeat(5))
    decoder = c.FrameDecoder(CODEC)
    decoder.feed(b"\x03\x01")
    decoder.reset()
    assert decoder.pending_bytes == 0 and decoder.feed(hb) == [c.Heartbeat(5)]
    decoder.feed(b"\x01" * 300)  # overlong: the rest up to the next delimiter is dropped
    decoder.reset()
    assert decoder.feed(hb) == [c.Heartbeat(5)]  # after a reset, nothing is dropped


def test_frames_split_anywhere_decode_and_empty_frames_are_ignored() -> None:
    wire = b"\x00\x00" + c.encode_many(CODEC, SAMPLES) + b"\x00"
    for cut in range(1, len(wire)):
        decoder = c.FrameDecoder(CODEC)
        assert decoder.feed(wire[:cut]) + decoder.feed(wire[cut:]) == SAMPLES
    assert c.FrameDecoder(CODEC).feed(b"") == []


def test_a_decoder_that_breaks_is_a_frame_error_not_an_exception() -> None:
    class Broken:
        def encode(self, msg: c.Message) -> bytes:
            return b""

        def decode_body(self, body: bytes) -> c.Message:
            raise KeyError("surprise")

    out = c.FrameDecoder(Broken()).feed(b"\x02\x05\x00")
    assert len(out) == 1 and isinstance(out[0], FrameError)
    assert (out[0].reason, out[0].detail) == ("internal", "KeyError: 'surprise'")


def test_a_new_codec_reads_and_writes_every_message() -> None:
    """A codec made here, not at import: its own structs and masks, not a shared one's."""
    codec = c.FrameCodec(LAYOUT)
    decoder = c.FrameDecoder(codec)
    wire = c.encode_many(codec, SAMPLES)
    assert wire == c.encode_many(CODEC, SAMPLES)
    assert decoder.feed(wire) == SAMPLES
    state = SAMPLES[0]
    assert isinstance(state, c.State)
    arg, payload = codec.encode_payload(state)
    assert arg == state.flags and c.FrameCodec.for_robot(ROBOT).encode_payload(state) == (
        arg,
        payload,
    )
    assert body_of(state)[5:-2] == payload
    assert codec._decode_payload(c.MsgType.STATE, state.seq, arg, payload) == state


def test_fresh_bits_beyond_the_channels_are_never_sent_nor_read() -> None:
    codec = c.FrameCodec(LAYOUT)
    full = (1 << (8 * LAYOUT.mask_bytes)) - 1
    assert 8 * LAYOUT.mask_bytes > N_CH  # there are spare bits to test
    sent = c.State(1, c.BridgeFlags.NONE, 0, full, (1,) * N_B, (0,) * N_CH)
    body = c.cobs_decode(codec.encode(sent)[:-1])
    assert int.from_bytes(body[7 : 7 + LAYOUT.mask_bytes], "little") == (1 << N_CH) - 1
    spare = bytearray(body[:-2])
    spare[7 : 7 + LAYOUT.mask_bytes] = full.to_bytes(LAYOUT.mask_bytes, "little")
    got = c.FrameCodec(LAYOUT).decode_body(with_crc(bytes(spare)))
    assert isinstance(got, c.State) and got.fresh_mask == (1 << N_CH) - 1


def test_consecutive_states_that_differ_in_one_byte_each_decode_right() -> None:
    codec = c.FrameCodec(LAYOUT)
    base = c.State(1, c.BridgeFlags.NONE, 2, 3, (1,) * N_B, (0,) * N_CH)
    changes = [
        dict(raw_values=(0,) * (N_CH - 1) + (1,)),  # the byte before the CRC
        dict(raw_values=(0,) * (N_CH - 1) + (256,)),
        dict(ack_seq=3),
        dict(flags=c.BridgeFlags.ESTOP),
        dict(board_status=(2,) + (1,) * (N_B - 1)),
        dict(fresh_mask=4),
    ]
    for seq, change in enumerate(changes, 2):
        for msg in (
            dataclasses.replace(base, seq=seq),
            dataclasses.replace(base, seq=seq + 100, **change),
        ):
            assert codec.decode_body(c.cobs_decode(codec.encode(msg)[:-1])) == msg


def test_the_largest_frame_on_the_wire_is_read() -> None:
    """255 bytes between delimiters is the limit, not past it (an unknown type, for size)."""
    body = with_crc(bytes([1, 0x7F, 0, 0, 0]) + b"\x01" * 247)
    encoded = c.cobs_encode(body)
    assert len(body) == c.MAX_BODY_BYTES and len(encoded) == c.MAX_WIRE_BYTES - 1
    with pytest.raises(FrameError) as caught:
        CODEC.decode(encoded)
    assert caught.value.reason == "type"


def test_a_state_of_another_version_is_refused_with_the_version() -> None:
    codec = c.FrameCodec(LAYOUT)
    body = bytearray(body_of(SAMPLES[0])[:-2])
    codec.decode_body(with_crc(bytes(body)))  # the fast path now knows this frame
    body[0] = 3
    with pytest.raises(FrameError) as caught:
        codec.decode_body(with_crc(bytes(body)))
    assert (caught.value.reason, caught.value.detail) == (
        "version",
        "protocol version 3, expected 1",
    )


def test_encoding_a_bad_state_says_why() -> None:
    with pytest.raises(ValueError, match=r"^state frame does not match the layout$"):
        CODEC.encode(c.State(1, c.BridgeFlags.NONE, 0, 0, (1,) * N_B, (0,) * (N_CH + 1)))
    with pytest.raises(ValueError, match=r"^cannot encode State\(seq=70000, "):
        CODEC.encode(c.State(70000, c.BridgeFlags.NONE, 0, 0, (1,) * N_B, (0,) * N_CH))


def test_the_general_state_decode_masks_the_spare_bits_too() -> None:
    full = (1 << (8 * LAYOUT.mask_bytes)) - 1
    arg, payload = CODEC.encode_payload(
        c.State(1, c.BridgeFlags.NONE, 0, 0, (1,) * N_B, (0,) * N_CH)
    )
    spare = bytearray(payload)
    spare[2 : 2 + LAYOUT.mask_bytes] = full.to_bytes(LAYOUT.mask_bytes, "little")
    got = CODEC._decode_payload(c.MsgType.STATE, 1, arg, bytes(spare))  # white box
    assert isinstance(got, c.State) and got.fresh_mask == (1 << N_CH) - 1


def test_a_frame_of_the_largest_size_between_delimiters_is_not_oversize() -> None:
    body = with_crc(bytes([1, 0x7F, 0, 0, 0]) + b"\x01" * 247)
    out = c.FrameDecoder(CODEC).feed(c.cobs_encode(body) + b"\x00")
    assert len(out) == 1 and isinstance(out[0], FrameError) and out[0].reason == "type"


def test_after_an_oversize_frame_the_same_chunk_goes_on() -> None:
    hb = CODEC.encode(c.Heartbeat(6))
    out = c.FrameDecoder(CODEC).feed(b"\x01" * 300 + b"\x00" + hb + hb)
    assert [type(x).__name__ for x in out] == ["FrameError", "Heartbeat", "Heartbeat"]


def test_encode_payload_answers_for_every_message_and_refuses_the_rest() -> None:
    assert CODEC.encode_payload(c.Ack(3, 2, c.AckStatus.DUPLICATE)) == (0, bytes([2, 1]))
    assert CODEC.encode_payload(c.Heartbeat(3)) == (0, b"")
    with pytest.raises(ValueError, match=r"^cannot encode Setpoint\(seq=1, board=22"):
        CODEC.encode_payload(c.Setpoint(1, 22, 0, ControlMode.TORQUE, 40000))
    with pytest.raises(ValueError, match=r"^not a message: 'junk'$"):
        CODEC.encode_payload("junk")  # type: ignore[arg-type]


def test_a_body_of_a_state_s_length_but_another_type_is_not_a_state() -> None:
    size = len(body_of(SAMPLES[0]))
    for seq in (0x0082, 0x8200, 0x8282):
        body = with_crc(bytes([1, 0x7F]) + seq.to_bytes(2, "little") + bytes(size - 6))
        with pytest.raises(FrameError) as caught:
            c.FrameCodec(LAYOUT).decode_body(body)
        assert caught.value.reason == "type"
