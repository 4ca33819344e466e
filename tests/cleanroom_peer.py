"""A clean-room peer of the PIRATEbay wire protocol, written from docs/protocol.md alone.

It imports nothing of ``pirate_bt.link``: framing (COBS, the 0x00 delimiter, the
255-byte limit), CRC-16/XMODEM, the body's header, the payload layouts and the layout
digest are spelled out here as the page gives them, so that a test can talk to our
bridge (as a host) and to our host (as a bridge) the way another implementation would.
The robot description is read only as data (its boards, motors and sensors).
"""

from __future__ import annotations

import hashlib
import socket
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from pirate_bt.robot.description import RobotDescription

VERSION = 1
HELLO, SETPOINT, BULK, HEARTBEAT, ESTOP, ESTOP_RESET, COUNTERS_REQUEST = range(1, 8)
HELLO_REPLY, STATE, ACK, NACK, COUNTERS, BRIDGE_HEARTBEAT = range(0x81, 0x87)
APPLIED, DUPLICATE, STALE = 0, 1, 2
(
    UNKNOWN_TYPE,
    BAD_LENGTH,
    BAD_LAYOUT,
    BAD_BOARD,
    BAD_SLOT,
    BAD_MODE,
    OUT_OF_RANGE,
    ESTOP_LATCHED,
    BUS_ERROR,
    NOT_READY,
) = range(1, 11)
F_ESTOP, F_WATCHDOG, F_BUS_FAULT, F_NO_SESSION, F_ESTOP_INPUT = 1, 2, 4, 8, 16
MODE_CODES = {"pwm": 0, "torque": 1, "position": 2, "velocity": 3}
KEEP = 0xFF


