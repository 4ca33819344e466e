"""Probe 20: a clean-room peer of the PIRATEbay wire protocol against our bridge and host.

``tests/cleanroom_peer.py`` implements the protocol from docs/protocol.md alone (no
``pirate_bt.link``). As a host it talks to the simulated bridge (in process on a
virtual clock, and served on TCP by ``SimServer``); as a bridge it serves a TCP socket
that our host connects to.
"""

from __future__ import annotations

import itertools
import json
import socket
import struct
import time
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
    PeerBridge,
    bulk,
    cobs_decode,
    cobs_encode,
    crc16,
    frame,
    hello,
    layout_of,
    parse_hello_reply,
)

from pirate_bt.robot import load_robot
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.boardbus import BoardBus
from pirate_bt.sim.bridge import SimBridge
from pirate_bt.sim.bridge_port import bridge_for
from pirate_bt.sim.server import SimServer
from pirate_bt.sim.simulator import Simulator

ROBOT: RobotDescription = load_robot()
LAYOUT: Layout = layout_of(ROBOT)
DRIVES = [
    name for board in ROBOT.boards for m in board.motors if (name := m.name).endswith("drive")
]


class VirtualBridge:
    """The simulated bridge in process, reached through bytes only, on a virtual clock."""

    def __init__(self) -> None:
        self.bridge: SimBridge = bridge_for(ROBOT, record_applied=False)
        self.now_s = 0.0
        self.decoder = Decoder()
        self.states: list[Frame] = []
        self.errors: list[str] = []

    def step(self, data: bytes = b"", dt: float = 0.001) -> list[Frame]:
        """Write ``data``, let ``dt`` pass, and return the answers (STATEs kept aside)."""
        if data:
            self.bridge.receive(data)
        self.now_s += dt
        self.bridge.advance_to(self.now_s)
        answers = []
        for item in self.decoder.feed(self.bridge.read()):
            if isinstance(item, str):
                self.errors.append(item)
            elif item.kind in (STATE, BRIDGE_HEARTBEAT):
                self.states.append(item)
            else:
                answers.append(item)
        return answers

    def one(self, data: bytes) -> Frame:
        answers = self.step(data)
        assert len(answers) == 1, answers
        return answers[0]

    def session(self) -> None:
        """HELLO, then release the boot latch, as a host does at connect."""
        reply = self.one(hello(1, LAYOUT))
        assert reply.kind == HELLO_REPLY
        assert self.one(frame(ESTOP_RESET, 2)).payload == bytes([ESTOP_RESET, APPLIED])

    def counters(self) -> tuple[int, ...]:
        reply = self.one(frame(COUNTERS_REQUEST, 77))
        assert reply.kind == COUNTERS
        return struct.unpack_from("<5I", reply.payload)

    def flags(self) -> int:
        self.step(dt=0.011)
        return self.states[-1].arg

    def drives(self) -> list[object]:
        return [self.bridge.model.setpoint(name) for name in DRIVES]


def _drive_entries(raw: int) -> list[tuple[int, int]]:
    return [(3, raw) if role == "drive" else (KEEP, 0) for _, _, role, _ in LAYOUT.motors]


def test_the_clean_room_layout_digest_and_crc_are_the_pages() -> None:
    """The digest text and CRC as the page spells them give the bridge's own."""
    assert crc16(b"123456789") == 0x31C3
    bridge = VirtualBridge()
    reply = bridge.one(hello(1, LAYOUT))
    fields = parse_hello_reply(reply.payload)
    assert fields["digest"] == LAYOUT.digest
    assert (fields["channels"], fields["motors"]) == (len(LAYOUT.channels), len(LAYOUT.motors))
    assert (fields["minor"], fields["sessions"], fields["watchdog_ms"]) == (2, 1, 250)
    assert 0x5000 <= fields["firmware"] <= 0x5FFF
    assert reply.arg & F_ESTOP and not reply.arg & F_NO_SESSION


