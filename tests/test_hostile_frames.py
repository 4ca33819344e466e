"""Hostile bytes on both ends of the link, and a host written from docs/protocol.md alone.

Two kinds of tests:

- hostile input: bytes no frame should contain, damaged, truncated, oversize and
  misnumbered frames, frames of unknown types or versions, fed to the reference
  bridge (:class:`~pirate_bt.sim.bridge.SimBridge`) and to the host's session. Nothing
  may raise, each bad frame is counted exactly once, no damaged frame makes the
  bridge act or the host take a state, and the answers are the ones the page gives;
- an independent host: COBS, the CRC, the frames and the layout digest written here
  from the protocol page and the robot's YAML only (no ``pirate_bt.link`` code), which
  must handshake with and command the simulator over its bytes, and agree with the
  library's host byte for byte on sample frames.
"""

from __future__ import annotations

import random
import struct
from pathlib import Path

import pytest
from doc_protocol import (
    DOC_BOARDS,
    DOC_CHANNELS,
    DOC_DIGEST,
    DOC_MOTORS,
    DOC_SLOTS,
    DOC_TEXT,
    DocHost,
    doc_cobs_decode,
    doc_cobs_encode,
    doc_crc,
    doc_frame,
)
from session_wire import Wire, reply, state

from pirate_bt.clock import SimClock
from pirate_bt.errors import FrameError, InputError, LinkError, ProtocolMismatch
from pirate_bt.link import open_link
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BulkSetpoints,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
    State,
)
from pirate_bt.link.inbound import BAD_STATES_BEFORE_MISMATCH
from pirate_bt.link.requests import Outcome
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot import ControlMode, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import Half
from pirate_bt.sim import Simulator
from pirate_bt.sim.bridge_port import bridge_for

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)


# -- an independent host, from docs/protocol.md alone (tests/doc_protocol.py) --------------


def test_the_layout_digest_follows_from_the_page_and_the_yaml() -> None:
    assert (DOC_CHANNELS, DOC_MOTORS, DOC_BOARDS) == (28, 16, 9)
    assert DOC_DIGEST == 0x9B54EA48 == CODEC.layout.digest
    assert [(s.board, s.slot) for s in ROBOT.setpoint_slots()] == DOC_SLOTS


def test_the_crc_and_cobs_of_the_page() -> None:
    assert doc_crc(b"123456789") == 0x31C3
    run = bytes(range(1, 255))
    assert doc_cobs_encode(run) == b"\xff" + run  # no trailing 0x01 block
    assert doc_cobs_decode(b"\xff" + run + b"\x01") == run
    # with the trailing block the frame is 256 bytes before its delimiter: oversize
    [error] = FrameDecoder(CODEC).feed(b"\xff" + run + b"\x01\x00")
    assert isinstance(error, FrameError) and error.reason == "oversize"


def test_the_library_host_writes_the_page_s_bytes() -> None:
    bulk_modes = (None,) * 15 + (ControlMode.PWM,)
    samples = [
        (Hello(1, DOC_DIGEST, 2), doc_frame(0x01, 1, struct.pack("<IB", DOC_DIGEST, 2))),
        (
            Setpoint(0x1234, 22, 1, ControlMode.VELOCITY, -300),
            doc_frame(0x02, 0x1234, struct.pack("<BBh", 1, 3, -300), arg=22),
        ),
        (
            BulkSetpoints(7, bulk_modes, (0,) * 15 + (200,)),
            doc_frame(0x03, 7, b"\xff\x00\x00" * 15 + struct.pack("<Bh", 0, 200)),
        ),
        (Heartbeat(65535), doc_frame(0x04, 65535)),
        (EStop(256), doc_frame(0x05, 256)),
        (EStopReset(3), doc_frame(0x06, 3)),
        (CountersRequest(9), doc_frame(0x07, 9)),
    ]
    for msg, wire in samples:
        assert CODEC.encode(msg) == wire, msg
        assert CODEC.decode(wire[:-1]) == msg
    # the page's sizes on the wire
    assert len(doc_frame(0x04, 1)) == 9
    assert len(CODEC.encode(BulkSetpoints(1, (None,) * 16, (0,) * 16))) == 57
    assert len(doc_frame(0x02, 1, bytes(4), arg=22)) == 13  # an 11-byte body