def crc16(data: bytes) -> int:
    """CRC-16/XMODEM: poly 0x1021, init 0, no reflection, no xorout."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def cobs_encode(body: bytes) -> bytes:
    """COBS; a body ending in a whole 254-byte block gets no trailing 0x01 block."""
    out = bytearray()
    block = bytearray()
    last_full = False
    for byte in body:
        last_full = False
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block.clear()
            continue
        block.append(byte)
        if len(block) == 254:
            out += b"\xff" + block
            block.clear()
            last_full = True
    if not last_full:
        out += bytes([len(block) + 1]) + block
    return bytes(out)


def cobs_decode(data: bytes) -> bytes | None:
    """The body, or None when a code byte points past the end (``cobs``)."""
    out = bytearray()
    i = 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            return None
        out += data[i + 1 : i + code]
        i += code
        if code < 255 and i < len(data):
            out.append(0)
    return bytes(out)


def frame(kind: int, seq: int, payload: bytes = b"", arg: int = 0, version: int = VERSION) -> bytes:
    """One frame on the wire: COBS(body) 0x00."""
    body = bytes([version, kind]) + struct.pack("<H", seq & 0xFFFF) + bytes([arg]) + payload
    body += struct.pack("<H", crc16(body))
    return cobs_encode(body) + b"\x00"


@dataclass(frozen=True)
class Frame:
    version: int
    kind: int
    seq: int
    arg: int
    payload: bytes


@dataclass
class Decoder:
    """Cuts a byte stream at each 0x00; frames and the reasons of bad ones, in order."""

    buffer: bytearray = field(default_factory=bytearray)
    skipping: bool = False

    def feed(self, data: bytes) -> list[Frame | str]:
        out: list[Frame | str] = []
        for byte in data:
            if byte != 0:
                if self.skipping:
                    continue
                self.buffer.append(byte)
                if len(self.buffer) > 255:
                    out.append("oversize")
                    self.buffer.clear()
                    self.skipping = True
                continue
            if self.skipping:
                self.skipping = False
                continue
            if self.buffer:
                out.append(_judge(bytes(self.buffer)))
                self.buffer.clear()
        return out


def _judge(encoded: bytes) -> Frame | str:
    body = cobs_decode(encoded)
    if body is None:
        return "cobs"
    if len(body) > 254:
        return "oversize"
    if len(body) < 7:
        return "short"
    if crc16(body[:-2]) != struct.unpack_from("<H", body, len(body) - 2)[0]:
        return "crc"
    if body[0] != VERSION:
        return "version"
    return Frame(body[0], body[1], struct.unpack_from("<H", body, 2)[0], body[4], body[5:-2])


@dataclass(frozen=True)
class Layout:
    """What both ends compute from the robot description (docs/protocol.md, Layout)."""

    channels: list[tuple[int, str]]
    motors: list[tuple[int, int, str, dict[str, tuple[int, int]]]]
    boards: list[int]
    channel_raw: list[tuple[int, int]]

    @property
    def digest(self) -> int:
        c = ";".join(f"{b}:{n}" for b, n in self.channels)
        m = ";".join(
            f"{b}:{s}:{role}:"
            + ",".join(f"{mode}={lo}..{hi}" for mode, (lo, hi) in sorted_modes(modes))
            for b, s, role, modes in self.motors
        )
        return int.from_bytes(hashlib.sha256(f"{c}|{m}".encode("ascii")).digest()[:4], "big")

    def state_payload(
        self,
        *,
        ack_seq: int = 0,
        values: list[int] | None = None,
        fresh: bool = True,
        status: int = 1,
    ) -> bytes:
        n = len(self.channels)
        vals = values if values is not None else [lo for lo, _ in self.channel_raw]
        mask = bytearray((n + 7) // 8)
        if fresh:
            for i in range(n):
                mask[i // 8] |= 1 << (i % 8)
        nibbles = bytearray((len(self.boards) + 1) // 2)
        for j in range(len(self.boards)):
            nibbles[j // 2] |= status << (4 * (j % 2))
        return (
            struct.pack("<H", ack_seq) + bytes(mask) + bytes(nibbles) + struct.pack(f"<{n}h", *vals)
        )

    def parse_state(self, payload: bytes) -> tuple[int, list[int]]:
        n = len(self.channels)
        at = 2 + (n + 7) // 8 + (len(self.boards) + 1) // 2
        assert len(payload) == at + 2 * n, len(payload)
        return struct.unpack_from("<H", payload)[0], list(struct.unpack_from(f"<{n}h", payload, at))


def sorted_modes(modes: dict[str, tuple[int, int]]) -> list[tuple[str, tuple[int, int]]]:
    return sorted(modes.items(), key=lambda item: MODE_CODES[item[0]])


def layout_of(robot: RobotDescription) -> Layout:
    """The layout, from the description's boards, sensors and motors (data only)."""
    channels: list[tuple[int, str]] = []
    raws: list[tuple[int, int]] = []
    motors: list[tuple[int, int, str, dict[str, tuple[int, int]]]] = []
    for board in sorted(robot.boards, key=lambda b: b.id):
        for sensor in sorted(board.sensors, key=lambda s: s.slot):
            names = (
                [f"{sensor.name}.{a}" for a in ("roll", "pitch", "yaw")]
                if str(sensor.kind) == "imu"
                else [sensor.name]
            )
            for name in names:
                channels.append((board.id, name))
                raws.append(tuple(sensor.raw))  # type: ignore[arg-type]
        for motor in sorted(board.motors, key=lambda m: m.slot):
            for what in ("velocity", "current"):
                conv = getattr(motor.feedback, what, None)
                if conv is not None:
                    channels.append((board.id, f"{motor.name}.{what}"))
                    raws.append(tuple(conv.raw))  # type: ignore[arg-type]
            function = str(motor.function.value)
            role = function if function in ("drive", "rotate", "bend") else "other"
            modes = {
                name: tuple(conv.raw)
                for name in MODE_CODES
                if (conv := getattr(motor.modes, name, None)) is not None
            }
            motors.append((board.id, motor.slot, role, modes))  # type: ignore[arg-type]
    boards = sorted({b for b, _ in channels} | {b for b, *_ in motors})
    return Layout(channels, motors, boards, raws)


def hello(seq: int, layout: Layout, minor: int = 2) -> bytes:
    return frame(HELLO, seq, struct.pack("<IB", layout.digest, minor))


def bulk(seq: int, entries: list[tuple[int, int]]) -> bytes:
    return frame(BULK, seq, b"".join(struct.pack("<Bh", m, v) for m, v in entries))


def parse_hello_reply(payload: bytes) -> dict[str, int]:
    names = ("digest", "channels", "motors", "watchdog_ms", "firmware", "minor", "boot_id")
    values = struct.unpack("<IBBHHBHB", payload)
    return dict(zip((*names, "sessions"), values, strict=True))


def hello_reply_payload(
    layout: Layout, *, minor: int = 2, sessions: int = 1, boot_id: int = 0x1234
) -> bytes:
    return struct.pack(
        "<IBBHHBHB",
        layout.digest,
        len(layout.channels),
        len(layout.motors),
        250,
        0x0001,
        minor,
        boot_id,
        sessions,
    )


def counters_payload(layout: Layout, boards: int | None = None) -> bytes:
    n = len(layout.boards) if boards is None else boards
    return struct.pack("<5I", 0, 0, 0, 0, 0) + b"".join(
        struct.pack("<B3I", layout.boards[i % len(layout.boards)], 0, 0, 0) for i in range(n)
    )


