"""The bridge firmware's own C logic, compiled for the host and driven in virtual time.

``firmware/piratebay/host/host_hal.c`` stands in for the AVR hardware files (USARTs,
timers, the MCU); every other file is the firmware's code as flashed. These tests
speak bytes to it, as the host does, and check the bridge rules of
``docs/protocol.md`` (1.1): sessions, the duplicate filter, every NACK code, the
e-stop latch and its reset, the watchdog, the stop category on the board bus, the
STATE frame. The frame helpers here are written from the protocol page, not taken
from ``pirate_bt.link``, so the firmware is checked against the page. The simavr
harness runs the AVR build against the shared conformance suite; this is the quick
path (a few seconds, no simavr).
"""

from __future__ import annotations

import binascii
import ctypes
import random
import shutil
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
from firmware_host import build_host_library

from pirate_bt.link.codec import cobs_decode, cobs_encode
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.loader import load_robot

VECTORS = Path(__file__).parent / "data" / "link_vectors.json"

HELLO, SETPOINT, BULK, HEARTBEAT, ESTOP, ESTOP_RESET, COUNTERS_REQUEST = range(1, 8)
HELLO_REPLY, STATE, ACK, NACK, COUNTERS = 0x81, 0x82, 0x83, 0x84, 0x85
APPLIED, DUPLICATE, STALE = 0, 1, 2
(UNKNOWN_TYPE, BAD_LENGTH, BAD_LAYOUT, BAD_BOARD, BAD_SLOT) = (1, 2, 3, 4, 5)
(BAD_MODE, OUT_OF_RANGE, ESTOP_LATCHED, BUS_ERROR, NOT_READY) = (6, 7, 8, 9, 10)
F_ESTOP, F_WATCHDOG, F_BUS_FAULT, F_NO_SESSION = 1, 2, 4, 8
ONLINE, FAULT, TIMEOUT, MOTORS_OFF = 1, 2, 4, 8
PWM, TORQUE, POSITION, VELOCITY, KEEP = 0, 1, 2, 3, 0xFF


def frame(kind: int, seq: int, arg: int = 0, payload: bytes = b"") -> bytes:
    body = bytes([1, kind]) + struct.pack("<HB", seq, arg) + payload
    body += struct.pack("<H", binascii.crc_hqx(body, 0))
    return cobs_encode(body) + b"\x00"


@dataclass(frozen=True)
class Frame:
    kind: int
    seq: int
    arg: int
    payload: bytes