def test_the_library_host_reads_the_page_s_bytes() -> None:
    flags = 0b1001  # ESTOP | NO_SESSION
    mask = (1 << 28) - 1 - 4  # channel 2 stale
    status = [1, 9, 1, 3, 1, 1, 5, 1, 8]  # board j in byte j/2, low nibble for even j
    status_bytes = bytes(
        status[j] | (status[j + 1] << 4 if j + 1 < 9 else 0) for j in (0, 2, 4, 6, 8)
    )
    values = tuple(range(-14, 14))
    payload = struct.pack("<H", 5) + mask.to_bytes(4, "little") + status_bytes
    payload += struct.pack("<28h", *values)
    wire = doc_frame(0x82, 0, payload, arg=flags)
    assert len(wire) == 76
    got = CODEC.decode(wire[:-1])
    assert got == State(0, BridgeFlags(flags), 5, mask, tuple(status), values)
    assert CODEC.decode(doc_frame(0x84, 77, bytes([2, 8]))[:-1]) == Nack(77, 2, NackCode(8))
    assert CODEC.decode(doc_frame(0x83, 1, bytes([6, 1]))[:-1]) == Ack(1, 6, AckStatus.DUPLICATE)


def _ack(frames: list[tuple[int, int, int, bytes]]) -> list[tuple[int, int, bytes]]:
    return [(kind, seq, payload) for kind, seq, _, payload in frames]


def test_a_host_from_the_page_handshakes_with_and_commands_the_simulator() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, seed=3) as sim:
        host = DocHost(sim)
        host.frames(0.05)
        assert host.states and host.states[-1]["flags"] == 0b1001  # booted latched, no session
        sim.write(b"\x00")  # flush, as before every HELLO
        host.send(0x01, 1, struct.pack("<IB", DOC_DIGEST, 2))
        [(kind, seq, arg, payload)] = host.frames()
        assert (kind, seq) == (0x81, 1)
        digest, n_ch, n_mo, wd_ms, firmware, minor, _boot, sessions = struct.unpack(
            "<IBBHHBHB", payload
        )
        assert (digest, n_ch, n_mo, wd_ms, minor, sessions) == (DOC_DIGEST, 28, 16, 250, 2, 1)
        assert 0x5000 <= firmware <= 0x5FFF and arg == 0b0001  # latched, session open
        host.send(0x06, 2)  # release the boot latch
        assert _ack(host.frames()) == [(0x83, 2, bytes([6, 0]))]
        drive = DOC_SLOTS.index((22, 1))
        host.send(0x02, 3, struct.pack("<BBh", 1, 3, 500), arg=22)  # 50 mm/s
        assert _ack(host.frames()) == [(0x83, 3, bytes([2, 0]))]
        entries = [(0xFF, 0)] * DOC_MOTORS
        entries[drive] = (3, 600)
        host.send(0x03, 4, b"".join(struct.pack("<Bh", m, v) for m, v in entries))
        answers = []
        for useq in range(1, 6):  # half a second, fed by a heartbeat every 100 ms
            host.send(0x04, useq)
            answers += _ack(host.frames(0.1))
        # a bulk is acknowledged by ack_seq only; each heartbeat by an ACK
        assert answers == [(0x83, useq, bytes([4, 0])) for useq in range(1, 6)]
        latest = host.states[-1]
        assert latest["ack_seq"] == 4 and latest["flags"] == 0
        board_index = sorted({b for b, _ in DOC_SLOTS}).index(22)
        assert latest["status"][board_index] == 1  # online, and its motors no longer off
        speed = latest["values"][
            DOC_TEXT.split("|")[0].split(";").index("22:bend_1_drive.velocity")
        ]
        assert speed > 0  # the wheel turns
        host.send(0x02, 4, struct.pack("<BBh", 1, 3, 0), arg=22)  # seq of the bulk: stale
        host.send(0x03, 4, b"".join(struct.pack("<Bh", m, v) for m, v in entries))  # duplicate
        host.send(0x05, 5)  # e-stop
        host.send(0x02, 6, struct.pack("<BBh", 1, 3, 500), arg=22)
        host.send(0x07, 6)  # counters (untracked seq)
        frames = host.frames()
        assert _ack(frames[:4]) == [
            (0x83, 4, bytes([2, 2])),
            (0x83, 4, bytes([3, 1])),
            (0x83, 5, bytes([5, 0])),
            (0x84, 6, bytes([2, 8])),
        ]
        kind, seq, _, payload = frames[4]
        rx, crc, framing, dups, trips = struct.unpack_from("<IIIII", payload)
        assert (kind, seq, len(payload)) == (0x85, 6, 20 + 13 * DOC_BOARDS)
        assert (rx, crc, framing, dups, trips) == (14, 0, 0, 2, 0)
        assert host.states[-1]["flags"] & 1 and all(s & 8 for s in host.states[-1]["status"])