class PeerBridge:
    """A bridge written from the page, serving one host on a TCP socket in real time.

    It answers as the page says (``HELLO``, ``ESTOP_RESET``, ``ESTOP``, ``HEARTBEAT``,
    ``SETPOINT``, ``BULK_SETPOINTS``, ``COUNTERS_REQUEST``) and sends a ``STATE`` every
    10 ms. ``on_frame(frame)`` may return the bytes to answer instead (``b""`` for
    none) or ``None`` for the page's answer; ``state(n)`` may return the payload (and
    flags) of the n-th ``STATE`` instead of the page's.
    """

    def __init__(
        self,
        layout: Layout,
        *,
        on_frame: Callable[[Frame], bytes | None] | None = None,
        state: Callable[[int, PeerBridge], tuple[bytes, int] | bytes | None] | None = None,
    ) -> None:
        self.layout = layout
        self.on_frame = on_frame
        self.state = state
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.bind(("127.0.0.1", 0))
        self.listener.listen(1)
        self.url = f"socket://127.0.0.1:{self.listener.getsockname()[1]}"
        self.received: list[Frame] = []
        self.changed = threading.Condition()
        self.estopped = True
        self.session = False
        self.ack_seq = 0
        self.boot_id = 0x1234
        self.sessions = 0
        # readings at rest: 0 where the raw range is signed (an IMU, a speed), else mid-range
        self.values = [0 if lo < 0 <= hi else (lo + hi) // 2 for lo, hi in layout.channel_raw]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="peer-bridge", daemon=True)
        self._thread.start()

    def reset(self) -> None:
        """A bridge reset: latched, no session, a new boot id."""
        self.estopped, self.session, self.ack_seq, self.sessions = True, False, 0, 0
        self.boot_id = (self.boot_id + 1) & 0xFFFF

    def flags(self) -> int:
        return (F_ESTOP if self.estopped else 0) | (0 if self.session else F_NO_SESSION)

    def wait_for(self, test: Callable[[list[Frame]], bool], timeout_s: float = 20.0) -> bool:
        """Wait (at most ``timeout_s``) until ``test`` holds on the frames received."""
        with self.changed:
            return self.changed.wait_for(lambda: test(self.received), timeout_s)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10.0)
        self.listener.close()

    def _answer(self, f: Frame) -> bytes:
        if f.kind == HELLO:
            self.session = True
            self.ack_seq = 0
            self.sessions = min(self.sessions + 1, 255)
        override = self.on_frame(f) if self.on_frame is not None else None
        if override is not None:
            return override
        if f.kind == HELLO:
            payload = hello_reply_payload(self.layout, sessions=self.sessions, boot_id=self.boot_id)
            return frame(HELLO_REPLY, f.seq, payload, self.flags())
        if f.kind == ESTOP_RESET:
            self.estopped = False
            return frame(ACK, f.seq, bytes([ESTOP_RESET, APPLIED]))
        if f.kind in (ESTOP, HEARTBEAT, SETPOINT):
            if f.kind == ESTOP:
                self.estopped = True
            return frame(ACK, f.seq, bytes([f.kind, APPLIED]))
        if f.kind == BULK:
            if self.estopped:
                return frame(NACK, f.seq, bytes([BULK, ESTOP_LATCHED]))
            self.ack_seq = f.seq
            return b""
        if f.kind == COUNTERS_REQUEST:
            return frame(COUNTERS, f.seq, counters_payload(self.layout))
        return frame(NACK, f.seq, bytes([f.kind, UNKNOWN_TYPE]))

    def _serve(self) -> None:
        self.listener.settimeout(0.05)
        conn = None
        while conn is None and not self._stop.is_set():
            try:
                conn, _ = self.listener.accept()
            except TimeoutError:
                continue
        if conn is None:
            return
        conn.settimeout(0.002)
        decoder = Decoder()
        n = 0
        next_state = time.monotonic()
        with conn:
            while not self._stop.is_set():
                try:
                    data = conn.recv(4096)
                    if not data:
                        break
                except TimeoutError:
                    data = b""
                except OSError:
                    break
                out = bytearray()
                for item in decoder.feed(data):
                    if isinstance(item, Frame):
                        out += self._answer(item)
                        with self.changed:
                            self.received.append(item)
                            self.changed.notify_all()
                now = time.monotonic()
                if now >= next_state:
                    next_state = max(next_state + 0.01, now)
                    n += 1
                    custom = self.state(n, self) if self.state is not None else None
                    if custom is None:
                        payload = self.layout.state_payload(
                            ack_seq=self.ack_seq, values=self.values
                        )
                        out += frame(STATE, n, payload, self.flags())
                    elif isinstance(custom, bytes):
                        out += custom
                    else:
                        out += frame(STATE, n, custom[0], custom[1])
                if out:
                    try:
                        conn.sendall(bytes(out))
                    except OSError:
                        break