def parse(wire: bytes) -> list[Frame]:
    out = []
    for raw in wire.split(b"\x00")[:-1]:
        body = cobs_decode(raw)
        assert binascii.crc_hqx(body[:-2], 0) == struct.unpack("<H", body[-2:])[0]
        assert body[0] == 1
        out.append(Frame(body[1], struct.unpack("<H", body[2:4])[0], body[4], body[5:-2]))
    return out


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_host_library(tmp_path_factory.mktemp("fw-host"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware core cannot be built")
        raise


class Bridge:
    """The host build of the firmware, one boot per instance."""

    def __init__(self, path: Path, robot: RobotDescription) -> None:
        # a private copy: each test gets fresh static state
        self.lib = ctypes.CDLL(str(path), mode=ctypes.RTLD_LOCAL)
        self.robot = robot
        self.channels = robot.state_channels()
        self.motors = robot.setpoint_slots()
        self.boards = robot.board_ids()
        for index in range(len(self.boards)):
            self.lib.fw_board(index, 1, 0)
        self.lib.fw_boot()
        self.frames: list[Frame] = []

    def write(self, data: bytes) -> None:
        self.lib.fw_write(data, len(data))

    def run(self, ms: float) -> None:
        self.lib.fw_run_us(int(ms * 1000))

    def read(self) -> list[Frame]:
        buf = ctypes.create_string_buffer(1 << 16)
        n = self.lib.fw_read(buf, len(buf))
        return parse(buf.raw[:n])

    def ask(self, data: bytes, ms: float = 10) -> list[Frame]:
        """Send, let `ms` pass, return the answers (STATE frames kept aside)."""
        self.write(data)
        self.run(ms)
        got = self.read()
        self.frames += [f for f in got if f.kind == STATE]
        return [f for f in got if f.kind != STATE]

    def states(self, ms: float = 12) -> list[Frame]:
        self.run(ms)
        return [f for f in self.read() if f.kind == STATE]

    def bus(self) -> list[bytes]:
        """Bodies (addr, cmd, payload, without CRC) the bridge sent on the board bus."""
        buf = ctypes.create_string_buffer(1 << 16)
        n = self.lib.fw_bus_log(buf, len(buf))
        data, out, i = buf.raw[:n], [], 0
        while i < len(data):
            out.append(data[i + 1 : i + 1 + data[i] - 2])
            i += 1 + data[i]
        return out

    def board(self, board_id: int, online: bool, status: int = 0) -> None:
        self.lib.fw_board(self.boards.index(board_id), int(online), status)

    def hello(self, seq: int = 1) -> Frame:
        (reply,) = self.ask(frame(HELLO, seq, payload=struct.pack("<IB", self.digest, 1)))
        return reply

    def start(self) -> None:
        """Hello and e-stop reset: a session that accepts setpoints."""
        self.run(25)  # a poll cycle or two: boards ONLINE
        self.hello(1)
        assert self.ask(frame(ESTOP_RESET, 2)) == [Frame(ACK, 2, 0, bytes([ESTOP_RESET, 0]))]

    @property
    def digest(self) -> int:
        return self.robot.layout_digest()

    def state(self, f: Frame) -> tuple[int, int, int, list[int], list[int]]:
        """ack_seq, fresh mask, board status nibbles, channel values of a STATE."""
        nc, nb = len(self.channels), len(self.boards)
        mb, sb = (nc + 7) // 8, (nb + 1) // 2
        p = f.payload
        assert len(p) == 2 + mb + sb + 2 * nc
        ack = struct.unpack("<H", p[:2])[0]
        fresh = int.from_bytes(p[2 : 2 + mb], "little")
        status = [(p[2 + mb + j // 2] >> (4 * (j % 2))) & 0xF for j in range(nb)]
        values = list(struct.unpack(f"<{nc}h", p[2 + mb + sb :]))
        return ack, fresh, f.arg, status, values


@pytest.fixture()
def bridge(library: Path, tmp_path: Path) -> Iterator[Bridge]:
    copy = tmp_path / "bridge.so"
    shutil.copy(library, copy)
    yield Bridge(copy, load_robot())


def nack(seq: int, kind: int, code: int) -> Frame:
    return Frame(NACK, seq, 0, bytes([kind, code]))


def ack(seq: int, kind: int, status: int = APPLIED) -> Frame:
    return Frame(ACK, seq, 0, bytes([kind, status]))


def setpoint(seq: int, board: int, slot: int, mode: int, raw: int) -> bytes:
    return frame(SETPOINT, seq, board, struct.pack("<BBh", slot, mode, raw))


def bulk(seq: int, entries: list[tuple[int, int]]) -> bytes:
    return frame(BULK, seq, payload=b"".join(struct.pack("<Bh", m, r) for m, r in entries))


# -- boot and sessions ------------------------------------------------------------------


def test_boots_latched_without_session_and_sends_state_every_period(bridge: Bridge) -> None:
    states = bridge.states(45)
    assert [s.seq for s in states] == [1, 2, 3, 4]
    for s in states:
        ack_seq, _, flags, status, _ = bridge.state(s)
        assert ack_seq == 0
        assert flags & (F_ESTOP | F_NO_SESSION) == F_ESTOP | F_NO_SESSION
        assert all(n & MOTORS_OFF for n in status)


def test_hello_reply_reports_the_layout_and_the_first_session(bridge: Bridge) -> None:
    reply = bridge.hello(seq=7)
    assert reply.kind == HELLO_REPLY and reply.seq == 7
    digest, nch, nmot, wd, _fw, minor, _boot, sessions = struct.unpack("<IBBHHBHB", reply.payload)
    assert (digest, nch, nmot, wd, minor, sessions) == (bridge.digest, 28, 16, 250, 1, 1)
    assert reply.arg & F_ESTOP and not reply.arg & F_NO_SESSION
    assert struct.unpack("<IBBHHBHB", bridge.hello(seq=9).payload)[-1] == 2
    # a retried hello (same seq, its reply lost, nothing handled since) is the same
    # session; after an ordered request, the same seq is a new host's new session
    assert struct.unpack("<IBBHHBHB", bridge.hello(seq=9).payload)[-1] == 2
    assert bridge.ask(frame(ESTOP_RESET, 10)) == [ack(10, ESTOP_RESET)]
    assert bridge.ask(frame(ESTOP, 11)) == [ack(11, ESTOP)]
    assert struct.unpack("<IBBHHBHB", bridge.hello(seq=9).payload)[-1] == 3


def test_hello_with_another_layout_or_version_is_refused(bridge: Bridge) -> None:
    other = struct.pack("<IB", bridge.digest ^ 1, 1)
    assert bridge.ask(frame(HELLO, 1, payload=other)) == [nack(1, HELLO, BAD_LAYOUT)]
    minor = struct.pack("<IB", bridge.digest, 0)
    assert bridge.ask(frame(HELLO, 2, payload=minor)) == [nack(2, HELLO, BAD_LAYOUT)]
    old = struct.pack("<I", bridge.digest)  # a 1.0 hello
    assert bridge.ask(frame(HELLO, 3, payload=old)) == [nack(3, HELLO, BAD_LENGTH)]
    assert bridge.state(bridge.states()[-1])[2] & F_NO_SESSION


def test_ordered_requests_before_any_session_are_not_ready(bridge: Bridge) -> None:
    assert bridge.ask(setpoint(5, 22, 1, VELOCITY, 10)) == [nack(5, SETPOINT, NOT_READY)]
    assert bridge.ask(frame(ESTOP_RESET, 6)) == [nack(6, ESTOP_RESET, NOT_READY)]
    assert bridge.ask(frame(HEARTBEAT, 7)) == [ack(7, HEARTBEAT)]
    assert bridge.ask(frame(ESTOP, 8)) == [ack(8, ESTOP)]


# -- duplicate filter -------------------------------------------------------------------


def test_duplicate_filter_replays_answers_and_refuses_stale_copies(bridge: Bridge) -> None:
    bridge.start()
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 500)) == [ack(3, SETPOINT)]
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 500)) == [ack(3, SETPOINT, DUPLICATE)]
    assert bridge.ask(setpoint(2, 22, 1, VELOCITY, 500)) == [ack(2, SETPOINT, STALE)]
    assert bridge.ask(setpoint(4, 99, 1, VELOCITY, 5)) == [nack(4, SETPOINT, BAD_BOARD)]
    # the refused request moved the filter; its copy gets the same NACK
    assert bridge.ask(setpoint(4, 99, 1, VELOCITY, 5)) == [nack(4, SETPOINT, BAD_BOARD)]
    counters = bridge.ask(frame(COUNTERS_REQUEST, 100))[0]
    assert struct.unpack("<5I", counters.payload[:20])[3] == 3


def test_sequence_numbers_wrap(bridge: Bridge) -> None:
    bridge.run(25)
    bridge.hello(65534)
    assert bridge.ask(frame(ESTOP_RESET, 65535)) == [ack(65535, ESTOP_RESET)]
    assert bridge.ask(setpoint(1, 22, 1, VELOCITY, 5)) == [ack(1, SETPOINT)]
    assert bridge.ask(setpoint(65535, 22, 1, VELOCITY, 5)) == [ack(65535, SETPOINT, STALE)]


# -- setpoints --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("board", "slot", "mode", "raw", "code"),
    [
        (99, 0, PWM, 0, BAD_BOARD),
        (24, 0, PWM, 0, BAD_SLOT),  # board 24 has a motor on slot 1 only
        (22, 0, VELOCITY, 0, BAD_MODE),  # a bend joint has no velocity mode
        (22, 0, KEEP, 0, BAD_MODE),
        (22, 0, 9, 0, BAD_MODE),
        (22, 0, POSITION, 2048, OUT_OF_RANGE),
        (22, 1, VELOCITY, -1201, OUT_OF_RANGE),
        (21, 1, PWM, -1, OUT_OF_RANGE),  # LEDs: pwm 0..255
    ],
)
def test_setpoint_refusals_name_the_first_failing_check(
    bridge: Bridge, board: int, slot: int, mode: int, raw: int, code: int
) -> None:
    bridge.start()
    assert bridge.ask(setpoint(3, board, slot, mode, raw)) == [nack(3, SETPOINT, code)]