# -- hostile bytes at the bridge --------------------------------------------------------------


def doc_reason(encoded: bytes) -> str | None:
    """What the page's checks (steps 1-2) make of the bytes before a delimiter.

    ``None`` for an intact frame, ``crc`` for a CRC mismatch, ``frame`` for the rest
    (``oversize``, ``cobs``, ``short``, ``version``).
    """
    if len(encoded) > 255:
        return "frame"
    try:
        body = doc_cobs_decode(encoded)
    except ValueError:
        return "frame"
    if len(body) < 7:
        return "frame"
    if doc_crc(body[:-2]) != int.from_bytes(body[-2:], "little"):
        return "crc"
    return None if body[0] == 1 else "frame"


Nacked = tuple[int, int, int]  # (seq, acked_type, error)


def _hostile_frames(rng: random.Random) -> list[tuple[bytes, str | Nacked | None]]:
    """Bad frames, each with what the bridge must make of it: a count (``crc``,
    ``frame``), a NACK, or nothing (lone delimiters, empty frames).

    No frame here may change what the bridge does. Each ends in its own delimiter.
    """
    good = doc_frame(0x02, 2, struct.pack("<BBh", 1, 3, 500), arg=22)  # would drive, if intact
    frames: list[tuple[bytes, str | Nacked | None]] = []
    for _ in range(400):
        pick = rng.randrange(10)
        seq = rng.randrange(65536)
        nack: Nacked | None = None
        if pick == 0:  # one byte of the body changed: the CRC catches every one-byte error
            body = bytearray(doc_cobs_decode(good[:-1]))
            body[rng.randrange(len(body))] ^= rng.randrange(1, 256)
            enc = doc_cobs_encode(bytes(body)) + b"\x00"
            assert doc_reason(enc[:-1]) == "crc"
        elif pick == 1:  # a good CRC, another major version
            version = rng.choice([0, 2, 255])
            enc = doc_frame(0x02, 2, struct.pack("<BBh", 1, 3, 500), arg=22, version=version)
        elif pick == 2:  # shorter than header + CRC
            short = bytes(rng.randrange(1, 256) for _ in range(rng.randrange(1, 7)))
            enc = doc_cobs_encode(short) + b"\x00"
        elif pick == 3:  # longer than 255 bytes before the delimiter, no zero inside
            enc = bytes(rng.randrange(1, 256) for _ in range(rng.randrange(256, 700))) + b"\x00"
        elif pick == 4:  # a COBS code pointing past the end
            tail = bytes(rng.randrange(1, 256) for _ in range(rng.randrange(0, 150)))
            enc = b"\xc8" + tail + b"\x00"
        elif pick == 5:  # lone delimiters and empty frames: nothing at all
            frames.append((b"\x00" * rng.randrange(1, 4), None))
            continue
        elif pick == 6:  # intact, but not a host -> bridge type: UNKNOWN_TYPE
            kind = rng.choice([0, 8, 0x7F, 0x81, 0x82, 0x83, 0x84, 0x85, 0x86, 0xFF])
            payload = bytes(rng.randrange(256) for _ in range(rng.randrange(0, 60)))
            enc, nack = doc_frame(kind, seq, payload), (seq, kind, 1)
        elif pick == 7:  # intact, a payload too long or too short for its type: BAD_LENGTH
            kind = rng.choice([1, 2, 3, 4, 5, 6, 7])
            size = {1: 5, 2: 4, 3: 48}.get(kind, 0) + rng.choice([-1, 1, 2])
            payload = bytes(rng.randrange(256) for _ in range(max(size, 1)))
            enc, nack = doc_frame(kind, seq, payload, arg=22), (seq, kind, 2)
        elif pick == 8:  # a HELLO for another layout or minor version: BAD_LAYOUT
            digest, minor = rng.choice([(DOC_DIGEST ^ 1, 2), (DOC_DIGEST, 0), (DOC_DIGEST, 3)])
            enc, nack = doc_frame(0x01, seq, struct.pack("<IB", digest, minor)), (seq, 1, 3)
        else:  # a frame cut short: the next one's bytes run into it
            enc = good[: rng.randrange(1, len(good) - 1)] + good
        frames.append((enc, nack or doc_reason(enc[:-1])))
        assert frames[-1][1] is not None
    noise = bytes(rng.randrange(1, 256) for _ in range(3000))  # random bytes, cut at zeros
    for part in noise.replace(bytes([rng.randrange(1, 256)]), b"\x00").split(b"\x00"):
        reason = doc_reason(part) if part else None
        if reason is not None:  # (a one-in-65536 intact frame is left out)
            frames.append((part + b"\x00", reason))
    rng.shuffle(frames)
    return frames