def test_the_bridge_boots_latched_and_refuses_ordered_requests_before_a_hello() -> None:
    bridge = VirtualBridge()
    bridge.step(dt=0.05)
    assert bridge.states and all(s.arg == F_ESTOP | F_NO_SESSION for s in bridge.states)
    seqs = [s.seq for s in bridge.states]
    assert seqs[0] == 1 and seqs == list(range(1, len(seqs) + 1))
    nack = bridge.one(bulk(5, _drive_entries(300)))
    assert (nack.kind, nack.seq, nack.payload) == (NACK, 5, bytes([BULK, NOT_READY]))
    ack = bridge.one(frame(ESTOP, 9))
    assert (ack.kind, ack.payload) == (ACK, bytes([ESTOP, APPLIED]))
    # the first HELLO sets `last` whatever its seq, even older than the ESTOP's
    assert bridge.one(hello(3, LAYOUT)).kind == HELLO_REPLY
    assert bridge.one(frame(ESTOP_RESET, 4)).payload == bytes([ESTOP_RESET, APPLIED])


@pytest.mark.parametrize(
    ("name", "wire"),
    [
        ("bad crc", frame(BULK, 3, b"\x03\x90\x01" * 16)[:-3] + b"\x55\x00"),
        ("version 2", frame(BULK, 3, b"".join(b"\x03\x90\x01" for _ in range(16)), version=2)),
        ("short", cobs_encode(b"\x01\x03\x03\x00") + b"\x00"),
        ("cobs", b"\x09\x01\x03\x00"),
        ("oversize", b"\x11" * 300 + b"\x00"),
        ("254 non-zero bytes and a trailing 01 block", b"\xff" + b"\x01" * 254 + b"\x01\x00"),
    ],
)
def test_a_bad_frame_is_dropped_unanswered_moves_nothing_and_does_not_feed_the_watchdog(
    name: str, wire: bytes
) -> None:
    bridge = VirtualBridge()
    bridge.session()
    before = bridge.drives()
    rx_before = bridge.counters()[0]
    # 300 ms of nothing but the bad frame, every 20 ms: the watchdog trips
    for _ in range(15):
        assert bridge.step(wire, dt=0.02) == [], name
    assert bridge.drives() == before
    assert bridge.flags() & F_WATCHDOG, name
    rx, crc, framing, *_ = bridge.counters()
    assert rx == rx_before + 1  # the COUNTERS_REQUEST itself, none of the bad frames
    assert crc + framing >= 15


def test_intact_frames_of_the_wrong_type_or_length_are_nacked_and_feed_the_watchdog() -> None:
    bridge = VirtualBridge()
    bridge.session()
    for wire, kind, code in [
        (frame(0x42, 11), 0x42, UNKNOWN_TYPE),
        (frame(STATE, 12, LAYOUT.state_payload()), STATE, UNKNOWN_TYPE),
        (frame(0x00, 13), 0x00, UNKNOWN_TYPE),
        (frame(HEARTBEAT, 14, b"\x00"), HEARTBEAT, BAD_LENGTH),
        (frame(HELLO, 15, struct.pack("<I", LAYOUT.digest)), HELLO, BAD_LENGTH),
        (frame(BULK, 16, b"\x03\x00\x00" * 15), BULK, BAD_LENGTH),
    ]:
        for _ in range(3):
            nack = bridge.one(wire)
            assert (nack.kind, nack.payload) == (NACK, bytes([kind, code])), hex(kind)
            bridge.step(dt=0.1)
    assert not bridge.flags() & F_WATCHDOG


def test_a_frame_cut_anywhere_and_garbage_between_frames_still_reach_the_bridge() -> None:
    bridge = VirtualBridge()
    bridge.session()
    wire = bulk(3, _drive_entries(400))
    for byte in wire:
        bridge.step(bytes([byte]), dt=0.0005)
    bridge.step(dt=0.011)
    ack_seq, _ = LAYOUT.parse_state(bridge.states[-1].payload)
    assert ack_seq == 3
    # garbage with no delimiter before a frame spoils that frame only; a lone 0x00 flushes
    assert bridge.step(b"\x13\x37\x42" + frame(HEARTBEAT, 1)) == []
    assert bridge.one(b"\x13\x37\x42\x00" + frame(HEARTBEAT, 2)).kind == ACK
    assert bridge.one(b"\x00\x00\x00" + frame(HEARTBEAT, 3) + b"\x00\x00").seq == 3