def test_applied_setpoint_goes_to_its_board_and_clears_motors_off(bridge: Bridge) -> None:
    bridge.start()
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 800)) == [ack(3, SETPOINT)]
    bridge.bus()
    states = bridge.states(12)
    status = bridge.state(states[-1])[3]
    assert status[bridge.boards.index(22)] == ONLINE
    assert status[bridge.boards.index(23)] == ONLINE | MOTORS_OFF
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    # bend joint: never commanded (keep); drive: velocity 800
    assert to_22[-1][2:] == bytes([KEEP, 0, 0, VELOCITY]) + struct.pack("<h", 800)


def test_setpoint_while_latched_or_to_a_silent_board_is_refused(bridge: Bridge) -> None:
    bridge.run(25)
    bridge.hello(1)
    assert bridge.ask(setpoint(2, 22, 1, VELOCITY, 1)) == [nack(2, SETPOINT, ESTOP_LATCHED)]
    assert bridge.ask(frame(ESTOP_RESET, 3)) == [ack(3, ESTOP_RESET)]
    bridge.board(22, online=False)
    bridge.run(25)
    assert bridge.ask(setpoint(4, 22, 1, VELOCITY, 1)) == [nack(4, SETPOINT, BUS_ERROR)]
    assert bridge.ask(setpoint(5, 23, 1, VELOCITY, 1)) == [ack(5, SETPOINT)]


