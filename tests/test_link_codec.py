"""The frame codec: shared vectors, round trips of every message type, and fuzzing."""

from __future__ import annotations

import dataclasses
import json
import random
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pirate_bt.errors import FrameError
from pirate_bt.link import codec as c
from pirate_bt.link.vectors import dumps, message_from_json, message_to_json
from pirate_bt.robot import ControlMode, load_robot

VECTORS = Path(__file__).parent / "data" / "link_vectors.json"
ROBOT = load_robot()
LAYOUT = c.WireLayout.from_robot(ROBOT)
CODEC = c.FrameCodec(LAYOUT)


def test_crc_is_xmodem() -> None:
    assert c.crc16(b"123456789") == 0x31C3


def test_vectors_file_is_current() -> None:
    """The committed JSON is what ``python -m pirate_bt.link.vectors`` writes today."""
    assert VECTORS.read_text() == dumps(ROBOT)


def test_vectors_decode_and_reencode() -> None:
    data = json.loads(VECTORS.read_text())
    assert data["protocol_version"] == c.PROTOCOL_VERSION
    assert data["protocol_minor"] == c.PROTOCOL_MINOR
    assert data["layout"]["digest"] == LAYOUT.digest == 0x9B54EA48  # docs/protocol.md
    assert data["layout"]["n_channels"] == LAYOUT.n_channels
    for case in data["good"]:
        wire = bytes.fromhex(case["hex"])
        msg = message_from_json(case["message"])
        assert CODEC.encode(msg) == wire, case["name"]
        assert c.FrameDecoder(CODEC).feed(wire) == [msg], case["name"]
        assert message_to_json(msg) == case["message"]
    for case in data["bad"]:
        out = c.FrameDecoder(CODEC).feed(bytes.fromhex(case["hex"]))
        assert len(out) == 1, case["name"]
        assert isinstance(out[0], FrameError), case["name"]
        assert out[0].reason == case["reason"], case["name"]


def test_vectors_cover_every_type_status_and_code() -> None:
    data = json.loads(VECTORS.read_text())
    messages = [case["message"] for case in data["good"]]
    assert {m["type"] for m in messages} == {t.name for t in c.MsgType}
    assert {m["status"] for m in messages if m["type"] == "ACK"} == {int(s) for s in c.AckStatus}
    assert {m["error"] for m in messages if m["type"] == "NACK"} == {int(e) for e in c.NackCode}
    reasons = {case["reason"] for case in data["bad"]}
    assert reasons == {"oversize", "cobs", "short", "crc", "version", "type", "length", "value"}
    names = {s["name"] for s in data["sequences"]}
    assert {
        "handshake",
        "duplicates",
        "wrap",
        "estop_and_reset",
        "watchdog_trip_and_recovery",
        "mid_session_hello",
        "bridge_reset",
        "nacks",
    } <= names


def test_cobs_vectors() -> None:
    data = json.loads(VECTORS.read_text())
    for case in data["cobs"]:
        body, encoded = bytes.fromhex(case["body"]), bytes.fromhex(case["encoded"])
        assert c.cobs_decode(encoded) == body, case["name"]
        assert 0 not in encoded
        if not case.get("decode_only"):
            assert c.cobs_encode(body) == encoded, case["name"]
    by_name = {case["name"]: case for case in data["cobs"]}
    block = bytes.fromhex(by_name["non_zero_254"]["encoded"])
    assert block[0] == 0xFF and len(block) == 255  # one full block, no trailing 0x01


def test_stream_vectors() -> None:
    data = json.loads(VECTORS.read_text())
    for case in data["streams"]:
        decoder = c.FrameDecoder(CODEC)
        out: list[c.Message | FrameError] = []
        for chunk in case["chunks"]:
            out += decoder.feed(bytes.fromhex(chunk))
        got = [
            {"error": item.reason} if isinstance(item, FrameError) else message_to_json(item)
            for item in out
        ]
        assert got == case["expect"], case["name"]