def test_the_duplicate_filter_and_the_nack_codes_as_the_page_orders_them() -> None:
    bridge = VirtualBridge()
    bridge.session()
    assert bridge.step(bulk(3, _drive_entries(400))) == []
    dup = bridge.one(bulk(3, _drive_entries(400)))
    assert dup.payload == bytes([BULK, DUPLICATE])
    stale = bridge.one(bulk(2, _drive_entries(-400)))
    assert stale.payload == bytes([BULK, STALE])
    # keep in a SETPOINT, a slot with no motor, a raw value out of range
    motor_board, motor_slot = LAYOUT.motors[0][0], LAYOUT.motors[0][1]
    keep = bridge.one(frame(SETPOINT, 4, bytes([motor_slot, KEEP, 0, 0]), arg=motor_board))
    assert keep.payload == bytes([SETPOINT, BAD_MODE])
    empty = bridge.one(frame(SETPOINT, 5, bytes([7, 0, 0, 0]), arg=motor_board))
    assert empty.payload == bytes([SETPOINT, BAD_SLOT])
    far = bridge.one(bulk(6, _drive_entries(5000)))
    assert far.payload == bytes([BULK, OUT_OF_RANGE])
    # a refused request moves `last`: its copy gets the same NACK, an older one STALE
    assert bridge.one(bulk(6, _drive_entries(5000))).payload == bytes([BULK, OUT_OF_RANGE])
    assert bridge.one(bulk(5, _drive_entries(5000))).payload == bytes([BULK, STALE])
    # e-stop: latched, setpoints refused, nothing moves
    assert bridge.one(frame(ESTOP, 7)).payload == bytes([ESTOP, APPLIED])
    latched = bridge.one(bulk(8, _drive_entries(300)))
    assert latched.payload == bytes([BULK, ESTOP_LATCHED])
    assert all(s is None or s.value == 0 for s in bridge.drives())


def test_hello_with_another_minor_or_digest_is_refused_and_changes_nothing() -> None:
    bridge = VirtualBridge()
    for payload in [
        struct.pack("<IB", LAYOUT.digest, 0),
        struct.pack("<IB", LAYOUT.digest, 3),
        struct.pack("<IB", LAYOUT.digest ^ 1, 2),
    ]:
        nack = bridge.one(frame(HELLO, 1, payload))
        assert nack.payload == bytes([HELLO, BAD_LAYOUT])
    assert bridge.flags() & F_NO_SESSION


def test_a_bridge_with_a_long_state_period_sends_bridge_heartbeats_between_states() -> None:
    """The page: ``BRIDGE_HEARTBEAT`` is sent when the bridge has sent no frame for 50 ms
    (never with a 10 ms state period). The simulated bridge never sent one: with an
    80 ms state period (a description the validator takes) the line was silent for
    80 ms at a time, where the firmware bridge beats every 50 ms."""
    slow = ROBOT.model_copy(
        update={"bridge": ROBOT.bridge.model_copy(update={"state_period": 0.08})}
    )
    bridge = bridge_for(slow, record_applied=False)
    decoder = Decoder()
    heard: list[tuple[float, Frame]] = []
    now = 0.0
    for _ in range(400):
        now += 0.001
        bridge.advance_to(now)
        heard += [(now, f) for f in decoder.feed(bridge.read()) if isinstance(f, Frame)]
    kinds = [(round(t, 3), f.kind, f.seq) for t, f in heard]
    beats = [k for k in kinds if k[1] == BRIDGE_HEARTBEAT]
    assert beats, kinds
    # the first 50 ms after boot (no frame yet), then 50 ms after each STATE
    assert kinds[:4] == [
        (0.05, BRIDGE_HEARTBEAT, 1),
        (0.08, STATE, 2),
        (0.13, BRIDGE_HEARTBEAT, 3),
        (0.16, STATE, 4),
    ], kinds
    booted = F_ESTOP | F_NO_SESSION  # (and WATCHDOG from 0.25 s: no host)
    assert all(f.arg & booted == booted for _, f in heard)
    assert all(not f.payload for _, f in heard if f.kind == BRIDGE_HEARTBEAT)
    assert [f.seq for _, f in heard] == list(range(1, len(heard) + 1))
    gaps = [b - a for (a, _), (b, _) in itertools.pairwise(heard)]
    assert max(gaps) <= 0.05 + 1e-9
    # an answer is a frame too: 30 ms after a STATE, it puts the next beat off past
    # the next STATE (due 50 ms after the answer)
    assert kinds[-1][:2] == (0.4, STATE)
    bridge.advance_to(0.43)
    assert decoder.feed(bridge.read()) == []
    bridge.receive(frame(HEARTBEAT, 9))
    bridge.advance_to(0.47)
    got = [f.kind for f in decoder.feed(bridge.read()) if isinstance(f, Frame)]
    assert got == [ACK], got