def test_bulk_is_all_or_nothing_and_acknowledged_by_state(bridge: Bridge) -> None:
    bridge.start()
    entries = [(KEEP, 0)] * len(bridge.motors)
    drive = next(m.index for m in bridge.motors if m.board == 22 and m.slot == 1)
    good = list(entries)
    good[drive] = (VELOCITY, 300)
    bad = list(good)
    bad[-1] = (PWM, 999)  # rear LEDs, out of range
    assert bridge.ask(bulk(3, bad)) == [nack(3, BULK, OUT_OF_RANGE)]
    bridge.bus()
    bridge.states(12)
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    assert to_22[-1][5:] == bytes([VELOCITY, 0, 0])  # still the boot stop setpoint
    assert bridge.ask(bulk(4, good), ms=1) == []
    states = bridge.states(12)
    assert bridge.state(states[-1])[0] == 4
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    assert to_22[-1][5:] == bytes([VELOCITY]) + struct.pack("<h", 300)
    assert bridge.ask(bulk(4, good)) == [ack(4, BULK, DUPLICATE)]
    wrong = frame(BULK, 5, payload=b"\xff\x00\x00" * (len(bridge.motors) - 1))
    assert bridge.ask(wrong) == [nack(5, BULK, BAD_LENGTH)]


# -- e-stop, stop category, watchdog ---------------------------------------------------


def _stops(bodies: list[bytes]) -> dict[int, bytes]:
    return {b[0]: b[2:] for b in bodies if b[1] == 0x02}


def test_estop_stops_drives_and_rotation_at_once_and_bend_joints_hold(bridge: Bridge) -> None:
    bridge.start()
    bend = next(m.index for m in bridge.motors if m.board == 22 and m.slot == 0)
    entries = [(KEEP, 0)] * len(bridge.motors)
    entries[bend] = (POSITION, 1000)
    bridge.ask(bulk(3, entries), ms=12)
    bridge.bus()
    assert bridge.ask(frame(ESTOP, 4), ms=1) == [ack(4, ESTOP)]
    stops = _stops(bridge.bus())
    # board bus 2: a STOP speaks the board's own modes: bend keeps, a drive brakes
    assert stops[22] == bytes([KEEP, 0, 0, PWM, 0, 0])
    assert stops[25] == bytes([PWM, 0, 0, PWM, 0, 0])  # rotate: pwm 0 = brake
    assert stops[21] == bytes([PWM, 0, 0, PWM, 0, 0])  # tilt and LEDs: brake
    assert 27 in stops and all(b in stops for b in (20, 23, 24, 26, 28))
    states = bridge.states(12)
    _, _, flags, status, _ = bridge.state(states[-1])
    assert flags & F_ESTOP and all(n & MOTORS_OFF for n in status)
    # the next exchanges keep the bend joint's position setpoint
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    assert to_22[-1][2:5] == bytes([POSITION]) + struct.pack("<h", 1000)
    # an ordered request sent before the e-stop and arriving after it is stale
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 9)) == [ack(3, SETPOINT, STALE)]
    assert bridge.ask(setpoint(5, 22, 1, VELOCITY, 9)) == [nack(5, SETPOINT, ESTOP_LATCHED)]


