"""The bridge firmware's C decoder against tables of damaged frames, in its host build.

Every single-byte corruption of a valid ``SETPOINT`` (every position, every other
value), a table of two-byte corruptions, every truncation, two frames glued together,
a stream of delimiters only and a length field that lies: the bridge must drop and
count each damaged frame (``crc_errors`` or ``frame_errors`` of its ``COUNTERS``,
docs/protocol.md, Bad frames), answer none of them, and act on none (no setpoint
reaches the board bus, the duplicate filter does not move: the good frame sent after
them all is still applied).

The expected counts come from the page's rules applied here, frame by frame, in
Python (:func:`classify`), not from the firmware.
"""

from __future__ import annotations

import shutil
import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from test_firmware_core import (
    ACK,
    APPLIED,
    COUNTERS_REQUEST,
    SETPOINT,
    STATE,
    VELOCITY,
    Bridge,
    Frame,
    frame,
    library,
    setpoint,
)

from pirate_bt.errors import FrameError
from pirate_bt.link.framing import cobs_decode, crc16
from pirate_bt.robot import load_robot

__all__ = ["library"]  # the host build, a fixture shared with test_firmware_core

BRIDGE_HEARTBEAT = 0x86
GOOD = setpoint(3, 22, 1, VELOCITY, 400)  # the frame every damaged one is made from
DRIVE_400 = bytes([VELOCITY]) + struct.pack("<h", 400)  # its setpoint on the board bus


@pytest.fixture
def fw(library: Path, tmp_path: Path) -> Iterator[Bridge]:
    """A bridge in a session that takes setpoints (its own copy of the host build)."""
    copy = tmp_path / "fw.so"
    shutil.copy(library, copy)
    bridge = Bridge(copy, load_robot())
    bridge.start()
    bridge.bus()  # forget the boot's polls
    yield bridge


def classify(wire: bytes) -> tuple[int, int, int]:
    """``(crc, framing, intact)`` frames the page says a bridge sees in ``wire`` (which
    ends with a delimiter): ``crc`` a CRC mismatch, ``framing`` oversize, COBS, short or
    version, ``intact`` a frame that passes the CRC and the version (answered)."""
    crc = framing = intact = 0
    for part in wire.split(b"\x00")[:-1]:
        if not part:
            continue  # an empty frame: no error
        if len(part) > 255:
            framing += 1
            continue
        try:
            body = cobs_decode(part)
        except FrameError:
            framing += 1
            continue
        if len(body) < 7:
            framing += 1
        elif crc16(body[:-2]) != struct.unpack("<H", body[-2:])[0]:
            crc += 1
        elif body[0] != 1:
            framing += 1
        else:
            intact += 1
    return crc, framing, intact


def single_byte_corruptions() -> list[bytes]:
    out = []
    for i in range(len(GOOD)):
        for value in range(256):
            if value != GOOD[i]:
                out.append(GOOD[:i] + bytes([value]) + GOOD[i + 1 :])
    return out


def two_byte_corruptions() -> list[bytes]:
    out = []
    n = len(GOOD) - 1  # the delimiter stays
    for i in range(n):
        for j in range(i + 1, n):
            for a, b in ((0x01, 0x01), (0x80, 0x01), (0xFF, 0xFF), (0x10, 0x21)):
                damaged = bytearray(GOOD)
                damaged[i] ^= a
                damaged[j] ^= b
                out.append(bytes(damaged))
    return out


def truncations() -> list[bytes]:
    # cut before its delimiter at every length: the flush that follows ends it
    return [GOOD[:k] for k in range(1, len(GOOD) - 1)]


TABLES = {
    "single bytes": single_byte_corruptions,
    "two bytes": two_byte_corruptions,
    "truncations": truncations,
    "glued": lambda: [GOOD[:-1] + GOOD, GOOD[:-1] * 20 + b"\x00"],
    "delimiters only": lambda: [b"\x00" * 4096],
    "oversize": lambda: [b"\x01" * 300, GOOD[:-1] * 30],
}


def counters(fw: Bridge, seq: int) -> tuple[int, int, int]:
    """The bridge's ``(rx_frames, crc_errors, frame_errors)``."""
    (reply,) = fw.ask(frame(COUNTERS_REQUEST, seq))
    return struct.unpack("<3I", reply.payload[:12])  # type: ignore[return-value]


@pytest.mark.parametrize("table", sorted(TABLES))
def test_the_firmware_counts_and_drops_every_damaged_frame_and_acts_on_none(
    fw: Bridge, table: str
) -> None:
    rx0, crc0, framing0 = counters(fw, 0x101)
    want_crc = want_framing = 0
    for damaged in TABLES[table]():
        wire = damaged + b"\x00"  # a flush after each: the next starts clean
        crc, framing, intact = classify(wire)
        assert intact == 0, damaged.hex()  # no damage in these tables makes a good frame
        want_crc += crc
        want_framing += framing
        fw.write(wire)
        fw.run(1)
        answers = [f for f in fw.read() if f.kind not in (STATE, BRIDGE_HEARTBEAT)]
        assert answers == [], (damaged.hex(), answers)
    rx, crc, framing = counters(fw, 0x102)
    # the two COUNTERS_REQUESTs are the only frames received
    assert (rx - rx0, crc - crc0, framing - framing0) == (1, want_crc, want_framing)
    # nothing damaged reached the board: board 22's drive got no 400 ...
    to_22 = [b for b in fw.bus() if b[:2] == bytes([22, 1])]
    assert all(b[5:] != DRIVE_400 for b in to_22)
    # ... and the duplicate filter did not move: the good frame is applied now
    assert fw.ask(GOOD) == [Frame(ACK, 3, 0, bytes([SETPOINT, APPLIED]))]
    fw.run(25)
    assert any(b[:2] == bytes([22, 1]) and b[5:] == DRIVE_400 for b in fw.bus())