# --- over TCP, in real time: our simulator as the bridge, and the page's bridge ------------


class TcpHost:
    """The page's host on a TCP socket: frames as they come, waited for by event."""

    def __init__(self, address: tuple[str, int]) -> None:
        self.sock = socket.create_connection(address, timeout=10.0)
        self.sock.settimeout(0.05)
        self.decoder = Decoder()
        self.closed = False

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def until(self, test: Callable[[Frame], bool], limit_s: float = 20.0) -> list[Frame]:
        """Frames up to and including the first that passes ``test`` (fails after
        ``limit_s``)."""
        seen: list[Frame] = []
        deadline = time.monotonic() + limit_s
        while time.monotonic() < deadline:
            try:
                data = self.sock.recv(4096)
            except TimeoutError:
                continue
            if not data:
                self.closed = True
                break
            for item in self.decoder.feed(data):
                if isinstance(item, Frame):
                    seen.append(item)
                    if test(item):
                        return seen
        raise AssertionError(f"not heard within {limit_s} s: {[(f.kind, f.seq) for f in seen]}")

    def answer(self, limit_s: float = 20.0) -> Frame:
        return self.until(lambda f: f.kind not in (STATE, BRIDGE_HEARTBEAT), limit_s)[-1]

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def served() -> Iterator[tuple[str, int]]:
    server = SimServer(Simulator("straight"))
    address = server.open_tcp(0)
    server.start()
    try:
        yield address
    finally:
        server.stop()


@pytest.mark.xdist_group("real-time")
def test_the_simulator_on_tcp_answers_the_pages_host_and_never_moves_on_a_bad_frame(
    served: tuple[str, int],
) -> None:
    host = TcpHost(served)
    try:
        boot = host.until(lambda f: f.kind == STATE)[-1]
        assert boot.arg & (F_ESTOP | F_NO_SESSION) == F_ESTOP | F_NO_SESSION
        host.send(b"\x00" + hello(1, LAYOUT))
        reply = host.answer()
        assert reply.kind == HELLO_REPLY and reply.seq == 1
        assert parse_hello_reply(reply.payload)["digest"] == LAYOUT.digest
        host.send(frame(ESTOP_RESET, 2))
        assert host.answer().payload == bytes([ESTOP_RESET, APPLIED])
        # bad frames get no answer: the next answer is the good heartbeat's
        bad_crc = frame(BULK, 3, b"\x03\x90\x01" * 16)[:-3] + b"\x55\x00"
        host.send(bad_crc + b"\xff" * 300 + b"\x00" + frame(BULK, 4, b"\x03", version=2))
        host.send(frame(HEARTBEAT, 50))
        ack = host.answer()
        assert (ack.kind, ack.seq, ack.payload) == (ACK, 50, bytes([HEARTBEAT, APPLIED]))
        # a frame cut in two across writes, garbage before its own delimiter
        wire = frame(0x42, 51)
        host.send(b"\x99\x98\x00" + wire[:4])
        time.sleep(0.05)  # the halves go in two segments (no assertion on time)
        host.send(wire[4:])
        nack = host.answer()
        assert (nack.kind, nack.seq, nack.payload) == (NACK, 51, bytes([0x42, UNKNOWN_TYPE]))
        # no bulk was applied: ack_seq is still 0
        state = host.until(lambda f: f.kind == STATE)[-1]
        assert LAYOUT.parse_state(state.payload)[0] == 0
        # the host falls silent: the watchdog trips (no latch)
        tripped = host.until(lambda f: f.kind == STATE and bool(f.arg & F_WATCHDOG))[-1]
        assert not tripped.arg & F_ESTOP
        host.send(frame(ESTOP, 5))
        assert host.answer().payload == bytes([ESTOP, APPLIED])
    finally:
        host.close()
    # a second host while one is connected is hung up on; a new one after it finds the
    # bridge as the last left it (no DTR reset over TCP): latched, in a session
    again = TcpHost(served)
    try:
        second = TcpHost(served)
        with pytest.raises(AssertionError):
            second.until(lambda f: True, limit_s=20.0)
        assert second.closed
        second.close()
        state = again.until(lambda f: f.kind == STATE)[-1]
        assert state.arg & (F_ESTOP | F_NO_SESSION) == F_ESTOP
    finally:
        again.close()