def test_a_rotate_motor_without_pwm_keeps_its_setpoint_on_a_stop(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """The stop category's exception (docs/protocol.md): a rotate or other motor whose
    description lists no pwm mode is not commanded by a stop; it keeps its setpoint."""
    robot_file = tmp_path_factory.mktemp("no-pwm") / "pirate.yaml"
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    rotate = "        function: rotate\n        assumption: true\n        modes: *joint_modes\n"
    assert text.count(rotate) == 1
    robot_file.write_text(
        text.replace(
            rotate,
            "        function: rotate\n        assumption: true\n        modes:\n"
            "          torque: {raw: [-1023, 1023], per_raw: 1 mN*m}\n"
            "          position: {raw: [-2048, 2047], per_raw: 0.087890625 deg}\n",
        )
    )
    try:
        library = build_host_library(tmp_path_factory.mktemp("fw-host-no-pwm"), robot_file)
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware core cannot be built")
        raise
    bridge = Bridge(library, load_robot(robot_file))
    bridge.start()
    assert bridge.ask(setpoint(3, 25, 0, PWM, 5)) == [nack(3, SETPOINT, BAD_MODE)]
    assert bridge.ask(setpoint(4, 25, 0, TORQUE, 200)) == [ack(4, SETPOINT)]
    bridge.run(12)
    bridge.bus()
    assert bridge.ask(frame(ESTOP, 5), ms=1) == [ack(5, ESTOP)]
    stops = _stops(bridge.bus())
    assert stops[25] == bytes([TORQUE]) + struct.pack("<h", 200) + bytes([PWM, 0, 0])
    assert stops[21] == bytes([PWM, 0, 0, PWM, 0, 0])  # the others as always


def test_estop_reset_is_refused_while_a_board_is_silent(bridge: Bridge) -> None:
    bridge.start()
    bridge.ask(frame(ESTOP, 3))
    bridge.board(26, online=False)
    bridge.run(25)
    assert bridge.ask(frame(ESTOP_RESET, 4)) == [nack(4, ESTOP_RESET, NOT_READY)]
    bridge.board(26, online=True)
    bridge.run(25)
    assert bridge.ask(frame(ESTOP_RESET, 5)) == [ack(5, ESTOP_RESET)]
    flags = bridge.state(bridge.states()[-1])[2]
    assert not flags & F_ESTOP


def test_watchdog_trips_after_silence_and_the_next_frame_clears_it(bridge: Bridge) -> None:
    bridge.start()
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 700)) == [ack(3, SETPOINT)]
    bridge.bus()
    bridge.run(240)
    assert not bridge.state(bridge.states(1)[-1])[2] & F_WATCHDOG
    bridge.run(30)
    flags = bridge.state(bridge.states()[-1])[2]
    assert flags & F_WATCHDOG and not flags & F_ESTOP
    assert _stops(bridge.bus())[22] == bytes([KEEP, 0, 0, PWM, 0, 0])
    assert bridge.ask(frame(HEARTBEAT, 50)) == [ack(50, HEARTBEAT)]
    assert not bridge.state(bridge.states()[-1])[2] & F_WATCHDOG
    counters = bridge.ask(frame(COUNTERS_REQUEST, 51))[0]
    assert struct.unpack("<5I", counters.payload[:20])[4] == 1
    # recovery needs no reset: new setpoints are accepted at once
    assert bridge.ask(setpoint(4, 22, 1, VELOCITY, 100)) == [ack(4, SETPOINT)]


# -- state frame and the bus ------------------------------------------------------------