def _chunks(rng: random.Random, stream: bytes) -> list[bytes]:
    """``stream`` cut anywhere: single bytes, a few, many frames at once."""
    chunks, i = [], 0
    while i < len(stream):
        n = rng.choice([1, 1, 2, 7, 64, 300, 4000])
        chunks.append(stream[i : i + n])
        i += n
    return chunks


@pytest.mark.parametrize("seed", [1, 2])
def test_hostile_bytes_are_counted_answered_as_the_page_says_and_never_obeyed(seed: int) -> None:
    rng = random.Random(seed)
    bridge = bridge_for(ROBOT, record_applied=True)
    bridge.receive(doc_frame(0x01, 1, struct.pack("<IB", DOC_DIGEST, 2)))
    bridge.receive(doc_frame(0x06, 2))  # released: an intact setpoint would be applied
    bridge.read()
    frames = _hostile_frames(rng)
    for chunk in _chunks(rng, b"".join(enc for enc, _ in frames)):
        bridge.receive(chunk)
    assert bridge.applied == [(MsgType.ESTOP_RESET, 2)]
    assert bridge.commands_executed == 0
    nacks = [fate for _, fate in frames if isinstance(fate, tuple)]
    answers = [m for m in _decode_all(bridge.read()) if not isinstance(m, State)]
    assert [(m.seq, m.acked_type, int(m.error)) for m in answers if isinstance(m, Nack)] == nacks
    assert len(answers) == len(nacks)
    bridge.receive(doc_frame(0x07, 1))
    [counters] = [m for m in _decode_all(bridge.read()) if not isinstance(m, State)]
    fates = [fate for _, fate in frames]
    assert (counters.rx_frames, counters.crc_errors, counters.frame_errors) == (
        2 + len(nacks) + 1,
        fates.count("crc"),
        fates.count("frame"),
    )
    # and it still works: the next intact setpoint is applied
    bridge.receive(doc_frame(0x02, 3, struct.pack("<BBh", 1, 3, 500), arg=22))
    assert bridge.applied[-1] == (MsgType.SETPOINT, 3)


def _decode_all(data: bytes) -> list[object]:
    items = FrameDecoder(CODEC).feed(data)
    assert not any(isinstance(item, FrameError) for item in items), items
    return items  # type: ignore[return-value]


# -- hostile bytes at the host ----------------------------------------------------------------


