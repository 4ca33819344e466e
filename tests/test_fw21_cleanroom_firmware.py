"""Probe 21: the clean-room peer of the wire protocol, as a host, against the bridge firmware.

``tests/cleanroom_peer.py`` was written from docs/protocol.md alone; probe 20 ran it
against the simulated bridge only. Here it talks to the firmware's own C
(``firmware/piratebay/``, built for this machine by ``tests/firmware_host.py``, the
``firmware-host`` bridge of the conformance suite, in virtual time at the line's baud
rate) with the bytes no frame should contain: bad frames of every kind, CRC-valid frames
of every type and of every wrong length, setpoints out of every range, a line of
garbage, a frame cut mid-way and then silence, a second host's session over an open one,
an e-stop whose CRC is damaged. What the boards are told is read off the board bus
(every ``EXCHANGE`` and ``STOP`` the bridge sent), so "never drives a motor on a bad
frame" and "motors stopped when the host goes silent" are checked where a motor would
feel them, not in the bridge's variables.
"""

from __future__ import annotations

import ctypes
import random
import struct
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from cleanroom_peer import (
    ACK,
    APPLIED,
    BAD_LAYOUT,
    BAD_LENGTH,
    BAD_MODE,
    BAD_SLOT,
    BRIDGE_HEARTBEAT,
    BULK,
    COUNTERS,
    COUNTERS_REQUEST,
    DUPLICATE,
    ESTOP,
    ESTOP_LATCHED,
    ESTOP_RESET,
    F_ESTOP,
    F_NO_SESSION,
    F_WATCHDOG,
    HEARTBEAT,
    HELLO,
    HELLO_REPLY,
    KEEP,
    MODE_CODES,
    NACK,
    NOT_READY,
    OUT_OF_RANGE,
    SETPOINT,
    STALE,
    STATE,
    UNKNOWN_TYPE,
    Decoder,
    Frame,
    Layout,
    bulk,
    cobs_encode,
    crc16,
    frame,
    hello,
    layout_of,
    parse_hello_reply,
)
from conformance.simavr_bridge import SimavrBridge
from firmware_host import FirmwareHostBridge, build_host_library
from firmware_sim_support import missing_toolchain

from pirate_bt.robot import load_robot
from pirate_bt.robot.description import RobotDescription

