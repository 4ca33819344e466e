"""The bridge firmware's checks at their edges, in its host build.

Written with the firmware's catalogue of operator mutations (docs/testing.md,
``tests/mutation/firmware.py``): each test pins down a check that a flipped comparison,
an operand off by one or a dropped condition got past. The bridge under test and the
frame helpers are those of ``tests/test_firmware_core.py``.
"""

from __future__ import annotations

import binascii
import ctypes
import shutil
import struct
from collections.abc import Iterator
from pathlib import Path

import pytest
from firmware_host import build_host_library
from test_firmware_bench import DebugRecord
from test_firmware_core import (
    BAD_LENGTH,
    BULK,
    BUS_ERROR,
    COUNTERS_REQUEST,
    DUPLICATE,
    ESTOP,
    ESTOP_RESET,
    F_WATCHDOG,
    HEARTBEAT,
    HELLO,
    KEEP,
    MOTORS_OFF,
    ONLINE,
    POSITION,
    PWM,
    SETPOINT,
    STALE,
    STATE,
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

from pirate_bt.link.codec import cobs_encode
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


# -- the watchdog's edge ------------------------------------------------------------------


@pytest.mark.parametrize("silence_ms", [250, 251])
def test_the_watchdog_trips_after_more_than_its_period_of_silence(
    fw: Bridge, silence_ms: int
) -> None:
    """250 ms without a frame is within the watchdog's 250 ms; 251 is not.

    The frame arrives exactly on a millisecond; the STATE encoded exactly ``silence_ms``
    later (the watchdog is checked first in that turn) says whether it tripped.
    """
    watchdog_ms = round(fw.robot.bridge.watchdog * 1000)
    period_ms = round(fw.robot.bridge.state_period * 1000)
    assert watchdog_ms == 250
    fw.start()
    fw.lib.fw_now_us.restype = ctypes.c_uint64
    now_us = int(fw.lib.fw_now_us())
    boundary_ms = (now_us // 1000 // period_ms + 30) * period_ms  # a STATE is encoded then
    fed_ms = boundary_ms - silence_ms
    fw.run((fed_ms * 1000 - now_us) / 1000)
    fw.write(frame(HEARTBEAT, 3))  # read in the turn at fed_ms exactly
    fw.run(silence_ms)  # up to the turn at boundary_ms, not including it
    fw.read()
    fw.run(1)
    (state,) = [f for f in fw.read() if f.kind == STATE]
    assert bool(fw.state(state)[2] & F_WATCHDOG) is (silence_ms > watchdog_ms)


# -- the duplicate filter and the e-stop -----------------------------------------------------


def test_an_estop_with_an_older_seq_leaves_the_duplicate_filter_where_it_was(fw: Bridge) -> None:
    """An ESTOP latches whatever its seq; an older one (sent before the last request,
    arriving after it) does not move the filter back: copies stay duplicates or stale."""
    fw.start()
    assert fw.ask(setpoint(10, 22, 1, VELOCITY, 5)) == [ack(10, SETPOINT)]
    assert fw.ask(frame(ESTOP, 5)) == [ack(5, ESTOP)]
    assert fw.ask(setpoint(10, 22, 1, VELOCITY, 5)) == [ack(10, SETPOINT, DUPLICATE)]
    assert fw.ask(setpoint(8, 22, 1, VELOCITY, 5)) == [ack(8, SETPOINT, STALE)]


# -- the BULK_SETPOINTS cycle figure (pb_debug, docs/firmware.md) -------------------------


def debug(fw: Bridge) -> DebugRecord:
    record = DebugRecord()
    fw.lib.fw_debug(ctypes.byref(record))
    return record


def test_the_bulk_cycle_figure_counts_a_bulk_from_its_delimiter_and_nothing_else(
    fw: Bridge,
) -> None:
    """``pb_debug.bulk_cycles_*``: from the BULK's 0x00 taken from the line to its setpoints
    applied. Here every read of the timer costs a tick, so the figure is a few ticks; a
    figure counted from boot (tens of thousands of ticks) or from another frame's
    delimiter, or a frame other than a BULK measured, shows."""
    fw.lib.fw_timer_read_cost(1)
    fw.start()
    assert fw.ask(frame(HEARTBEAT, 3)) == [ack(3, HEARTBEAT)]
    assert fw.ask(frame(COUNTERS_REQUEST, 4))
    before = debug(fw)
    assert (before.bulk_cycles_last, before.bulk_cycles_max) == (0, 0)  # no BULK yet
    fw.lib.fw_now_us.restype = ctypes.c_uint64
    assert int(fw.lib.fw_now_us()) * 2 % 0x10000 > 1000  # the ticks since boot would show
    entries = [(KEEP, 0)] * len(fw.motors)
    entries[5] = (VELOCITY, 300)
    assert fw.ask(bulk(5, entries), ms=1) == []
    after = debug(fw)
    assert 0 < after.bulk_cycles_last < 100
    assert after.bulk_cycles_max == after.bulk_cycles_last


# -- COBS at the edges of its buffers ----------------------------------------------------------


def firmware_cobs_decode(fw: Bridge, data: bytes, n: int, cap: int) -> tuple[int, bytes]:
    """``cobs_decode(data, n, out, cap)`` of the firmware: its result and ``out``, which
    holds ``cap`` bytes and then guard bytes (0xA5) that must stay as they were."""
    fw.lib.cobs_decode.restype = ctypes.c_int16
    fw.lib.cobs_decode.argtypes = [
        ctypes.c_char_p,
        ctypes.c_uint16,
        ctypes.c_void_p,
        ctypes.c_uint16,
    ]
    out = ctypes.create_string_buffer(b"\xa5" * (cap + 8), cap + 8)
    got = fw.lib.cobs_decode(data, n, out, cap)
    assert out.raw[cap:] == b"\xa5" * 8, f"written past cap={cap}: {out.raw.hex()}"
    return got, out.raw[: max(got, 0)]


@pytest.mark.parametrize(
    "body",
    [b"\x11\x22\x33", b"\x11\x22\x00\x33", b"\x11\x22\x00", b"\x00", b"\x11" * 254],
    ids=["data", "zero-inside", "zero-last", "one-zero", "full-block"],
)
def test_cobs_decodes_into_exactly_its_size_and_refuses_less(fw: Bridge, body: bytes) -> None:
    """A body of n bytes decodes with a buffer of n and is refused with any less, and
    nothing is written at or past the buffer's end either way."""
    encoded = cobs_encode(body)
    assert firmware_cobs_decode(fw, encoded, len(encoded), len(body)) == (len(body), body)
    for cap in range(len(body)):
        assert firmware_cobs_decode(fw, encoded, len(encoded), cap)[0] == -1, cap


def test_cobs_refuses_nothing_and_decodes_a_lone_code_to_an_empty_body(fw: Bridge) -> None:
    assert firmware_cobs_decode(fw, b"", 0, 254)[0] == -1
    assert firmware_cobs_decode(fw, b"\x01", 1, 254) == (0, b"")


def test_cobs_refuses_a_block_one_past_the_end_whatever_follows_in_memory(fw: Bridge) -> None:
    """The block 0x04 claims 3 bytes where 2 are given: refused, the byte after the input
    (0x07, not a delimiter) not read."""
    assert firmware_cobs_decode(fw, b"\x04\x01\x02\x07", 3, 254)[0] == -1
    assert firmware_cobs_decode(fw, b"\x04\x01\x02\x07", 4, 254) == (3, b"\x01\x02\x07")


# -- the frame limit: 255 bytes before a delimiter ------------------------------------------


def test_255_bytes_make_a_frame_and_256_are_dropped_whatever_they_decode_to(
    fw: Bridge,
) -> None:
    """docs/protocol.md, Framing: more than 255 bytes before a delimiter is ``oversize``.
    A 254-byte body without zeros is 255 bytes in COBS; the same body with a trailing
    0x01 (which decodes to nothing more) is 256, and is dropped, and the next frame is
    read."""
    payload = bytearray(b"\x5a" * 247)
    while True:
        body = bytes([1, HEARTBEAT]) + struct.pack("<HB", 0x0101, 1) + payload
        body += struct.pack("<H", binascii.crc_hqx(body, 0))
        if 0 not in body:
            break
        payload[0] += 1
    assert len(body) == 254 and cobs_encode(body) == b"\xff" + body
    fw.run(25)
    assert fw.ask(b"\xff" + body + b"\x00") == [nack(0x0101, HEARTBEAT, BAD_LENGTH)]
    assert fw.ask(b"\xff" + body + b"\x01\x00") == []
    assert fw.ask(frame(HEARTBEAT, 5)) == [ack(5, HEARTBEAT)]
    assert frame_errors(fw, 6) == (0, 1)


# -- the STATE's board nibbles, an odd and an even number of boards -------------------------


def test_an_odd_number_of_boards_leaves_the_last_high_nibble_0(fw: Bridge) -> None:
    """docs/protocol.md, STATE: an unused high nibble is 0 (9 boards, the default robot)."""
    assert len(fw.boards) % 2 == 1
    fw.run(25)
    state = fw.states()[-1]
    mb = (len(fw.channels) + 7) // 8
    last = state.payload[2 + mb + len(fw.boards) // 2]
    assert last == ONLINE | MOTORS_OFF  # the 9th board's nibble, then 0


EXTRA_BOARD = """
  - id: 29
    module: rear
    motors:
      - slot: 1
        name: rear_lamp
        function: leds
        modes:
          pwm: {raw: [0, 255], per_raw: 0.392156862745098 %}
    sensors:
      - {<<: *angle_sensor, slot: 0, name: rear_lamp_angle}
"""


def test_an_even_number_of_boards_fills_every_status_byte_and_every_reading(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """A robot with a 10th board: 5 status bytes, no unused nibble, and the readings
    after them where they belong (the default robot has 9 boards)."""
    robot_file = tmp_path_factory.mktemp("ten-boards") / "pirate.yaml"
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    assert text.count("\nclamp:") == 1
    robot_file.write_text(text.replace("\nclamp:", EXTRA_BOARD + "\nclamp:"))
    try:
        library = build_host_library(tmp_path_factory.mktemp("fw-host-ten"), robot_file)
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware core cannot be built")
        raise
    bridge = Bridge(library, load_robot(robot_file))
    assert len(bridge.boards) == 10
    for i in range(len(bridge.channels)):
        bridge.lib.fw_reading(i, ctypes.c_int16(7 * i - 100))
    bridge.run(25)
    _, _, _, status, values = bridge.state(bridge.states()[-1])
    assert status == [ONLINE | MOTORS_OFF] * 10
    assert values == [7 * i - 100 for i in range(len(bridge.channels))]
    # the 10th board is a board like the others
    bridge.hello(1)
    assert bridge.ask(frame(ESTOP_RESET, 2)) == [ack(2, ESTOP_RESET)]
    assert bridge.ask(setpoint(3, 29, 1, PWM, 200)) == [ack(3, SETPOINT)]
    assert bridge.state(bridge.states()[-1])[3][9] == ONLINE