def test_hostile_bytes_at_the_host_are_counted_once_each_and_never_taken_as_state() -> None:
    wire = Wire(hello=reply())
    wire.answer(state(10))
    wire.poll()
    kept = wire.session.latest_state()
    assert kept is not None
    good = CODEC.encode(state(11))
    payload = doc_cobs_decode(good[:-1])[5:-2]
    bad = [
        good[:-3] + bytes([good[-3] ^ 0x55]) + good[-2:],  # damaged
        doc_frame(0x82, 12, payload, version=2),  # another major version
        doc_frame(0x82, 12, payload[:-1]),  # a state one byte short
        doc_frame(0x82, 12, payload + b"\x01"),  # a state one byte long
        doc_frame(0x83, 1, bytes([4, 3])),  # ACK status 3 does not exist
        doc_frame(0x84, 1, bytes([4, 0])),  # NACK code 0 does not exist
        doc_frame(0x84, 1, bytes([4, 11])),  # nor 11
        doc_frame(0x83, 1, bytes([4])),  # an ACK cut short
        doc_frame(0x88, 12, payload),  # no such type
        doc_frame(0x02, 12, bytes(3)),  # a SETPOINT one byte short
        bytes(range(1, 256)) * 2 + b"\x00",  # far too long
        b"\x03\x01",  # then bytes left hanging ...
        b"\x00",  # ... ended here: a frame too short
        b"\x00\x00\x00",  # nothing
    ]
    stream = b"".join(bad)
    for i in range(0, len(stream), 3):  # split at every third byte
        wire.far.write(stream[i : i + 3])
        wire.poll()
    assert wire.session.crc_errors == 12  # the last two items end one frame; the rest, none
    assert wire.session.latest_state() == kept
    # many frames in one read: the newest state is kept, an old one dropped and counted
    wire.answer(*(state(s) for s in (11, 12, 13, 9)))
    wire.poll()
    latest = wire.session.latest_state()
    assert latest is not None and latest[0].seq == 13
    assert wire.session.duplicates == 1


def test_an_estop_answered_stale_is_a_failure_not_a_latch() -> None:
    wire = Wire(hello=reply())
    req = wire.session.estop()
    [msg] = wire.sent()
    wire.answer(Ack(msg.seq, MsgType.ESTOP, AckStatus.STALE))
    wire.poll()
    assert req.outcome is Outcome.STALE and req.ack_status is AckStatus.STALE
    assert not wire.session.stats().estopped
    assert wire.session.stats().stale == 1
    assert wire.session.take_failures() == [req]


def test_only_a_nack_of_the_hello_refuses_a_new_session() -> None:
    wire = Wire(hello=reply())
    wire.answer(state(1, flags=BridgeFlags.NO_SESSION))  # a bridge reset: a new HELLO
    wire.poll()
    [hello] = [m for m in wire.sent() if isinstance(m, Hello)]
    # a heartbeat's untracked seq may equal the HELLO's ordered seq: its answer is not the
    # bridge refusing the session
    wire.answer(Nack(hello.seq, MsgType.HEARTBEAT, NackCode.BAD_LENGTH))
    wire.poll()
    wire.session.ensure_alive()
    wire.answer(reply(hello.seq, boot_id=8))
    wire.poll()
    assert wire.session.sessions == 2
    wire.answer(state(1, flags=BridgeFlags.NO_SESSION))
    wire.poll()
    [hello] = [m for m in wire.sent() if isinstance(m, Hello)]
    wire.answer(Nack(hello.seq, MsgType.HELLO, NackCode.BAD_LAYOUT))
    with pytest.raises(ProtocolMismatch):
        wire.poll()


def test_a_refused_command_list_leaves_nothing_behind_for_the_next_send() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, seed=1) as sim:
        link: RobotLink = open_link(sim.url, ROBOT, clock)
        try:
            drive = MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)
            with pytest.raises(InputError, match="no torque mode"):
                link.send([drive, MotorCommand("bend_2_drive", ControlMode.TORQUE, 0.1)])
            link.send([MotorCommand("rear_leds", ControlMode.PWM, 0.5)])
            msg = link._last_bulk.msg if link._last_bulk else None
            assert isinstance(msg, BulkSetpoints)
            index = [s.motor.name for s in ROBOT.setpoint_slots()].index("bend_1_drive")
            assert msg.modes[index] is None  # the refused call's drive is not sent
        finally:
            link.close()


def test_the_page_s_layout_text_is_the_one_its_rules_give() -> None:
    page = (Path(__file__).resolve().parents[1] / "docs" / "protocol.md").read_text()
    block = page.split("text (one line, broken here at each `;` and at the `|`) is\n\n")[1]
    lines = block.split("\n\n")[0].splitlines()
    assert "".join(line.strip() for line in lines) == DOC_TEXT