ROBOT: RobotDescription = load_robot()
LAYOUT: Layout = layout_of(ROBOT)
EXCHANGE, STOP = 0x01, 0x02
PWM, VELOCITY = MODE_CODES["pwm"], MODE_CODES["velocity"]
WATCHDOG_S = ROBOT.bridge.watchdog
PERIOD_S = ROBOT.bridge.state_period


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_host_library(tmp_path_factory.mktemp("fw21-host"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware cannot be built for the host")
        raise


class FirmwarePeer:
    """The firmware in virtual time, reached by the clean-room peer's bytes only; the
    board bus read back as what each motor was last told."""

    def __init__(self, library: Path, workdir: Path) -> None:
        self.bridge: FirmwareHostBridge | SimavrBridge = FirmwareHostBridge(ROBOT, library, workdir)
        self._setup()

    def _setup(self) -> None:
        self.decoder = Decoder()
        self.states: list[Frame] = []
        self.errors: list[str] = []
        # (board, slot) -> (command, mode, raw) last sent on the bus; None: never
        self.told: dict[tuple[int, int], tuple[int, int, int]] = {}
        self.slots = {board.id: sorted(m.slot for m in board.motors) for board in ROBOT.boards}

    def step(self, data: bytes = b"", dt: float = 0.02) -> list[Frame]:
        """Write ``data``, let ``dt`` pass; the answers (STATEs and heartbeats kept aside)."""
        if data:
            self.bridge.write(data)
        answers = []
        for item in self.decoder.feed(self.bridge.read(dt)):
            if isinstance(item, str):
                self.errors.append(item)
            elif item.kind in (STATE, BRIDGE_HEARTBEAT):
                self.states.append(item)
            else:
                answers.append(item)
        self._read_bus()
        return answers

    def one(self, data: bytes) -> Frame:
        """The one answer to ``data``: within 20 ms, or up to 60 ms later (a COUNTERS
        reply behind a STATE on the line takes 20 ms)."""
        answers = self.step(data)
        for _ in range(6):
            if answers:
                break
            answers = self.step(dt=0.01)
        assert len(answers) == 1, answers
        return answers[0]

    def session(self, seq: int = 1) -> None:
        assert self.one(hello(seq, LAYOUT)).kind == HELLO_REPLY
        released = self.one(frame(ESTOP_RESET, seq + 1))
        assert released.payload == bytes([ESTOP_RESET, APPLIED])

    def counters(self, seq: int = 7777) -> tuple[int, ...]:
        reply = self.one(frame(COUNTERS_REQUEST, seq))
        assert reply.kind == COUNTERS
        return struct.unpack_from("<5I", reply.payload)

    def flags(self) -> int:
        self.step(dt=PERIOD_S + 0.001)
        return self.states[-1].arg

    def _read_bus(self) -> None:
        assert isinstance(self.bridge, FirmwareHostBridge)
        buf = ctypes.create_string_buffer(1 << 16)
        n = self.bridge._lib.fw_bus_log(buf, len(buf))
        raw, i = buf.raw[:n], 0
        while i < len(raw):
            size, body = raw[i], raw[i + 1 : i + 1 + raw[i]]
            i += 1 + size
            addr, cmd, payload = body[0], body[1], body[2:-2]
            if cmd not in (EXCHANGE, STOP):
                continue
            for k, slot in enumerate(self.slots.get(addr, [])):
                mode, value = struct.unpack_from("<Bh", payload, 3 * k)
                if mode != KEEP:
                    self.told[(addr, slot)] = (cmd, mode, value)

    def drives(self) -> dict[tuple[int, int], tuple[int, int] | None]:
        """What every drive motor was last told on the bus: (mode, raw), None: never."""
        out: dict[tuple[int, int], tuple[int, int] | None] = {}
        for board, slot, role, _ in LAYOUT.motors:
            if role == "drive":
                told = self.told.get((board, slot))
                out[(board, slot)] = None if told is None else told[1:]
        return out

    def close(self) -> None:
        self.bridge.close()


class SimavrPeer(FirmwarePeer):
    """The AVR build in simavr behind its pty (the conformance suite's firmware-simavr,
    its MCU held between reads), with the Python boards on its bus: what each motor was
    last told is what its board applied."""

    def __init__(self) -> None:
        self.bridge = SimavrBridge(ROBOT)
        self._setup()

    def _read_bus(self) -> None:
        assert isinstance(self.bridge, SimavrBridge)
        boards = self.bridge._bridge.boards
        for board, slot, _, _ in LAYOUT.motors:
            applied = boards.motor_state(board, slot)
            if applied is not None:
                self.told[(board, slot)] = (0, *applied)


@pytest.fixture
def peer(library: Path, tmp_path: Path) -> Iterator[FirmwarePeer]:
    under_test = FirmwarePeer(library, tmp_path)
    try:
        yield under_test
    finally:
        under_test.close()


@pytest.fixture(params=["firmware-host", "firmware-simavr"])
def any_peer(
    request: pytest.FixtureRequest, library: Path, tmp_path: Path
) -> Iterator[FirmwarePeer]:
    """The host build, and the AVR build in simavr (its USARTs, interrupts and rings)."""
    if request.param == "firmware-simavr":
        if (why := missing_toolchain()) is not None:
            pytest.skip(f"simavr: {why}")
        under_test: FirmwarePeer = SimavrPeer()
    else:
        under_test = FirmwarePeer(library, tmp_path)
    try:
        yield under_test
    finally:
        under_test.close()


def drive_entries(raw: int) -> list[tuple[int, int]]:
    return [(VELOCITY, raw) if role == "drive" else (KEEP, 0) for _, _, role, _ in LAYOUT.motors]


def settle(peer: FirmwarePeer, done: Callable[[], bool], limit_s: float = 1.0) -> list[Frame]:
    """Let time pass until ``done()`` (at most ``limit_s``: only a bug waits that long);
    the answers heard meanwhile. Two state periods at least: a setpoint reaches its board
    at the next poll."""
    heard = peer.step(dt=2 * PERIOD_S)
    waited = 2 * PERIOD_S
    while not done() and waited < limit_s:
        heard += peer.step(dt=PERIOD_S)
        waited += PERIOD_S
    return heard


def running(peer: FirmwarePeer, raw: int = 400, seq: int = 3) -> None:
    """A session with every drive told velocity ``raw`` on the bus."""
    peer.session()
    assert peer.step(bulk(seq, drive_entries(raw))) == []
    heard = settle(peer, lambda: set(peer.drives().values()) == {(VELOCITY, raw)})
    assert set(peer.drives().values()) == {(VELOCITY, raw)}, (peer.drives(), heard)


def braked(peer: FirmwarePeer) -> bool:
    """Every drive told to stop: velocity 0, or pwm 0 (a STOP's brake)."""
    return set(peer.drives().values()) <= {(VELOCITY, 0), (PWM, 0)}


def test_the_firmware_speaks_the_pages_digest_crc_and_hello_reply(any_peer: FirmwarePeer) -> None:
    peer = any_peer
    assert crc16(b"123456789") == 0x31C3
    peer.step(dt=0.05)
    # boots latched, no session, STATE from seq 1 on, one a period
    assert peer.states and all(s.arg & (F_ESTOP | F_NO_SESSION) for s in peer.states)
    assert [s.seq for s in peer.states] == list(range(1, len(peer.states) + 1))
    nack = peer.one(bulk(5, drive_entries(300)))
    assert (nack.kind, nack.seq, nack.payload) == (NACK, 5, bytes([BULK, NOT_READY]))
    reply = peer.one(hello(3, LAYOUT))
    fields = parse_hello_reply(reply.payload)
    assert fields["digest"] == LAYOUT.digest
    assert (fields["channels"], fields["motors"]) == (len(LAYOUT.channels), len(LAYOUT.motors))
    assert (fields["minor"], fields["sessions"]) == (2, 1)
    assert fields["watchdog_ms"] == round(WATCHDOG_S * 1000)
    assert not 0x5000 <= fields["firmware"] <= 0x5FFF  # reserved for simulated bridges
    assert reply.arg & F_ESTOP and not reply.arg & F_NO_SESSION
    assert peer.one(frame(ESTOP_RESET, 4)).payload == bytes([ESTOP_RESET, APPLIED])
    assert peer.errors == []


def damaged_crc(kind: int, seq: int, payload: bytes = b"") -> bytes:
    """An intact COBS frame whose CRC is wrong (cutting bytes off an encoded frame, as
    tests/test_probe20_wire.py's "bad crc" does, makes a COBS error instead)."""
    body = bytes([1, kind]) + struct.pack("<HB", seq, 0) + payload
    body += struct.pack("<H", crc16(body) ^ 0x5A5A)
    return cobs_encode(body) + b"\x00"


BAD_FRAMES = {
    "bad crc": damaged_crc(BULK, 4, struct.pack("<Bh", VELOCITY, -400) * len(LAYOUT.motors)),
    "version 2": frame(BULK, 4, b"\x03\x70\xfe" * 16, version=2),
    "short": cobs_encode(b"\x01\x03\x04\x00") + b"\x00",
    "cobs": b"\x09\x01\x03\x00",
    "oversize": b"\x11" * 300 + b"\x00",
    "254 non-zero bytes and a trailing 01 block": b"\xff" + b"\x01" * 254 + b"\x01\x00",
    "an e-stop with a damaged crc": damaged_crc(ESTOP, 4),
}


@pytest.mark.parametrize("name", sorted(BAD_FRAMES))
def test_a_bad_frame_moves_no_motor_is_counted_and_lets_the_watchdog_trip(
    any_peer: FirmwarePeer, name: str
) -> None:
    peer = any_peer
    if isinstance(peer, SimavrPeer) and "crc" not in name:
        pytest.skip("the host build checks the other kinds (the same frame.c)")
    running(peer, 400)
    rx_before = peer.counters()[0]
    # nothing but the bad frame, every 20 ms, for longer than the watchdog
    for _ in range(round(WATCHDOG_S / 0.02) + 3):
        assert peer.step(BAD_FRAMES[name]) == [], name
        # before the trip the drives run on as told; never as the bad frame says
        assert set(peer.drives().values()) <= {(VELOCITY, 400), (VELOCITY, 0), (PWM, 0)}
    assert braked(peer), peer.drives()
    assert peer.flags() & F_WATCHDOG
    assert not peer.flags() & F_ESTOP, "a damaged ESTOP is no ESTOP: it latched"
    rx, crc, framing, _, trips = peer.counters(9000)
    assert rx == rx_before + 1  # the COUNTERS_REQUEST, none of the bad frames
    sent = round(WATCHDOG_S / 0.02) + 3
    assert (crc, framing) == ((sent, 0) if "crc" in name else (0, sent)), name
    assert trips == 1


def test_every_type_and_every_wrong_length_is_refused_and_moves_no_motor(
    peer: FirmwarePeer,
) -> None:
    running(peer, 400)
    rng = random.Random(21)
    seq = 100
    host_types = {HELLO: 5, SETPOINT: 4, BULK: 3 * len(LAYOUT.motors)}
    for kind in range(256):
        seq += 1
        if kind in range(1, 8):
            # every length but the type's own, up to the largest payload, and lying ones
            right = host_types.get(kind, 0)
            lengths = sorted({0, 1, right - 1, right + 1, 247, *rng.sample(range(248), 6)})
            for n in (n for n in lengths if 0 <= n != right):
                seq += 1
                nack = peer.one(frame(kind, seq, rng.randbytes(n)))
                assert (nack.kind, nack.seq, nack.payload) == (NACK, seq, bytes([kind, BAD_LENGTH]))
            continue
        nack = peer.one(frame(kind, seq, rng.randbytes(rng.randrange(12)), arg=rng.randrange(256)))
        assert (nack.kind, nack.payload) == (NACK, bytes([kind, UNKNOWN_TYPE])), hex(kind)
    # each was intact: the watchdog was fed all along, and no motor was told anything new
    assert not peer.flags() & F_WATCHDOG
    assert set(peer.drives().values()) == {(VELOCITY, 400)}


def test_setpoints_outside_every_range_and_mode_are_refused_on_the_bus_too(
    peer: FirmwarePeer,
) -> None:
    running(peer, 400)
    told = dict(peer.told)
    seq = 10
    for board, slot, _, modes in LAYOUT.motors:
        for mode, (lo, hi) in modes.items():
            for raw in (lo - 1, hi + 1):
                if not -32768 <= raw <= 32767:
                    continue
                seq += 1
                payload = struct.pack("<BBh", slot, MODE_CODES[mode], raw)
                nack = peer.one(frame(SETPOINT, seq, payload, arg=board))
                assert nack.payload == bytes([SETPOINT, OUT_OF_RANGE]), (board, slot, mode, raw)
                entries = [(KEEP, 0)] * len(LAYOUT.motors)
                entries[[(b, s) for b, s, _, _ in LAYOUT.motors].index((board, slot))] = (
                    MODE_CODES[mode],
                    raw,
                )
                seq += 1
                nack = peer.one(bulk(seq, entries))
                assert nack.payload == bytes([BULK, OUT_OF_RANGE]), (board, slot, mode, raw)
        unlisted = [code for code in range(256) if code not in MODE_CODES.values()]
        for code in [*unlisted[:4], KEEP]:
            seq += 1
            payload = struct.pack("<BBh", slot, code, 0)
            assert peer.one(frame(SETPOINT, seq, payload, arg=board)).payload == bytes(
                [SETPOINT, BAD_MODE]
            )
    seq += 1
    no_slot = peer.one(frame(SETPOINT, seq, bytes([7, 0, 0, 0]), arg=LAYOUT.motors[0][0]))
    assert no_slot.payload == bytes([SETPOINT, BAD_SLOT])
    peer.step(dt=3 * PERIOD_S)
    assert peer.told == told  # every motor was told exactly what it was before


def test_a_line_of_garbage_moves_no_motor_and_the_next_good_frame_is_heard(
    peer: FirmwarePeer,
) -> None:
    running(peer, 400)
    rng = random.Random(2126)
    garbage = rng.randbytes(40_000)  # 3.5 s of the line
    for at in range(0, len(garbage), 1152):  # 100 ms of the line at a time
        assert all(a.kind == NACK for a in peer.step(garbage[at : at + 1152], dt=0.1))
        assert set(peer.drives().values()) <= {(VELOCITY, 400), (VELOCITY, 0), (PWM, 0)}
    assert braked(peer)
    # a lone 0x00 ends whatever garbage was left; the next frame is taken at once
    assert peer.one(b"\x00" + frame(HEARTBEAT, 1)).payload == bytes([HEARTBEAT, APPLIED])
    assert not peer.flags() & F_WATCHDOG
    _, crc, framing, _, _ = peer.counters()
    assert crc + framing >= garbage.count(0) - 20  # the few intact ones were answered


def test_a_frame_cut_mid_way_then_silence_stops_the_drives_within_the_watchdog(
    any_peer: FirmwarePeer,
) -> None:
    peer = any_peer
    running(peer, 400)
    cut = bulk(4, drive_entries(-400))
    peer.step(cut[: len(cut) // 2], dt=0.001)
    waited = 0.001
    while not braked(peer) and waited < 2.0:
        peer.step(dt=0.005)
        waited += 0.005
    assert braked(peer), peer.drives()
    # within the watchdog, one state period and one bus cycle
    assert waited <= WATCHDOG_S + 2 * PERIOD_S + 0.005, waited
    assert peer.flags() & F_WATCHDOG
    # the clamps held: no bend joint was told anything by the stop
    bends = {(b, s) for b, s, role, _ in LAYOUT.motors if role == "bend"}
    assert not bends & set(peer.told)
    # the host comes back: the half frame spoils the first frame after it (the page:
    # a sender may flush it with a lone 0x00), and the drives stay stopped
    assert peer.step(frame(HEARTBEAT, 2)) == []
    assert braked(peer)
    assert peer.one(b"\x00" + frame(HEARTBEAT, 3)).kind == ACK
    assert not peer.flags() & F_WATCHDOG
    assert braked(peer)


def test_a_second_hosts_session_stops_the_first_ones_drives_and_keeps_its_latch(
    any_peer: FirmwarePeer,
) -> None:
    peer = any_peer
    running(peer, 400, seq=3)
    second = peer.one(hello(20_000, LAYOUT, minor=1))
    fields = parse_hello_reply(second.payload)
    assert (fields["sessions"], fields["minor"]) == (2, 1)
    assert not second.arg & F_ESTOP  # the first host released it: a hello keeps it so
    settle(peer, lambda: braked(peer))
    assert braked(peer), peer.drives()
    # the first host's next bulk is older than the new session's hello: stale, unapplied
    stale = peer.one(bulk(4, drive_entries(-400)))
    assert stale.payload == bytes([BULK, STALE])
    peer.step(dt=2 * PERIOD_S)
    assert braked(peer)
    # the second host's own goes through
    assert peer.step(bulk(20_001, drive_entries(200))) == []
    heard = settle(peer, lambda: set(peer.drives().values()) == {(VELOCITY, 200)})
    assert set(peer.drives().values()) == {(VELOCITY, 200)}, (peer.drives(), heard)
    assert peer.one(bulk(20_001, drive_entries(200))).payload == bytes([BULK, DUPLICATE])


def test_an_intact_estop_stops_the_drives_and_refuses_setpoints(any_peer: FirmwarePeer) -> None:
    peer = any_peer
    running(peer, 400)
    assert peer.one(frame(ESTOP, 5)).payload == bytes([ESTOP, APPLIED])
    settle(peer, lambda: braked(peer))
    assert braked(peer)
    assert peer.one(bulk(6, drive_entries(300))).payload == bytes([BULK, ESTOP_LATCHED])
    assert peer.one(bulk(4, drive_entries(300))).payload == bytes([BULK, STALE])
    peer.step(dt=2 * PERIOD_S)
    assert braked(peer)


def test_hello_with_another_minor_or_digest_changes_nothing(any_peer: FirmwarePeer) -> None:
    peer = any_peer
    for payload in [
        struct.pack("<IB", LAYOUT.digest, 0),
        struct.pack("<IB", LAYOUT.digest, 3),
        struct.pack("<IB", LAYOUT.digest ^ 1, 2),
    ]:
        assert peer.one(frame(HELLO, 1, payload)).payload == bytes([HELLO, BAD_LAYOUT])
    assert peer.flags() & F_NO_SESSION
