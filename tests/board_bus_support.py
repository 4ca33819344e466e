"""The board bus as docs/board-bus.md writes it, and the firmwares' host builds, for
``test_board_bus_hostile.py``.

The independent end (:class:`DocBoard`, :func:`doc_request`, :func:`doc_take_reply`)
is written from docs/board-bus.md alone; its CRC-16/XMODEM and COBS are the ones the
page takes from docs/protocol.md, written from that page in ``doc_protocol.py``. Only
the robot's layout (boards, motors, modes, ranges and channels) comes from the robot
description, as the page says. The host builds (:class:`Pico`, :class:`BusMaster`)
wrap the PICO and bridge firmwares' C, built by ``make host``.
"""

from __future__ import annotations

import ctypes
import heapq
import json
import os
import random
import shutil
import struct
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from doc_protocol import doc_cobs_encode, doc_crc

from pirate_bt.link.layout import StopRole, stop_role
from pirate_bt.robot.description import ControlMode
from pirate_bt.robot.loader import load_robot
from pirate_bt.sim.boardbus import BoardBus

ROOT = Path(__file__).resolve().parents[1]
ROBOT = load_robot()
BOARDS = sorted(ROBOT.board_ids())
MODE_CODE = {
    ControlMode.PWM: 0,
    ControlMode.TORQUE: 1,
    ControlMode.POSITION: 2,
    ControlMode.VELOCITY: 3,
}
KEEP = 0xFF
EXCHANGE, STOP, REPLY = 0x01, 0x02, 0x81
FAULT, MOTORS_OFF, OWN_STOP = 0x01, 0x02, 0x04
SILENCE_S = 0.100
BODY_MAX = 32
VECTORS: dict[str, Any] = json.loads(
    (Path(__file__).parent / "data" / "board_bus_vectors.json").read_text()
)
# per board, from the vectors' sequences: the PICO's inputs and the channels they give
BOARD_INPUTS: dict[int, tuple[dict[str, list[int]], list[int]]] = {
    s["board"]: (s["steps"][0]["pico_inputs"], s["steps"][0]["channels"])
    for s in VECTORS["sequences"]
}
CHANNELS_22 = BOARD_INPUTS[22][1]


# -- the page, written out: COBS, CRC, frames ------------------------------------------------


crc16_xmodem = doc_crc
cobs_encode = doc_cobs_encode  # a bus body (at most 33 bytes) never ends in a 0xFF block


def cobs_decode(data: bytes) -> bytes | None:
    out, i = bytearray(), 0
    if not data:
        return None
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            return None
        out += data[i + 1 : i + code]
        i += code
        if code != 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def wire(body: bytes) -> bytes:
    """A frame on the line: COBS(body, CRC little-endian) 0x00."""
    return cobs_encode(body + crc16_xmodem(body).to_bytes(2, "little")) + b"\x00"


@dataclass(frozen=True)
class MotorInfo:
    role: StopRole
    ranges: dict[int, tuple[int, int]]  # mode code -> raw range


@dataclass(frozen=True)
class BoardInfo:
    id: int
    motors: list[MotorInfo]
    n_channels: int


def _layout() -> dict[int, BoardInfo]:
    motors: dict[int, list[MotorInfo]] = {b: [] for b in BOARDS}
    for slot in ROBOT.setpoint_slots():  # slot order within a board
        ranges = {
            MODE_CODE[mode]: conv.raw
            for mode in ControlMode
            if (conv := slot.motor.modes.get(mode)) is not None
        }
        motors[slot.board].append(MotorInfo(stop_role(slot.motor), ranges))
    channels = {b: 0 for b in BOARDS}
    for channel in ROBOT.state_channels():
        channels[channel.board] += 1
    return {b: BoardInfo(b, motors[b], channels[b]) for b in BOARDS}


LAYOUT = _layout()


def doc_request(addr: int, cmd: int, setpoints: list[tuple[int, int]]) -> bytes:
    """The master's EXCHANGE or STOP: addr, cmd, then ``uint8 mode, int16 raw`` each."""
    body = bytes([addr, cmd]) + b"".join(struct.pack("<Bh", m, r) for m, r in setpoints)
    return wire(body)


def doc_take_reply(addr: int, frame: bytes) -> tuple[int, list[int]] | None:
    """The master's checks of one reply frame (COBS, no delimiter): status and channels,
    or None for a bad reply (COBS, length, CRC, address, command)."""
    body = cobs_decode(frame)
    n = LAYOUT[addr].n_channels
    if body is None or len(body) != 5 + 2 * n or len(body) > BODY_MAX:
        return None
    if crc16_xmodem(body[:-2]) != int.from_bytes(body[-2:], "little"):
        return None
    if body[0] != addr or body[1] != REPLY:
        return None
    return body[2], list(struct.unpack(f"<{n}h", body[3:-2]))


