"""The bridge firmware's checks at their edges, in its host build.

Written with the firmware's catalogue of operator mutations (docs/testing.md,
``tests/mutation/firmware.py``): each test pins down a check that a flipped comparison,
an operand off by one or a dropped condition got past. The bridge under test and the
frame helpers are those of ``tests/test_firmware_core.py``.
"""

from __future__ import annotations

import shutil
import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from test_firmware_core import (
    BULK,
    BUS_ERROR,
    COUNTERS_REQUEST,
    ESTOP_RESET,
    HEARTBEAT,
    HELLO,
    KEEP,
    POSITION,
    SETPOINT,
    STALE,
    UNKNOWN_TYPE,
    VELOCITY,
    Bridge,
    ack,
    bulk,
    frame,
    library,
    nack,
    setpoint,
)

from pirate_bt.robot import load_robot

__all__ = ["library"]  # the host build, a fixture shared with test_firmware_core


@pytest.fixture
def fw(library: Path, tmp_path: Path) -> Iterator[Bridge]:
    """A freshly booted bridge: its own copy of the host build."""
    copy = tmp_path / "fw.so"
    shutil.copy(library, copy)
    yield Bridge(copy, load_robot())


def frame_errors(fw: Bridge, seq: int) -> tuple[int, int]:
    """The bridge's ``(crc_errors, frame_errors)`` counters."""
    (counters,) = fw.ask(frame(COUNTERS_REQUEST, seq))
    return struct.unpack("<5I", counters.payload[:20])[1:3]  # type: ignore[return-value]


def test_every_type_past_the_last_request_is_unknown(fw: Bridge) -> None:
    """0x08 is no ESTOP_RESET: the type check ends exactly at COUNTERS_REQUEST (0x07)."""
    fw.start()
    for kind in (0x00, 0x08, 0x09, 0x7F):
        assert fw.ask(frame(kind, 10 + kind)) == [nack(10 + kind, kind, UNKNOWN_TYPE)]


def test_the_first_board_takes_setpoints(fw: Bridge) -> None:
    """Board index 0 (the camera board, id 20) is a board like the others."""
    fw.start()
    assert fw.ask(setpoint(3, 20, 0, POSITION, 100)) == [ack(3, SETPOINT)]


def test_a_seq_half_a_circle_ahead_is_stale(fw: Bridge) -> None:
    fw.start()  # the last ordered seq is 2
    assert fw.ask(setpoint(2 + 0x8000, 22, 1, VELOCITY, 1)) == [ack(2 + 0x8000, SETPOINT, STALE)]
    assert fw.ask(setpoint(2 + 0x7FFF, 22, 1, VELOCITY, 1)) == [ack(2 + 0x7FFF, SETPOINT)]


def test_a_bulk_for_a_silent_board_is_refused_unless_it_keeps_its_motors(
    fw: Bridge,
) -> None:
    fw.start()
    fw.board(22, online=False)
    fw.run(25)
    silent = next(m.index for m in fw.motors if m.board == 22 and m.slot == 1)
    other = next(m.index for m in fw.motors if m.board == 23 and m.slot == 1)
    entries = [(KEEP, 0)] * len(fw.motors)
    to_silent = list(entries)
    to_silent[silent] = (VELOCITY, 100)
    assert fw.ask(bulk(3, to_silent)) == [nack(3, BULK, BUS_ERROR)]
    to_other = list(entries)
    to_other[other] = (VELOCITY, 100)  # board 22's motors kept: nothing goes to it
    assert fw.ask(bulk(4, to_other), ms=1) == []
    assert fw.state(fw.states(12)[-1])[0] == 4


def test_empty_frames_are_no_errors(fw: Bridge) -> None:
    fw.run(25)
    fw.write(b"\x00\x00\x00")
    fw.run(5)
    assert frame_errors(fw, 1) == (0, 0)


def test_an_overlong_frame_is_one_error_and_the_next_frame_is_read(fw: Bridge) -> None:
    fw.run(25)
    fw.write(b"\x01" * 300 + b"\x00")
    fw.run(40)
    assert fw.ask(frame(HEARTBEAT, 5)) == [ack(5, HEARTBEAT)]
    assert frame_errors(fw, 6) == (0, 1)


def test_a_cobs_block_one_past_the_end_is_an_error(fw: Bridge) -> None:
    fw.run(25)
    encoded = bytearray(frame(HEARTBEAT, 7)[:-1])  # without its delimiter
    last = 0
    while last + encoded[last] < len(encoded):
        last += encoded[last]
    encoded[last] += 1  # the last block now claims one byte more than there is
    assert fw.ask(bytes(encoded) + b"\x00") == []
    assert frame_errors(fw, 8) == (0, 1)


def test_a_burst_of_requests_gets_at_most_the_answers_that_fit(fw: Bridge) -> None:
    """Answers queue behind STATE frames; when 4 wait, a request is handled, not answered."""
    fw.start()
    burst = b"".join(frame(HEARTBEAT, 100 + i) for i in range(40))
    fw.write(burst)
    fw.run(200)
    answers = [f for f in fw.read() if f.kind == 0x83]
    assert 4 <= len(answers) < 40
    assert all(100 <= f.seq < 140 for f in answers)
    assert fw.ask(frame(HEARTBEAT, 200)) == [ack(200, HEARTBEAT)]  # still answering


def test_a_reset_of_a_latch_that_is_not_set_is_acknowledged(fw: Bridge) -> None:
    """Nothing to release: the readiness checks of a release do not apply."""
    fw.start()  # released
    fw.board(24, online=False)  # a board that is not ready
    fw.run(25)
    assert fw.ask(frame(ESTOP_RESET, 3)) == [ack(3, ESTOP_RESET)]


@pytest.mark.parametrize("kind", [0x7F, COUNTERS_REQUEST, HELLO])
def test_a_burst_of_any_answer_gets_at_most_what_fits(fw: Bridge, kind: int) -> None:
    """NACKs (an unknown type), COUNTERS and HELLO_REPLYs wait for the line like ACKs."""
    payload = struct.pack("<IB", fw.digest, 1) if kind == HELLO else b""
    fw.run(25)
    fw.write(b"".join(frame(kind, 100 + i, payload=payload) for i in range(40)))
    fw.run(300)
    answers = [f for f in fw.read() if f.kind != 0x82]
    assert 4 <= len(answers) < 40
    assert fw.ask(frame(HEARTBEAT, 200)) == [ack(200, HEARTBEAT)]  # still answering