def test_state_frame_fits_the_slot() -> None:
    state = LAYOUT.wire_bytes(LAYOUT.state_payload_bytes)
    bulk = LAYOUT.wire_bytes(LAYOUT.bulk_payload_bytes)
    slot_bytes = ROBOT.bridge.baud / 10 * ROBOT.bridge.state_period
    assert state == 76 and bulk == 57
    assert max(state, bulk) / slot_bytes <= 0.70


# --- round trips ----------------------------------------------------------------------------

seqs = st.integers(0, 0xFFFF)
u8 = st.integers(0, 0xFF)
u32 = st.integers(0, 0xFFFFFFFF)
i16 = st.integers(-32768, 32767)
modes = st.sampled_from(list(ControlMode))
n_ch, n_m, n_b = LAYOUT.n_channels, LAYOUT.n_motors, LAYOUT.n_boards

messages = st.one_of(
    st.builds(c.Hello, seqs, u32, u8),
    st.builds(c.Setpoint, seqs, st.integers(1, 254), st.integers(0, 1), modes, i16),
    st.builds(
        c.BulkSetpoints,
        seqs,
        st.tuples(*[st.one_of(st.none(), modes)] * n_m),
        st.tuples(*[i16] * n_m),
    ),
    st.builds(c.Heartbeat, seqs),
    st.builds(c.EStop, seqs),
    st.builds(c.EStopReset, seqs),
    st.builds(c.CountersRequest, seqs),
    st.builds(
        c.HelloReply,
        seqs,
        u32,
        u8,
        u8,
        st.integers(0, 0xFFFF),
        st.integers(0, 0xFFFF),
        u8,
        st.integers(0, 0xFFFF),
        u8,
        st.builds(c.BridgeFlags, st.integers(0, 15)),
    ),
    st.builds(
        c.State,
        seqs,
        st.builds(c.BridgeFlags, st.integers(0, 15)),
        seqs,
        st.integers(0, (1 << n_ch) - 1),
        st.tuples(*[st.integers(0, 15)] * n_b),
        st.tuples(*[i16] * n_ch),
    ),
    st.builds(c.Ack, seqs, u8, st.sampled_from(list(c.AckStatus))),
    st.builds(c.Nack, seqs, u8, st.sampled_from(list(c.NackCode))),
    st.builds(
        c.Counters,
        seqs,
        u32,
        u32,
        u32,
        u32,
        u32,
        # one entry per board of the layout: another count is a bad frame
        st.lists(st.builds(c.BoardCounters, u8, u32, u32, u32), min_size=n_b, max_size=n_b).map(
            tuple
        ),
    ),
    st.builds(c.BridgeHeartbeat, seqs, st.builds(c.BridgeFlags, st.integers(0, 15))),
)


@given(st.lists(messages, min_size=1, max_size=5), st.integers(1, 64))
def test_round_trip_in_chunks(msgs: list[c.Message], chunk: int) -> None:
    wire = b"".join(CODEC.encode(m) for m in msgs)
    assert wire.count(0) == len(msgs)
    assert all(len(CODEC.encode(m)) <= c.MAX_WIRE_BYTES for m in msgs)
    decoder = c.FrameDecoder(CODEC)
    out: list[c.Message | FrameError] = []
    for i in range(0, len(wire), chunk):
        out += decoder.feed(wire[i : i + chunk])
    assert out == msgs


@given(st.binary(max_size=600))
def test_cobs_round_trip(data: bytes) -> None:
    if data:
        encoded = c.cobs_encode(data)
        assert 0 not in encoded
        assert c.cobs_decode(encoded) == data


def test_encode_refuses_out_of_range_fields() -> None:
    with pytest.raises(ValueError):
        CODEC.encode(c.Setpoint(1, 22, 0, ControlMode.TORQUE, 40000))
    with pytest.raises(ValueError):
        CODEC.encode(c.BulkSetpoints(1, (None,), (0,)))
    with pytest.raises(ValueError):
        CODEC.encode(c.Heartbeat(70000))


def test_seq_newer_wraps() -> None:
    assert c.seq_newer(1, 0) and c.seq_newer(0, 0xFFFF) and not c.seq_newer(5, 5)
    assert not c.seq_newer(0, 1) and not c.seq_newer(0x8000, 0)


