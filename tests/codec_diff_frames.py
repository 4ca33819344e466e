"""The host-link differential test's frames: every message the host sends, valid,
mutated and random, on the bundled robot's layout (``tests/test_codec_differential13.py``,
split from it along that seam)."""

from __future__ import annotations

import random
import struct

from pirate_bt.link.codec import (
    BulkSetpoints,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    Heartbeat,
    Hello,
    Message,
    MsgType,
    Setpoint,
    cobs_decode,
    cobs_encode,
    crc16,
)
from pirate_bt.link.raw import HOST_TYPES
from pirate_bt.robot.description import ControlMode
from pirate_bt.robot.loader import load_robot

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
BOARDS = ROBOT.board_ids()
SLOTS = ROBOT.setpoint_slots()
DIGEST = ROBOT.layout_digest()
N_MOTORS = len(SLOTS)


# -- frames: valid, mutated, random --------------------------------------------------------------


def wire(kind: int, seq: int, arg: int, payload: bytes, version: int = 1) -> bytes:
    body = struct.pack("<BBHB", version, kind, seq, arg) + payload
    return cobs_encode(body + struct.pack("<H", crc16(body))) + b"\x00"


def edge(rng: random.Random, lo: int, hi: int) -> int:
    return rng.choice([lo, hi, lo - 1, hi + 1, 0, rng.randint(lo, hi), rng.randint(-32768, 32767)])


def host_message(rng: random.Random, seq: int) -> Message:
    """Any host -> bridge message the Python codec encodes, fields good and bad."""
    kind = rng.choice([1, 2, 2, 3, 3, 4, 5, 6, 7])
    if kind == 1:
        digest = DIGEST if rng.random() < 0.8 else rng.randrange(1 << 32)
        return Hello(seq, digest, rng.choice([1, 2, 2, 0, 3, rng.randrange(256)]))
    if kind == 2:
        slot = rng.choice(SLOTS)
        board = slot.board if rng.random() < 0.9 else rng.randrange(256)
        number = slot.slot if rng.random() < 0.9 else rng.choice([0, 1, 2, 7, 8, 255])
        mode = rng.choice(list(ControlMode))
        conv = slot.motor.modes.get(mode)
        lo, hi = conv.raw if conv is not None else (-255, 255)
        return Setpoint(seq, board, number, mode, max(-32768, min(32767, edge(rng, lo, hi))))
    if kind == 3:
        modes: list[ControlMode | None] = []
        raws = []
        for slot in SLOTS:
            listed = [m for m in ControlMode if slot.motor.modes.get(m) is not None]
            mode = rng.choice([None, *listed, *listed, *listed, rng.choice(list(ControlMode))])
            lo, hi = slot.motor.modes.get(mode).raw if mode in listed else (-100, 100)
            raw = edge(rng, lo, hi) if rng.random() < 0.1 else rng.randint(lo, hi)
            modes.append(mode)
            raws.append(0 if mode is None else max(-32768, min(32767, raw)))
        return BulkSetpoints(seq, tuple(modes), tuple(raws))
    return {4: Heartbeat, 5: EStop, 6: EStopReset, 7: CountersRequest}[kind](seq)


def body_of(frame: bytes) -> bytes:
    return cobs_decode(frame[:-1])