def test_state_carries_board_readings_fresh_and_status(bridge: Bridge) -> None:
    for i in range(len(bridge.channels)):
        bridge.lib.fw_reading(i, ctypes.c_int16(i * 100 - 1000))
    bridge.run(25)
    _, fresh, _, status, values = bridge.state(bridge.states()[-1])
    assert values == [i * 100 - 1000 for i in range(len(bridge.channels))]
    assert fresh == (1 << len(bridge.channels)) - 1
    assert all(n & ONLINE for n in status)
    bridge.board(24, online=False)
    bridge.lib.fw_reading(11, 5)
    bridge.run(25)
    _, fresh, flags, status, values = bridge.state(bridge.states()[-1])
    imu = [c.index for c in bridge.channels if c.board == 24]
    assert all(not fresh >> i & 1 for i in imu) and fresh >> 16 & 1
    assert values[11] == 11 * 100 - 1000  # the last value read
    assert status[bridge.boards.index(24)] & TIMEOUT and not flags & F_BUS_FAULT
    counters = bridge.ask(frame(COUNTERS_REQUEST, 9))[0]
    per_board = counters.payload[20:]
    j = bridge.boards.index(24)
    board, timeouts, _crc, retries = struct.unpack("<BIII", per_board[13 * j : 13 * j + 13])
    assert board == 24 and timeouts >= 2 and retries >= 1


def test_whole_bus_silent_sets_bus_fault(bridge: Bridge) -> None:
    for board in bridge.boards:
        bridge.board(board, online=False)
    bridge.run(60)
    _, fresh, flags, status, _ = bridge.state(bridge.states()[-1])
    assert flags & F_BUS_FAULT and fresh == 0 and all(n & TIMEOUT for n in status)


def test_board_fault_is_reported_in_its_nibble(bridge: Bridge) -> None:
    bridge.board(27, online=True, status=0x01)
    bridge.run(25)
    status = bridge.state(bridge.states()[-1])[3]
    assert status[bridge.boards.index(27)] & FAULT


# -- bad frames -------------------------------------------------------------------------


def test_bad_frames_are_dropped_silently_and_counted(bridge: Bridge) -> None:
    import json

    vectors = json.loads(VECTORS.read_text())["bad"]
    silent = [v for v in vectors if v["reason"] in ("oversize", "cobs", "short", "crc", "version")]
    assert silent
    for v in silent:
        data = bytes.fromhex(v["hex"])
        # a vector cut off without its delimiter (oversize) ends at our next 0x00
        assert bridge.ask(data if data.endswith(b"\x00") else data + b"\x00") == [], v["name"]
    assert bridge.ask(b"\x01" * 300 + b"\x00") == []  # oversize
    counters = bridge.ask(frame(COUNTERS_REQUEST, 1))[0]
    rx, crc, framing, _, _ = struct.unpack("<5I", counters.payload[:20])
    want_crc = sum(v["reason"] == "crc" for v in silent)
    assert (rx, crc, framing) == (1, want_crc, len(silent) - want_crc + 1)


def test_unknown_and_bridge_types_get_unknown_type(bridge: Bridge) -> None:
    assert bridge.ask(frame(0x42, 3)) == [nack(3, 0x42, UNKNOWN_TYPE)]
    assert bridge.ask(frame(STATE, 4)) == [nack(4, STATE, UNKNOWN_TYPE)]
    assert bridge.ask(frame(HEARTBEAT, 5, payload=b"x")) == [nack(5, HEARTBEAT, BAD_LENGTH)]


def test_random_bytes_and_mutated_frames_change_nothing(bridge: Bridge) -> None:
    bridge.start()
    rng = random.Random(14)
    good = setpoint(3, 22, 1, VELOCITY, 400)
    noise = bytearray()
    for _ in range(2000):
        if rng.random() < 0.5:
            noise += bytes(rng.randrange(256) for _ in range(rng.randrange(1, 40)))
        else:
            mutated = bytearray(good)
            mutated[rng.randrange(len(mutated) - 1)] ^= 1 << rng.randrange(8)
            noise += mutated
    bridge.bus()
    for i in range(0, len(noise), 512):
        bridge.write(bytes(noise[i : i + 512]))
        bridge.run(50)
    answers = [f for f in bridge.read() if f.kind != STATE]
    assert all(f.kind in (ACK, NACK) for f in answers)
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    assert to_22 and all(b[5:] == bytes([VELOCITY, 0, 0]) for b in to_22)
    bridge.write(b"\x00")
    reply = bridge.hello(7)
    assert reply.kind == HELLO_REPLY and reply.seq == 7