def _stopped(frames: list[Frame]) -> bool:
    """The host sent an ESTOP, or a bulk with every drive at velocity 0."""
    for f in frames:
        if f.kind == ESTOP:
            return True
        if f.kind == BULK:
            entries = [struct.unpack_from("<Bh", f.payload, 3 * i) for i in range(16)]
            drives = [e for e, m in zip(entries, LAYOUT.motors, strict=True) if m[2] == "drive"]
            if all(e == (3, 0) for e in drives):
                return True
    return False


@pytest.mark.xdist_group("real-time")
@pytest.mark.parametrize(
    ("hostile", "says"),
    [
        (
            lambda n, peer: (
                LAYOUT.state_payload(ack_seq=peer.ack_seq, values=peer.values) + b"\x00\x00",
                peer.flags(),
            ),
            "protocol mismatch: the bridge sent 3 STATE frames in a row of another layout",
        ),
        (
            lambda n, peer: (
                LAYOUT.state_payload(ack_seq=peer.ack_seq, values=peer.values, status=1 | 2),
                peer.flags(),
            ),
            "report FAULT",
        ),
        (
            lambda n, peer: peer.reset(),
            "e-stop: the bridge reports its e-stop latched: it reset in the middle of the session",
        ),
    ],
    ids=["state-of-another-layout", "every-board-in-fault", "bridge-reset"],
)
def test_our_host_refuses_a_hostile_bridge_in_one_line_and_stops_the_robot(
    hostile: Callable[[int, PeerBridge], tuple[bytes, int] | None], says: str
) -> None:
    """The page's bridge on TCP; after 0.3 s of good STATEs it turns hostile."""
    import pirate_bt

    peer = PeerBridge(
        LAYOUT,
        state=lambda n, p: hostile(n, p) if n > 30 and p.session and not p.estopped else None,
    )
    try:
        result = pirate_bt.run_tree("straight", port=peer.url, params={"distance": "0.1 m"})
        assert result.exit_code == 3, result.why
        assert says in result.why and "\n" not in result.why, result.why
        assert peer.wait_for(_stopped), [(f.kind, f.seq) for f in peer.received]
    finally:
        peer.close()


# --- the board bus: the page's master against the Python boards ---------------------------


def _bus_frame(addr: int, cmd: int, payload: bytes) -> bytes:
    body = bytes([addr, cmd]) + payload
    return cobs_encode(body + struct.pack("<H", crc16(body)))