@dataclass
class DocBoard:
    """One board from the page: frames, checks, EXCHANGE, STOP, the board-side timeout."""

    info: BoardInfo
    channels: list[int]
    now_s: float = 0.0
    heard_s: float = 0.0
    own_stop: bool = False
    raw: bytearray = field(default_factory=bytearray)
    damaged: bool = False
    state: list[tuple[int, int] | None] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.state = [None] * len(self.info.motors)

    def advance(self, now_s: float) -> None:
        self.now_s = now_s
        if not self.own_stop and now_s - self.heard_s > SILENCE_S + 1e-9:
            self.own_stop = True
            for k, motor in enumerate(self.info.motors):
                if motor.role is StopRole.BEND:
                    continue  # the clamp holds its torque
                if 0 in motor.ranges:
                    self.state[k] = (0, 0)  # pwm 0: brake
                elif motor.role is StopRole.DRIVE:
                    self.state[k] = (3, 0)  # velocity 0: brake

    def receive(self, data: bytes, damaged_at: int | None = None) -> bytes:
        """Bytes off the line; the replies this board sends (wire bytes)."""
        out = b""
        for i, byte in enumerate(data):
            if i == damaged_at:
                self.damaged = True
            if byte:
                self.raw.append(byte)
                continue
            frame, damaged = bytes(self.raw), self.damaged
            self.raw.clear()
            self.damaged = False
            if frame and not damaged:
                out += self._frame(frame)
        return out

    def _frame(self, frame: bytes) -> bytes:
        body = cobs_decode(frame)
        if body is None or not 4 <= len(body) <= BODY_MAX:
            return b""
        if crc16_xmodem(body[:-2]) != int.from_bytes(body[-2:], "little"):
            return b""
        addr, cmd, payload = body[0], body[1], body[2:-2]
        if addr != self.info.id or cmd not in (EXCHANGE, STOP):
            return b""
        if len(payload) != 3 * len(self.info.motors):
            return b""
        self.heard_s = self.now_s
        if cmd == STOP:
            self.own_stop = False
            self._apply(payload)
            return b""
        if not self.own_stop:
            self._apply(payload)
        status = (MOTORS_OFF if None in self.state else 0) | (OWN_STOP if self.own_stop else 0)
        reply = bytes([self.info.id, REPLY, status])
        reply += struct.pack(f"<{len(self.channels)}h", *self.channels)
        return wire(reply)

    def _apply(self, payload: bytes) -> None:
        for k, (mode, raw) in enumerate(struct.iter_unpack("<Bh", payload)):
            accepted = self.info.motors[k].ranges.get(mode)
            if accepted is not None and accepted[0] <= raw <= accepted[1]:
                self.state[k] = (mode, raw)


# -- the two firmwares' host builds ---------------------------------------------------------

ASAN = "-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer"