# -- the conformance suite's adapter ----------------------------------------------------


def test_adapter_resets_disconnects_and_reconnects_a_board(library: Path, tmp_path: Path) -> None:
    from firmware_host import FirmwareHostBridge

    robot = load_robot()
    under_test = FirmwareHostBridge(robot, library, tmp_path)
    hello = frame(HELLO, 1, payload=struct.pack("<IB", robot.layout_digest(), 1))
    under_test.write(hello)
    first = [f for f in parse(under_test.read(0.03)) if f.kind == HELLO_REPLY]
    under_test.disconnect_board(26, 0.1)
    states = [f for f in parse(under_test.read(0.03)) if f.kind == STATE]
    j = sorted(robot.board_ids()).index(26)
    status = states[-1].payload[2 + 4 + j // 2] >> (4 * (j % 2)) & 0xF
    assert status & TIMEOUT
    states = [f for f in parse(under_test.read(0.1)) if f.kind == STATE]
    status = states[-1].payload[2 + 4 + j // 2] >> (4 * (j % 2)) & 0xF
    assert status & ONLINE and not status & TIMEOUT
    under_test.reset()
    under_test.write(hello)
    second = [f for f in parse(under_test.read(0.03)) if f.kind == HELLO_REPLY]
    boot = [struct.unpack("<IBBHHBHB", f.payload)[6] for f in (*first, *second)]
    assert len(boot) == 2 and boot[0] != boot[1]
    under_test.close()


def test_garbled_replies_count_as_crc_errors_and_the_board_times_out(bridge: Bridge) -> None:
    j = bridge.boards.index(23)
    bridge.lib.fw_board(j, 2, 0)
    bridge.run(35)
    _, fresh, _, status, _ = bridge.state(bridge.states()[-1])
    assert status[j] & TIMEOUT and not any(
        fresh >> c.index & 1 for c in bridge.channels if c.board == 23
    )
    counters = bridge.ask(frame(COUNTERS_REQUEST, 9))[0]
    board, timeouts, crc, retries = struct.unpack(
        "<BIII", counters.payload[20 + 13 * j : 33 + 13 * j]
    )
    assert board == 23 and crc >= 4 and timeouts == 0 and retries >= 2


def test_every_board_gets_polled_when_most_of_the_bus_is_dead(bridge: Bridge) -> None:
    """Eight silent boards take 1.5 ms each (and a retry): more than a period. The
    cycle goes on in the next period, so the last board is still polled."""
    for board in bridge.boards[:-1]:
        bridge.board(board, online=False)
    bridge.run(150)
    bridge.read()
    states = [bridge.state(s) for s in bridge.states(100)]
    last = bridge.boards[-1]
    rear = [c.index for c in bridge.channels if c.board == last]
    assert any(all(fresh >> i & 1 for i in rear) for _, fresh, _, _, _ in states)
    assert all(st[-1] & ONLINE for _, _, _, st, _ in states)
    assert not any(flags & F_BUS_FAULT for _, _, flags, _, _ in states)


def test_firmware_cobs_matches_the_host_codec(library: Path) -> None:
    lib = ctypes.CDLL(str(library))
    rng = random.Random(7)
    cases = [
        b"",
        b"\x00",
        b"\x00\x00",
        b"\x11" * 254,
        b"\x11" * 253 + b"\x00",
        b"\x00" + b"\x22" * 253,
    ]
    cases += [
        bytes(rng.choice((0, 0, rng.randrange(256))) for _ in range(rng.randrange(1, 255)))
        for _ in range(300)
    ]
    out = ctypes.create_string_buffer(300)
    back = ctypes.create_string_buffer(300)
    for body in cases:
        n = lib.cobs_encode(body, len(body), out)
        assert out.raw[:n] == cobs_encode(body), body.hex()
        if n > 0 and body:
            m = lib.cobs_decode(out, n, back, 254)
            assert back.raw[:m] == body
    # a receiver accepts a trailing 0x01 after a full block and adds nothing
    assert lib.cobs_decode(b"\xff" + b"\x11" * 254 + b"\x01", 256, back, 254) == 254
    assert lib.cobs_decode(b"\x05\x01\x02", 3, back, 254) == -1  # code past the end
