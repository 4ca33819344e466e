"""The PIRATEbay wire protocol written from ``docs/protocol.md`` and the robot's YAML
alone, with no ``pirate_bt.link`` code: the CRC, COBS, frames, the layout digest and
a host (:class:`DocHost`) that drives the simulator over its bytes. Shared by the tests
that check the library and the firmware against the page (``test_hostile_frames.py``,
``test_board_bus_hostile.py``, whose bus uses the same CRC and COBS).
"""

from __future__ import annotations

import struct
from hashlib import sha256
from pathlib import Path

import yaml

from pirate_bt.sim import Simulator

ROBOT_YAML = Path(__file__).resolve().parents[1] / "hardware" / "pirate.yaml"


def doc_crc(data: bytes) -> int:
    """CRC-16/XMODEM, bit by bit: poly 0x1021, init 0, no reflection, no xorout."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def doc_cobs_encode(body: bytes) -> bytes:
    out, block = bytearray(), bytearray()
    full = False  # the body ended with a 0xFF block: no last block after it
    for byte in body:
        full = False
        if byte == 0:
            out += bytes([len(block) + 1]) + block
            block.clear()
        else:
            block.append(byte)
            if len(block) == 254:
                out += b"\xff" + block
                block.clear()
                full = True
    if not full:
        out += bytes([len(block) + 1]) + block
    return bytes(out)


def doc_cobs_decode(data: bytes) -> bytes:
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        if code == 0 or i + code > len(data):
            raise ValueError("cobs")
        out += data[i + 1 : i + code]
        i += code
        if code != 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def doc_frame(kind: int, seq: int, payload: bytes = b"", arg: int = 0, version: int = 1) -> bytes:
    body = bytes([version, kind]) + seq.to_bytes(2, "little") + bytes([arg]) + payload
    body += doc_crc(body).to_bytes(2, "little")
    return doc_cobs_encode(body) + b"\x00"


def doc_layout(path: Path) -> tuple[str, int, int, int, list[tuple[int, int]]]:
    """Layout text, channels, motors, boards and (board, slot) per motor, from the YAML."""
    robot = yaml.safe_load(path.read_text())
    channels, motors, slots = [], [], []
    order = ("pwm", "torque", "position", "velocity")  # mode-code order
    boards = sorted(robot["boards"], key=lambda b: b["id"])
    for board in boards:
        bid = board["id"]
        for sensor in sorted(board.get("sensors", []), key=lambda s: s["slot"]):
            if sensor.get("kind") == "imu":
                channels += [f"{bid}:{sensor['name']}.{axis}" for axis in ("roll", "pitch", "yaw")]
            else:
                channels.append(f"{bid}:{sensor['name']}")
        for motor in sorted(board.get("motors", []), key=lambda m: m["slot"]):
            feedback = motor.get("feedback") or {}
            channels += [
                f"{bid}:{motor['name']}.{k}" for k in ("velocity", "current") if k in feedback
            ]
            fn = motor["function"]
            role = fn if fn in ("drive", "rotate", "bend") else "other"
            modes = ",".join(
                f"{m}={motor['modes'][m]['raw'][0]}..{motor['modes'][m]['raw'][1]}"
                for m in order
                if m in motor["modes"]
            )
            motors.append(f"{bid}:{motor['slot']}:{role}:{modes}")
            slots.append((bid, motor["slot"]))
    return (
        ";".join(channels) + "|" + ";".join(motors),
        len(channels),
        len(motors),
        len(boards),
        slots,
    )


DOC_TEXT, DOC_CHANNELS, DOC_MOTORS, DOC_BOARDS, DOC_SLOTS = doc_layout(ROBOT_YAML)
DOC_DIGEST = int.from_bytes(sha256(DOC_TEXT.encode("ascii")).digest()[:4], "big")


class DocHost:
    """A host that knows only the page: frames out through ``write``, frames in by ``read``."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim
        self._rx = b""
        self.states: list[dict[str, object]] = []

    def send(self, kind: int, seq: int, payload: bytes = b"", arg: int = 0) -> None:
        self.sim.write(doc_frame(kind, seq, payload, arg))

    def frames(self, seconds: float = 0.02) -> list[tuple[int, int, int, bytes]]:
        """(type, seq, arg, payload) of every good frame in ``seconds`` of line; STATEs kept."""
        self.sim.clock.advance(seconds)
        self._rx += self.sim.read()
        *parts, self._rx = self._rx.split(b"\x00")
        out = []
        for part in parts:
            if not part:
                continue
            body = doc_cobs_decode(part)
            assert len(body) >= 7 and doc_crc(body[:-2]) == int.from_bytes(body[-2:], "little")
            assert body[0] == 1
            kind, seq, arg, payload = (
                body[1],
                int.from_bytes(body[2:4], "little"),
                body[4],
                body[5:-2],
            )
            if kind == 0x82:
                self.states.append(self._state(seq, arg, payload))
            elif kind != 0x86:
                out.append((kind, seq, arg, payload))
        return out

    def _state(self, seq: int, flags: int, payload: bytes) -> dict[str, object]:
        mask_n, status_n = (DOC_CHANNELS + 7) // 8, (DOC_BOARDS + 1) // 2
        assert len(payload) == 2 + mask_n + status_n + 2 * DOC_CHANNELS
        status = payload[2 + mask_n : 2 + mask_n + status_n]
        values = struct.unpack_from(f"<{DOC_CHANNELS}h", payload, 2 + mask_n + status_n)
        return {
            "seq": seq,
            "flags": flags,
            "ack_seq": int.from_bytes(payload[:2], "little"),
            "status": [(status[j // 2] >> (4 * (j % 2))) & 0xF for j in range(DOC_BOARDS)],
            "values": values,
        }