# --- fuzzing --------------------------------------------------------------------------------


@given(st.binary(max_size=2000))
def test_random_bytes_only_frame_errors(data: bytes) -> None:
    for item in c.FrameDecoder(CODEC).feed(data):
        if isinstance(item, FrameError):
            assert item.reason != "internal"


@given(messages, st.data())
def test_mutated_frames_are_never_accepted_wrongly(msg: c.Message, data: st.DataObject) -> None:
    wire = bytearray(CODEC.encode(msg))
    n_flips = data.draw(st.integers(1, 3))
    for _ in range(n_flips):
        pos = data.draw(st.integers(0, len(wire) - 2))
        wire[pos] ^= data.draw(st.integers(1, 255))
    out = c.FrameDecoder(CODEC).feed(bytes(wire) + b"\x00")
    for item in out:
        if isinstance(item, FrameError):
            assert item.reason != "internal"
        else:
            # CRC-16 detects every error burst up to 16 bits; with at most 3 changed bytes
            # an accepted frame must be the original one.
            assert item == msg


def test_mutation_soak_seeded() -> None:
    rng = random.Random(1234)
    frames = [
        CODEC.encode(c.State(i, c.BridgeFlags.NONE, i, (1 << n_ch) - 1, (1,) * n_b, (i,) * n_ch))
        for i in range(50)
    ] + [CODEC.encode(c.Ack(i, 2)) for i in range(50)]
    accepted_bad = 0
    for _ in range(3000):
        wire = bytearray(rng.choice(frames))
        op = rng.randrange(4)
        if op == 0:
            wire[rng.randrange(len(wire))] = rng.randrange(256)
        elif op == 1:
            del wire[rng.randrange(len(wire))]
        elif op == 2:
            wire.insert(rng.randrange(len(wire)), rng.randrange(256))
        else:
            start = rng.randrange(len(wire))
            wire[start : start + 3] = bytes(rng.randrange(256) for _ in range(3))
        for item in c.FrameDecoder(CODEC).feed(bytes(wire)):
            if isinstance(item, FrameError):
                assert item.reason != "internal"
            elif CODEC.encode(item) not in frames:
                accepted_bad += 1
    # A random corruption slips past a 16-bit CRC with probability ~1/65536 per frame, so
    # none of these 3000 may; an 8-bit check (the CRC's low byte alone) lets one through.
    assert accepted_bad == 0


def test_oversize_then_resync() -> None:
    decoder = c.FrameDecoder(CODEC)
    out = decoder.feed(b"\x01" * 300)
    assert [e.reason for e in out if isinstance(e, FrameError)] == ["oversize"]
    good = c.Heartbeat(3)
    assert decoder.feed(b"\x01\x00" + CODEC.encode(good)) == [good]


# --- fast paths (STATE frame, COBS) agree with the general ones -------------------------------


def _reference_cobs_encode(data: bytes) -> bytes:
    """COBS by the textbook byte loop, to check the split-based encoder against."""
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
    if block or not data or data[-1] == 0 or len(data) % 254:
        out += bytes((len(block) + 1,)) + block
    return bytes(out)


@given(st.binary(min_size=1, max_size=600))
def test_cobs_matches_the_byte_loop(data: bytes) -> None:
    expected = _reference_cobs_encode(data)
    assert c.cobs_decode(expected) == data
    if len(data) < 254:  # every frame body; longer runs may end in another valid form
        assert c.cobs_encode(data) == expected


def test_cobs_decode_long_runs_and_bad_codes() -> None:
    for data in (b"\x01" * 253, b"\x01" * 254, b"\x01" * 255, b"\x01" * 254 + b"\x00\x02"):
        assert c.cobs_decode(c.cobs_encode(data)) == data
    with pytest.raises(FrameError, match="runs past the end"):
        c.cobs_decode(b"\x05\x01\x02")
    with pytest.raises(FrameError, match="runs past the end"):
        c.cobs_decode(b"\x02\x01\x09")
    with pytest.raises(FrameError, match="zero byte"):
        c.cobs_decode(b"\x02\x00")