def test_the_python_boards_answer_the_pages_bus_master() -> None:
    """docs/board-bus.md from the master's side: replies, keep, own stop, STOP, noise."""
    bus = BoardBus(bridge_for(ROBOT).model)
    now = 0.0

    def send(
        addr: int, entries: list[tuple[int, int]], cmd: int = 1, dt: float = 0.001
    ) -> int | None:
        nonlocal now
        now += dt
        reply = bus.handle(
            now, _bus_frame(addr, cmd, b"".join(struct.pack("<Bh", *e) for e in entries))
        )
        if not reply:
            return None
        assert reply.endswith(b"\x00") and b"\x00" not in reply[:-1]
        body = cobs_decode(reply[:-1])
        assert body is not None and crc16(body[:-2]) == struct.unpack("<H", body[-2:])[0]
        channels = sum(1 for b, _ in LAYOUT.channels if b == addr)
        assert (body[0], body[1], len(body)) == (addr, 0x81, 5 + 2 * channels)
        return body[2]

    keep = {b: [(KEEP, 0)] * sum(1 for m in LAYOUT.motors if m[0] == b) for b in LAYOUT.boards}
    for board in LAYOUT.boards:  # nothing commanded since boot: MOTORS_OFF
        assert send(board, keep[board]) == 0x02
    assert send(22, [(KEEP, 0), (3, 400)]) == 0x02  # the bend joint still never commanded
    assert bus.motor_state(22, 1) == (3, 400)
    # a keep's raw, a mode the motor lacks, a value out of range: ignored
    assert send(22, [(KEEP, 1234), (1, 5)]) == 0x02
    assert send(22, [(KEEP, 0), (3, 5000)]) == 0x02
    assert bus.motor_state(22, 1) == (3, 400)
    # not the master's voice for board 22: frames to others, bad frames, no broadcast
    for wire in [
        _bus_frame(22, 1, b"\xff\x00\x00"),  # a payload not 3 bytes per motor
        _bus_frame(22, 3, b"\xff\x00\x00" * 2),  # an unknown cmd
        _bus_frame(22, 0x81, b"\xff\x00\x00" * 2),  # a reply
        _bus_frame(0, 1, b""),
        _bus_frame(0xFF, 1, b""),
        _bus_frame(22, 1, b"\xff\x00\x00" * 2)[:-1] + b"\x01",  # its CRC damaged
    ]:
        now += 0.001
        assert bus.handle(now, wire) == b""
    for _ in range(12):
        assert send(23, keep[23], dt=0.01) is not None
    # 100 ms without a good frame to it: board 22 stopped itself (brake), joints held
    assert send(22, [(KEEP, 0), (3, 400)]) == 0x02 | 0x04
    assert bus.motor_state(22, 1) == (0, 0)
    # a STOP (not answered) ends its own stop; the next EXCHANGE applies again
    assert send(22, [(KEEP, 0), (0, 0)], cmd=2) is None
    assert send(22, [(KEEP, 0), (3, 300)]) == 0x02
    assert bus.motor_state(22, 1) == (3, 300)


# --- python -m pirate_bt.sim.board_vectors ----------------------------------------------


def test_the_board_vectors_writer_takes_one_file_and_fails_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``python -m pirate_bt.sim.board_vectors`` (docs/board-bus.md, Vectors) run anywhere
    but the checkout's root was a FileNotFoundError traceback; ``--help`` wrote a file
    named ``--help``; a folder or a file it cannot write was a traceback; a second
    argument was ignored; the file was written in place (half a file on a failure)."""
    from pirate_bt.sim import board_vectors

    monkeypatch.chdir(tmp_path)
    assert board_vectors.main(["--help"]) == 0
    assert "usage" in capsys.readouterr().out
    assert not (tmp_path / "--help").exists()
    for args in (["a.json", "b.json"], ["-x"], [""]):
        assert board_vectors.main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "usage" in err, err
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("x")
    for name in ("folder", "file/v.json"):
        assert board_vectors.main([name]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"{name}: cannot write") and err.count("\n") == 1, err
    # with no file named, from anywhere: the checkout's own file (the tests compare it)
    written: list[Path] = []
    monkeypatch.setattr(
        board_vectors,
        "write_atomically",
        lambda path, fill: written.append(Path(path)),
        raising=False,
    )
    assert board_vectors.main([]) == 0
    assert written == [Path(__file__).parent / "data" / "board_bus_vectors.json"]
    monkeypatch.undo()
    assert board_vectors.main([str(tmp_path / "v.json")]) == 0
    assert json.loads((tmp_path / "v.json").read_text()) == board_vectors.build_vectors(ROBOT)