def mutate(rng: random.Random, frame: bytes) -> bytes:
    """One hostile variant of a good frame (delimiter included)."""
    body = body_of(frame)
    how = rng.randrange(14)
    if how == 0:  # a bit flip anywhere, the delimiter too
        out = bytearray(frame)
        out[rng.randrange(len(out))] ^= 1 << rng.randrange(8)
        return bytes(out)
    if how == 1:  # cut short
        return frame[: rng.randrange(len(frame) - 1)] + b"\x00"
    if how == 2:  # extended before the delimiter
        return (
            frame[:-1] + bytes(rng.randrange(1, 256) for _ in range(rng.randrange(1, 8))) + b"\x00"
        )
    if how == 3:  # another version, a good CRC
        version = rng.choice([0, 2, 0x81, 0xFF, rng.randrange(256)])
        return wire(body[1], body[2] | body[3] << 8, body[4], body[5:-2], version)
    if how == 4:  # payload one byte short or long, a good CRC
        payload = body[5:-2]
        payload = (
            payload[:-1]
            if payload and rng.random() < 0.5
            else payload + bytes([rng.randrange(256)])
        )
        return wire(body[1], body[2] | body[3] << 8, body[4], payload)
    if how == 5:  # a zero inside
        at = rng.randrange(len(frame))
        return frame[:at] + b"\x00" + frame[at:]
    if how == 6:  # 0xFF runs
        n = rng.choice([1, 2, 254, 255, 256, rng.randrange(1, 300)])
        return b"\xff" * n + rng.choice([b"\x00", b"\x01\x00", frame])
    if how == 7:  # a body of 254 bytes (the most there is) or 255 (one too many)
        n = rng.choice([254 - 7, 255 - 7, 253 - 7])
        payload = bytes(rng.choice([0, rng.randrange(1, 256)]) for _ in range(n))
        return wire(rng.choice([*HOST_TYPES, rng.randrange(256)]), rng.randrange(65536), 0, payload)
    if how == 8:  # a body of 254 non-zero bytes: one 0xFF block; or with a trailing 0x01
        for _ in range(64):
            payload = bytes(rng.randrange(1, 256) for _ in range(247))
            good = wire(
                rng.randrange(1, 256), rng.randrange(1, 65536), rng.randrange(1, 256), payload
            )
            if good[0] == 0xFF and len(good) == 256:
                return good if rng.random() < 0.5 else good[:-1] + b"\x01\x00"
        return good
    if how == 9:  # body shorter than a header and a CRC
        return cobs_encode(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 7)))) + b"\x00"
    if how == 10:  # a good CRC, any type, arg and payload length
        n = rng.choice(
            [0, 1, 2, 3, 4, 5, 6, 3 * N_MOTORS - 1, 3 * N_MOTORS + 1, rng.randrange(248)]
        )
        return wire(
            rng.randrange(256),
            rng.randrange(65536),
            rng.randrange(256),
            bytes(rng.randrange(256) for _ in range(n)),
        )
    if how == 11:  # the delimiter lost: glued to the next frame
        return frame[:-1]
    if how == 12:  # a code byte one past the end
        out = bytearray(frame[:-1])
        out[0] = min(255, len(out) + 1)
        return bytes(out) + b"\x00"
    if body[1] in (MsgType.SETPOINT, MsgType.BULK_SETPOINTS) and rng.random() < 0.5:
        # a mode code outside the table (the Python codec cannot encode one)
        payload = bytearray(body[5:-2])
        at = 1 if body[1] == MsgType.SETPOINT else 3 * rng.randrange(N_MOTORS)
        payload[at] = rng.choice([4, 5, 0x80, 0xFE, rng.randrange(4, 255)])
        return wire(body[1], body[2] | body[3] << 8, body[4], bytes(payload))
    return frame  # as it was (duplicates)


def random_bytes(rng: random.Random) -> bytes:
    n = rng.choice([1, 2, 7, 8, 255, 256, 257, rng.randrange(1, 400)])
    density = rng.choice([0.0, 0.004, 0.05, 0.3])
    return bytes(0 if rng.random() < density else rng.randrange(1, 256) for _ in range(n))


def hostile_stream(rng: random.Random, n: int) -> list[bytes]:
    """``n`` records of valid, mutated and random host bytes (a final 0x00 ends them)."""
    out = []
    for _i in range(n):
        msg = host_message(rng, rng.randrange(65536))
        frame = CODEC.encode(msg)
        pick = rng.random()
        out.append(frame if pick < 0.3 else random_bytes(rng) if pick < 0.4 else mutate(rng, frame))
    out.append(b"\x00")
    return out