states = st.builds(
    c.State,
    seqs,
    st.builds(c.BridgeFlags, st.integers(0, 15)),
    seqs,
    st.integers(0, (1 << n_ch) - 1),
    st.tuples(*[st.integers(0, 15)] * n_b),
    st.tuples(*[i16] * n_ch),
)


@given(states)
def test_state_fast_path_matches_general_decode(msg: c.State) -> None:
    body = c.cobs_decode(CODEC.encode(msg)[:-1])
    arg, payload = CODEC.encode_payload(msg)
    header = c._HEADER.pack(c.PROTOCOL_VERSION, c.MsgType.STATE, msg.seq, arg)
    assert body[:-2] == header + payload  # encode: one pack == header + payload packs
    general = CODEC._decode_payload(c.MsgType.STATE, msg.seq, arg, payload)
    fast = CODEC.decode_body(body)
    assert type(fast) is c.State and fast == general == msg
    assert hash(fast) == hash(msg) and repr(fast) == repr(msg)
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.seq = 1  # type: ignore[misc]


def test_state_board_status_cache_follows_changes() -> None:
    decoder = c.FrameDecoder(CODEC)
    for status in [(1,) * n_b, (2,) * n_b, (1,) * n_b, tuple(range(n_b))] * 2:
        msg = c.State(9, c.BridgeFlags.ESTOP, 3, 5, status, (7,) * n_ch)
        assert decoder.feed(CODEC.encode(msg)) == [msg]
    # a tuple that was encoded before is still checked the first time it is invalid
    with pytest.raises(ValueError, match="nibble"):
        CODEC.encode(c.State(9, c.BridgeFlags.NONE, 3, 5, (16,) * n_b, (7,) * n_ch))
    with pytest.raises(ValueError, match="layout"):
        CODEC.encode(c.State(9, c.BridgeFlags.NONE, 3, 5, (1,) * n_b, (7,) * (n_ch - 1)))
    with pytest.raises(ValueError):
        CODEC.encode(c.State(9, c.BridgeFlags.NONE, 3, 5, (1,) * n_b, (40000,) * n_ch))


def test_state_fast_path_keeps_error_order() -> None:
    msg = c.State(9, c.BridgeFlags.NONE, 3, 5, (1,) * n_b, (7,) * n_ch)
    body = bytearray(c.cobs_decode(CODEC.encode(msg)[:-1]))
    bad_crc = bytes(body[:-1]) + bytes((body[-1] ^ 1,))
    body[0] = c.PROTOCOL_VERSION + 1
    body[-2:] = c._CRC.pack(c.crc16(bytes(body[:-2])))
    for wire, reason in ((bad_crc, "crc"), (bytes(body), "version")):
        out = c.FrameDecoder(CODEC).feed(c.cobs_encode(wire) + b"\x00")
        assert len(out) == 1 and isinstance(out[0], FrameError) and out[0].reason == reason


def test_iter_feed_matches_feed() -> None:
    msgs: list[c.Message] = [
        c.Heartbeat(1),
        c.State(2, c.BridgeFlags.NONE, 1, 3, (1,) * n_b, (4,) * n_ch),
    ]
    wire = c.encode_many(CODEC, msgs) + b"\x00\x07garbage"
    assert list(c.FrameDecoder(CODEC).iter_feed(wire)) == c.FrameDecoder(CODEC).feed(wire)
    assert list(c.FrameDecoder(CODEC).iter_feed(b"")) == []


def test_layout_digest_covers_roles_modes_and_ranges() -> None:
    from pirate_bt.link.layout import StopRole, digest_of, layout_text, stop_role

    text = layout_text(ROBOT)
    assert digest_of(text) == ROBOT.layout_digest() == LAYOUT.digest
    assert "22:1:drive:pwm=-255..255,velocity=-1200..1200" in text.split("|")[1].split(";")
    roles = {s.motor.name: stop_role(s.motor) for s in ROBOT.setpoint_slots()}
    assert roles["bend_1_joint"] is StopRole.BEND and roles["rotate"] is StopRole.ROTATE
    assert roles["bend_1_drive"] is StopRole.DRIVE and roles["front_leds"] is StopRole.OTHER