def test_a_line_that_only_carries_damaged_frames_leaves_the_robot_stopped() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, seed=2) as sim:
        link = open_link(sim.url, ROBOT, clock)
        link.send([MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.6) for i in (3, 4)])
        link.send([MotorCommand(m.name, ControlMode.VELOCITY, 0.08) for m in ROBOT.drive_motors()])
        for _ in range(100):
            clock.advance(0.01)
            link.poll()
        assert sim.truth().velocity_mps > 0
        executed, received = sim.counters().commands_executed, sim.bridge.rx_frames
        # From now on the host's frames all arrive damaged: each heartbeat and setpoint
        # with one byte changed (the CRC catches it), or cut short.
        rng = random.Random(4)
        intact = [
            doc_frame(0x04, 900),
            doc_frame(0x03, 900, struct.pack("<Bh", 3, 800) * DOC_MOTORS),
            doc_frame(0x06, 901),
        ]
        for i in range(100):
            body = bytearray(doc_cobs_decode(intact[i % 3][:-1]))
            body[rng.randrange(len(body))] ^= rng.randrange(1, 256)
            sim.write(doc_cobs_encode(bytes(body)) + b"\x00")
            sim.write(intact[i % 3][: rng.randrange(1, 8)] + b"\x00")
            clock.advance(0.01)
        truth = sim.truth()
        assert sim.counters().watchdog_trips == 1
        assert truth.velocity_mps == 0.0
        assert truth.halves[Half.REAR].clamped  # clamps held
        assert sim.counters().commands_executed == executed
        assert sim.bridge.rx_frames == received  # none of them was taken as a frame
        link.session.close()


def doc_host_rejects(encoded: bytes) -> bool:
    """Whether a host drops the bytes before a delimiter as a bad frame (the page's
    Bad frames table: framing, CRC and version, then type, length and code tables)."""
    if doc_reason(encoded) is not None:
        return True
    body = doc_cobs_decode(encoded)
    kind, payload = body[1], body[5:-2]
    state_size = 2 + (DOC_CHANNELS + 7) // 8 + (DOC_BOARDS + 1) // 2 + 2 * DOC_CHANNELS
    sizes = {1: 5, 2: 4, 3: 3 * DOC_MOTORS, 4: 0, 5: 0, 6: 0, 7: 0, 0x81: 14, 0x82: state_size}
    sizes.update({0x83: 2, 0x84: 2, 0x86: 0})
    if kind == 0x85:  # one entry for each board of the layout
        return len(payload) != 20 + 13 * DOC_BOARDS
    if kind not in sizes:
        return True
    if len(payload) != sizes[kind]:
        return True
    if kind == 0x02:
        return payload[1] > 3
    if kind == 0x03:
        return any(m > 3 and m != 0xFF for m in payload[0::3])
    if kind == 0x83:
        return payload[1] > 2
    if kind == 0x84:
        return not 1 <= payload[1] <= 10
    return False


def doc_state_length(encoded: bytes) -> int | None:
    """The payload length of a STATE that passes the page's framing, CRC and version
    checks (``None`` for any other frame)."""
    if doc_reason(encoded) is not None:
        return None
    body = doc_cobs_decode(encoded)
    return len(body) - 7 if body[1] == 0x82 else None