def _make(directory: str, build: Path, *args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [
            "make",
            "-s",
            "-C",
            str(ROOT / "firmware" / directory),
            "host",
            f"BUILD={build}",
            f"PIRATE_BT={sys.executable} -m pirate_bt",
            *args,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
    )


def _wait(proc: subprocess.Popen[str]) -> None:
    out, _ = proc.communicate()
    if proc.returncode != 0:
        raise RuntimeError(f"building a host library failed:\n{out}")


@dataclass
class Builds:
    plain: Path
    asan: Path
    asan_jobs: list[subprocess.Popen[str]]

    def asan_ready(self) -> Path:
        for job in self.asan_jobs:
            _wait(job)
        self.asan_jobs = []
        return self.asan


def _layout_header(build: Path) -> None:
    """What ``make`` would generate first (``pirate-bt robot header``), written here at
    once: newer than its sources, so the four builds need no Python of their own."""
    from pirate_bt.robot.header import render_header

    robot_file = ROOT / "hardware" / "pirate.yaml"
    (build / "robot.path").write_text(f"{robot_file}\n")
    (build / "layout.h").write_text(render_header(load_robot(robot_file), str(robot_file)))
    old = robot_file.stat().st_mtime - 1
    os.utime(build / "robot.path", (old, old))


class Pico:
    """The PICO firmware's host build, one board, a private copy of its static state."""

    def __init__(self, library: Path, workdir: Path) -> None:
        copy = workdir / f"pico-{id(self)}.so"
        shutil.copy(library, copy)
        self.lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
        self.now_us = 0

    def boot(self, board: int) -> None:
        inputs = BOARD_INPUTS[board][0]
        self.lib.pk_boot(board, 0)
        self.lib.pk_imu(*inputs["imu"])
        for i, value in enumerate(inputs["adc"]):
            self.lib.pk_adc(i, value)

    def run_to(self, us: int) -> None:
        if us > self.now_us:
            self.lib.pk_run_us(ctypes.c_uint32(us - self.now_us))
            self.now_us = us

    def write(self, data: bytes, damaged_at: int | None = None) -> None:
        for i, byte in enumerate(data):
            if i == damaged_at:
                self.lib.pk_write_damaged(byte)
            else:
                self.lib.pk_write(bytes([byte]), 1)

    def read(self) -> bytes:
        buf = ctypes.create_string_buffer(4096)
        n = self.lib.pk_read(buf, len(buf))
        return buf.raw[:n]

    def motors(self, n: int) -> list[tuple[int, int] | None]:
        out = []
        for k in range(n):
            value = (ctypes.c_int16 * 2)()
            self.lib.pk_state(k, value)
            out.append(None if value[0] == 0xFE else (value[0], value[1]))
        return out


class Splitter:
    """The Python boards' line: bytes to frames at each 0x00 (the harness's job)."""

    def __init__(self, bus: BoardBus, board: int) -> None:
        self.bus, self.board, self.raw = bus, board, bytearray()

    def receive(self, now_s: float, data: bytes) -> bytes:
        out = b""
        for byte in data:
            if byte:
                self.raw.append(byte)
                continue
            frame = bytes(self.raw)
            self.raw.clear()
            if frame:
                answer = self.bus.handle(now_s, frame)
                body = cobs_decode(answer[:-1]) if answer else None
                if body and body[0] == self.board:  # every board is here: ours only
                    out += answer
        self.bus.advance_to(now_s)
        return out

    def motors(self) -> list[tuple[int, int] | None]:
        slots = [s.slot for s in ROBOT.setpoint_slots() if s.board == self.board]
        return [self.bus.motor_state(self.board, slot) for slot in slots]


def _setpoints(rng: random.Random, n: int) -> list[tuple[int, int]]:
    out = []
    for _ in range(n):
        mode = rng.choice([0, 1, 2, 3, KEEP, KEEP, rng.randrange(4, 255)])
        raw = rng.choice([0, rng.randint(-300, 300), rng.randint(-2100, 2100)])
        out.append((mode, rng.randint(-32768, 32767) if rng.random() < 0.1 else raw))
    return out


def hostile_stream(rng: random.Random, board: int) -> bytes:
    """A stream of the bytes a board may hear: good frames among every kind of bad one."""
    n_motors = len(LAYOUT[board].motors)
    others = [b for b in BOARDS if b != board] + [0, 1, 0x7F, 0x80 | board, 0xFF]
    out = bytearray()
    for _ in range(rng.randint(5, 40)):
        kind = rng.randrange(11)
        good = doc_request(board, rng.choice([EXCHANGE, STOP]), _setpoints(rng, n_motors))
        if kind <= 1:
            out += good
        elif kind == 2:  # a good frame to another board, or to no board at all
            addr = rng.choice(others)
            motors = len(LAYOUT[addr].motors) if addr in LAYOUT else rng.randint(0, 3)
            out += doc_request(addr, rng.choice([EXCHANGE, STOP]), _setpoints(rng, motors))
        elif kind == 3:  # CRC-valid nonsense: any address, command and length
            addr = rng.choice([board, *others])
            body = bytes([addr, rng.randrange(256)]) + rng.randbytes(rng.randint(0, 34))
            out += wire(body)
        elif kind == 4:  # the right length and CRC, a command that is not the board's
            cmd = rng.choice([0x00, 0x03, REPLY, 0x82, 0xFF, EXCHANGE | 0x40])
            out += doc_request(board, cmd, _setpoints(rng, n_motors))
        elif kind == 5:  # one entry too few or too many
            count = max(0, n_motors + rng.choice([-1, 1, 2]))
            out += doc_request(board, rng.choice([EXCHANGE, STOP]), _setpoints(rng, count))
        elif kind == 6:  # a good frame, damaged: a bit flipped, a byte lost or doubled
            frame = bytearray(good)
            i = rng.randrange(len(frame) - 1)
            how = rng.randrange(4)
            if how == 0:
                frame[i] ^= 1 << rng.randrange(8)
            elif how == 1:
                del frame[i]
            elif how == 2:
                frame.insert(i, frame[i])
            else:
                frame = frame[: rng.randrange(1, len(frame))]  # truncated: runs into the next
            out += frame
        elif kind == 7:  # noise
            out += bytes(rng.choice([0, rng.randrange(1, 256)]) for _ in range(rng.randint(1, 40)))
        elif kind == 8:  # longer than any frame, then the delimiter
            out += bytes(rng.randrange(1, 256) for _ in range(rng.randint(34, 300))) + b"\x00"
        elif kind == 9:  # lone delimiters
            out += b"\x00" * rng.randint(1, 3)
        else:  # a good frame with its trailing bytes replaced: CRC fails
            out += good[:-3] + bytes([rng.randrange(1, 256), rng.randrange(1, 256), 0])
    return bytes(out)


def _slots(stream: bytes) -> list[bytes]:
    """The stream cut after each 0x00: one piece per millisecond on the line."""
    pieces, start = [], 0
    for i, byte in enumerate(stream):
        if byte == 0:
            pieces.append(stream[start : i + 1])
            start = i + 1
    if start < len(stream):
        pieces.append(stream[start:])
    return pieces


# -- hostile boards behind the bridge firmware ------------------------------------------------

TURNAROUND_US = 150  # a board's, as the PICO firmware's in the chain
ONLINE, B_FAULT, TIMEOUT, B_MOTORS_OFF = 1, 2, 4, 8
F_BUS_FAULT = 4
STATE_KIND = 0x82

Behaviour = Any  # (request body, the page board's reply) -> [(delay µs, bytes)]


class BusMaster:
    """The bridge firmware's host build with the page's boards (:class:`DocBoard`) on its
    bus, each answering after its turnaround at the line's byte rate, unless a test
    gives a board another behaviour."""

    def __init__(self, library: Path, workdir: Path) -> None:
        from test_firmware_core import Bridge

        copy = workdir / f"bridge-{id(self)}.so"
        shutil.copy(library, copy)
        self.host = Bridge(copy, ROBOT)
        self.lib = self.host.lib
        self.lib.fw_now_us.restype = ctypes.c_uint64
        for index in range(len(BOARDS)):
            self.lib.fw_board(index, 0, 0)  # nobody answers but the boards below
        self.boards = {
            b: DocBoard(LAYOUT[b], [10 * b + k for k in range(LAYOUT[b].n_channels)])
            for b in BOARDS
        }
        self.behaviour: dict[int, Behaviour] = {}
        self.line: list[tuple[int, int, bool]] = []  # (µs, byte, flagged) on the line
        self.sent: list[tuple[int, bytes]] = []  # (µs, body without CRC) the bridge sent
        self.seq = 100
        self.last_state: Any = None

    @property
    def now_us(self) -> int:
        return int(self.lib.fw_now_us())

    def run(self, ms: float, step_us: int = 10) -> None:
        end = self.now_us + round(ms * 1000)
        while self.now_us < end:
            self.lib.fw_run_us(ctypes.c_uint32(step_us))
            now = self.now_us
            for body in self.host.bus():
                self.sent.append((now, body))
                self._heard(now, body)
            due = bytearray()
            while self.line and self.line[0][0] <= now:
                _, byte, flagged = heapq.heappop(self.line)
                if flagged:
                    self.lib.fw_bus_inject(bytes(due), len(due))
                    due.clear()
                    self.lib.fw_bus_inject_damaged(byte)
                else:
                    due.append(byte)
            if due:
                self.lib.fw_bus_inject(bytes(due), len(due))

    def _heard(self, now: int, body: bytes) -> None:
        frame = wire_with_crc(body)
        for board in self.boards.values():
            board.advance(now / 1e6)
            reply = board.receive(frame)
            if body[0] != board.info.id or body[1] != EXCHANGE:
                continue
            behaviour = self.behaviour.get(board.info.id)
            answers = behaviour(body, reply) if behaviour else [(TURNAROUND_US, reply)]
            for answer in answers:
                self.put(now + answer[0], *answer[1:])

    def put(self, at_us: int, data: bytes, flagged: int | None = None) -> None:
        """Bytes on the line from `at_us`, one per 10 µs (1 Mbaud 8N1); the byte at
        index `flagged` with a framing error."""
        for i, byte in enumerate(data):
            heapq.heappush(self.line, (at_us + 10 * i, byte, i == flagged))

    def state(self) -> tuple[int, int, list[int], list[int]]:
        """The last STATE: fresh mask, flags, board status nibbles, channels."""
        self.last_state = (self.host.states(0) or [self.last_state])[-1]
        _, fresh, flags, status, values = self.host.state(self.last_state)
        return fresh, flags, status, values

    def counters(self) -> dict[int, tuple[int, int, int]]:
        """(timeouts, crc_errors, retries) of every board, from a COUNTERS answer."""
        from test_firmware_core import COUNTERS_REQUEST, frame

        self.seq += 1
        self.host.write(frame(COUNTERS_REQUEST, self.seq))
        self.run(2)
        got = self.host.read()
        self.last_state = ([self.last_state] + [f for f in got if f.kind == STATE_KIND])[-1]
        (answer,) = [f for f in got if f.kind != STATE_KIND and f.seq == self.seq]
        out = {}
        for j, board in enumerate(BOARDS):
            part = answer.payload[20 + 13 * j : 33 + 13 * j]
            out[board] = struct.unpack("<BIII", part)[1:]
        return out

    def fresh(self, board: int, fresh: int) -> bool:
        mine = [c.index for c in ROBOT.state_channels() if c.board == board]
        return all(fresh >> i & 1 for i in mine)


def wire_with_crc(body: bytes) -> bytes:
    """The bus log holds bodies without their CRC: the frame as it was on the line."""
    return wire(body)


# -- replies and behaviours the tests give the page's boards ------------------------------


def _reply(
    board: int, status: int = 0, channels: list[int] | None = None, cmd: int = REPLY
) -> bytes:
    values = channels if channels is not None else [7] * LAYOUT[22].n_channels
    return wire(bytes([board, cmd, status]) + struct.pack(f"<{len(values)}h", *values))


def _crc_broken(board: int) -> bytes:
    frame = bytearray(cobs_decode(_reply(board)[:-1]) or b"")
    frame[-1] ^= 0x40
    return cobs_encode(bytes(frame)) + b"\x00"


# name -> (what board 22 answers each EXCHANGE with, after its turnaround)
BAD_REPLIES: dict[str, bytes] = {
    "another_boards_reply": _reply(23),
    "its_own_request_echoed": doc_request(22, EXCHANGE, [(KEEP, 0), (KEEP, 0)]),
    "not_a_reply_command": _reply(22, cmd=0x82),
    "a_channel_short": _reply(22, channels=[1, 2, 3]),
    "a_channel_long": _reply(22, channels=[1, 2, 3, 4, 5]),
    "crc_broken": _crc_broken(22),
    "cobs_broken": b"\x09" + _reply(22)[1:],
    "empty_body": wire(b""),
    "noise": bytes(range(1, 18)) + b"\x00",
    "to_no_board": _reply(0),
}
GOOD_REPLIES: dict[str, bytes] = {
    "a_leading_delimiter": b"\x00" + _reply(22),
    "unknown_status_bits": _reply(22, status=0xF0),  # bits 4-7: no meaning, ignored
    "stale": _reply(22, status=0x08),  # bit 3: its sensors not read (not fresh)
    "all_zero_channels": _reply(22, channels=[0, 0, 0, 0]),
}


def _random_reply(rng: random.Random) -> bytes:
    good = _reply(22, status=rng.choice([0, 1, 2, 3]), channels=[rng.randint(-99, 99)] * 4)
    kind = rng.randrange(4)
    if kind == 0:  # CRC-valid, any address, command and length
        addr = rng.choice([22, 22, 23, 0, 0xFF])
        cmd = rng.choice([REPLY, REPLY, EXCHANGE, 0x80, rng.randrange(256)])
        return wire(bytes([addr, cmd]) + rng.randbytes(rng.choice([9, 9, 8, 10, 1, 30])))
    frame = bytearray(good[:-1])
    i = rng.randrange(len(frame))
    if kind == 1:
        frame[i] ^= 1 << rng.randrange(8)
    elif kind == 2:
        del frame[i]
    else:
        frame.insert(i, rng.randrange(1, 256))
    return bytes(b for b in frame if b) + b"\x00"


def _once(answer: list[tuple[int, bytes]]) -> Behaviour:
    """A board that answers its first poll so, and every other one as the page says."""
    done: list[bool] = []

    def behaviour(body: bytes, reply: bytes) -> list[tuple[int, bytes]]:
        if done:
            return [(TURNAROUND_US, reply)]
        done.append(True)
        return answer

    return behaviour