def test_the_host_counts_exactly_the_frames_the_page_calls_bad() -> None:
    rng = random.Random(11)
    wire = Wire(hello=reply())
    kinds = [0x81, 0x82, 0x82, 0x83, 0x84, 0x85, 0x86, 1, 2, 3, 4, 7, 0, 0x87, 0xFF]
    state_size = 2 + 4 + 5 + 2 * DOC_CHANNELS
    stream, bad = b"", 0
    other_layout = 0  # STATEs of another length since the last good one (the page's run)

    def run_after(parts: list[bytes], run: int) -> int:
        for part in parts:
            length = doc_state_length(part) if part else None
            if length is not None:
                run = 0 if length == state_size else run + 1
        return run

    for i in range(600):
        kind = rng.choice(kinds)
        size = {0x82: state_size, 0x83: 2, 0x84: 2, 0x81: 14, 0x85: 20 + 13 * 9, 3: 48}.get(kind, 4)
        size = max(0, size + rng.choice([0, 0, 0, -1, 1]))
        payload = bytearray(rng.randrange(256) for _ in range(size))
        if kind in (0x83, 0x84) and size == 2:
            payload[0] = rng.choice([2, 3, 5, 6])  # never a HELLO's answer
            payload[1] = rng.choice([0, 1, 2, 3, 10, 11, 255])
        arg = rng.randrange(256) & ~int(BridgeFlags.NO_SESSION)  # no bridge reset
        enc = doc_frame(kind, i, bytes(payload), arg=arg, version=rng.choice([1] * 9 + [2]))
        if rng.random() < 0.1:  # damaged on the way
            j = rng.randrange(len(enc) - 1)
            enc = enc[:j] + bytes([enc[j] ^ rng.randrange(1, 256) or 1]) + enc[j + 1 :]
        parts = enc.split(b"\x00")[:-1]
        if run_after(parts, other_layout) >= BAD_STATES_BEFORE_MISMATCH:
            # that many in a row is a bridge of another layout, which ends the session
            # (tests/test_link_leftovers.py): a good STATE comes between here
            enc = doc_frame(0x82, i, bytes(state_size), arg=arg)
            parts = enc.split(b"\x00")[:-1]
        other_layout = run_after(parts, other_layout)
        for part in parts:
            bad += bool(part) and doc_host_rejects(part)
        stream += enc
    for chunk in _chunks(rng, stream):
        wire.far.write(chunk)
        wire.poll()
    assert bad > 100
    assert wire.session.crc_errors == bad
    wire.session.ensure_alive()


def test_a_request_that_cannot_be_encoded_is_refused_at_once_and_never_wedges_poll() -> None:
    wire = Wire(hello=reply())
    first = wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, 5)  # in flight
    with pytest.raises(ValueError, match="cannot encode"):
        wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, 70_000)  # not an int16
    with pytest.raises(ValueError, match="cannot encode"):
        wire.session.send_setpoint(300, 1, ControlMode.VELOCITY, 5)  # not a byte
    [sent] = wire.sent()
    wire.answer(Ack(sent.seq, MsgType.SETPOINT))
    for _ in range(8):  # answers and retries come and go: poll never meets the bad ones
        wire.poll(0.0625)
    assert first.outcome is Outcome.ACKED
    assert wire.session.take_failures() == []
    bulk = wire.session.send_bulk([ControlMode.PWM] * 16, [10] * 16)
    with pytest.raises(ValueError, match="cannot encode"):
        wire.session.send_bulk([ControlMode.PWM] * 16, [10] * 15 + [1 << 20])
    assert not bulk.done  # the good bulk in flight was not superseded by the bad one
    wire.answer(state(20, ack_seq=bulk.seq))
    wire.poll()
    assert bulk.outcome is Outcome.ACKED


def test_a_closed_session_queues_no_request_of_any_kind() -> None:
    wire = Wire(hello=reply())
    wire.session.close()
    for make in (
        lambda: wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, 0),
        lambda: wire.session.send_bulk([None] * 16, [0] * 16),
        wire.session.estop_reset,
    ):
        with pytest.raises(LinkError, match=r"^session closed$"):
            make()
    assert wire.sent(heartbeats=True) == []


def test_a_link_loss_counts_the_frames_it_swallows_not_the_delimiters() -> None:
    bridge = bridge_for(ROBOT)
    beat = doc_frame(0x04, 1)
    bridge.receive(beat[:4])  # a frame under way when the line goes
    bridge.schedule([FaultSpec(kind="link_loss", at=0.0, duration=1.0)])
    bridge.advance_to(0.01)
    bridge.receive(beat[4:])  # its end is lost: one frame
    bridge.receive(b"\x00\x00" + beat + b"\x00\x00\x00")  # flushes, one frame, empty ones
    bridge.receive(beat[:5])
    bridge.receive(beat[5:-1])
    bridge.receive(b"\x00")  # a frame that came in three pieces: one
    assert bridge.frames_dropped == 3
    bridge.receive(beat[:3])  # cut by the end of the loss: neither dropped nor taken
    bridge.advance_to(1.5)
    bridge.receive(b"\x00" + beat)
    assert bridge.frames_dropped == 3
    assert (bridge.rx_frames, bridge.crc_errors, bridge.frame_errors) == (1, 0, 0)
