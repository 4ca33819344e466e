"""The bridge firmware's bench-readiness (issue 26), on its host build in virtual time.

The rules of ``docs/firmware.md`` ("Wiring", "Line errors") and ``docs/board-bus.md``
(version 2) that the firmware's own C decides: a byte the USART flags drops the frame
it belongs to and is counted; a retry waits until the line has been quiet for the
longest legal reply; every board gets a STOP in its own modes (a drive brakes); a board
that reports its own stop (it heard no master) stops the whole robot. The AVR-only
parts (pins, fuses, boot id) are checked on the ELF and in simavr
(``tests/test_firmware_chain.py``).
"""

from __future__ import annotations

import ctypes
import itertools
import shutil
import struct
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from test_firmware_core import (
    COUNTERS_REQUEST,
    ESTOP,
    ESTOP_RESET,
    F_ESTOP,
    HEARTBEAT,
    HELLO,
    KEEP,
    MOTORS_OFF,
    NACK,
    NOT_READY,
    PWM,
    VELOCITY,
    Bridge,
    Frame,
    ack,
    frame,
    library,  # noqa: F401  (a fixture)
    nack,
    setpoint,
)

from pirate_bt.robot.loader import load_robot

ROOT = Path(__file__).resolve().parents[1]
ELF = ROOT / "firmware" / "piratebay" / "build" / "piratebay.elf"
GUARD_US = 34 * 10  # the longest legal bus frame at 1 Mbaud
TIMEOUT_US = 1500


class DebugRecord(ctypes.Structure):
    """``struct pb_debug`` (firmware/piratebay/mcu.h)."""

    _fields_ = [
        ("magic", ctypes.c_uint16),
        ("mcu_resets", ctypes.c_uint16),
        ("last_mcusr", ctypes.c_uint8),
        ("reserved", ctypes.c_uint8),
        *(
            (name, ctypes.c_uint16)
            for name in (
                "stack_low",
                "stack_bottom",
                "state_cycles_last",
                "state_cycles_max",
                "bulk_cycles_last",
                "bulk_cycles_max",
                "rx_overruns",
                "host_framing",
                "bus_framing",
                "bus_overrun",
                "bus_echo",
                "board_own_stops",
                "estop_input_trips",
            )
        ),
    ]


class BenchBridge(Bridge):
    def bus(self) -> list[bytes]:
        return [body for _, body in self.bus_timed()]

    def bus_timed(self) -> list[tuple[int, bytes]]:
        """(virtual µs, body) of every bus frame since the last call."""
        times = (ctypes.c_uint64 * 4096)()
        n = self.lib.fw_bus_times(times, 4096)
        bodies = super().bus()
        assert len(bodies) == n
        return list(zip(times[:n], bodies, strict=True))

    def lib_now_us(self) -> int:
        self.lib.fw_now_us.restype = ctypes.c_uint64
        return int(self.lib.fw_now_us())

    def debug(self) -> DebugRecord:
        record = DebugRecord()
        self.lib.fw_debug(ctypes.byref(record))
        return record


@pytest.fixture()
def bridge(library: Path, tmp_path: Path) -> Iterator[BenchBridge]:  # noqa: F811
    copy = tmp_path / "bridge.so"
    shutil.copy(library, copy)
    yield BenchBridge(copy, load_robot())


def test_a_byte_the_usart_flags_drops_its_frame_and_is_counted(bridge: BenchBridge) -> None:
    bridge.start()
    good = frame(HEARTBEAT, 40)
    # the same heartbeat with one byte flagged (a framing error): dropped, no answer
    bridge.write(good[:3])
    bridge.lib.fw_write_damaged(good[3])
    assert bridge.ask(good[4:]) == []
    # a damaged delimiter ends the frame it damaged; the next frame is whole
    bridge.write(good[:-1])
    bridge.lib.fw_write_damaged(0)
    assert bridge.ask(frame(HEARTBEAT, 41)) == [ack(41, HEARTBEAT)]
    counters = bridge.ask(frame(COUNTERS_REQUEST, 42))[0]
    rx, _crc, framing, _, _ = struct.unpack("<5I", counters.payload[:20])
    assert framing == 2 and rx == 2 + 2  # hello, reset, then heartbeat 41 and this request


def test_a_retry_waits_out_the_longest_legal_reply(bridge: BenchBridge) -> None:
    bridge.run(25)
    bridge.bus_timed()
    bridge.board(26, online=False)
    bridge.run(40)
    timed = bridge.bus_timed()
    to_26 = [t for t, body in timed if body[:2] == bytes([26, 1])]
    gaps = [b - a for a, b in itertools.pairwise(to_26) if b - a < 5000]
    assert gaps, "no retry seen"
    assert all(gap >= TIMEOUT_US + GUARD_US for gap in gaps)
    # and the request after the retry's timeout (to the next board) waits as long
    after = [
        t1 - t0
        for (t0, b0), (t1, b1) in itertools.pairwise(timed)
        if b0[:2] == bytes([26, 1]) and b1[:2] == bytes([27, 1])
    ]
    assert after and all(gap >= TIMEOUT_US + GUARD_US for gap in after)


def test_every_board_gets_a_stop_in_its_own_modes(bridge: BenchBridge) -> None:
    bridge.start()
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 600), ms=12) == [ack(3, 2)]
    bridge.bus()
    assert bridge.ask(frame(ESTOP, 4), ms=1) == [ack(4, ESTOP)]
    stops = {b[0]: b[2:] for b in bridge.bus() if b[1] == 0x02}
    assert sorted(stops) == sorted(bridge.robot.board_ids())
    for slot in bridge.motors:
        entry = stops[slot.board][3 * slot_position(bridge, slot) :][:3]
        function = slot.motor.function
        if function == "bend":
            assert entry == bytes([KEEP, 0, 0])
        else:
            assert entry == bytes([PWM, 0, 0]), slot.motor.name  # brake
    # the next exchange carries the protocol's stop setpoint, velocity 0 (a brake on
    # the board, docs/board-bus.md), not the old 600
    bridge.run(12)
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    assert to_22[-1][5:] == bytes([VELOCITY, 0, 0])


def slot_position(bridge: BenchBridge, slot: object) -> int:
    board = getattr(slot, "board")  # noqa: B009
    same = [s for s in bridge.motors if s.board == board]
    return same.index(slot)  # type: ignore[arg-type]


def test_a_board_holding_its_own_stop_stops_the_robot(bridge: BenchBridge) -> None:
    bridge.start()
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 600), ms=12) == [ack(3, 2)]
    bridge.bus()
    own_stop = 0x04
    bridge.board(27, online=True, status=own_stop)
    bridge.run(12)
    bridge.board(27, online=True, status=0)
    bridge.run(12)
    bodies = bridge.bus()
    stops = {b[0] for b in bodies if b[1] == 0x02}
    assert stops == set(bridge.robot.board_ids())
    to_22 = [b for b in bodies if b[:2] == bytes([22, 1])]
    assert to_22[-1][5:] == bytes([VELOCITY, 0, 0])
    status = bridge.state(bridge.states()[-1])[3]
    assert all(n & MOTORS_OFF for n in status)
    assert bridge.debug().board_own_stops >= 1


def test_the_elf_holds_de_low_from_its_first_instruction_and_carries_its_fuses() -> None:
    if shutil.which("avr-objdump") is None or not ELF.exists():
        pytest.skip("avr-objdump or the ELF missing (make firmware)")
    dump = subprocess.run(
        ["avr-objdump", "-d", "-j", ".text", str(ELF)], capture_output=True, text=True, check=True
    ).stdout
    code = {}
    for line in dump.splitlines():
        parts = line.split("\t")
        if len(parts) >= 3 and parts[0].strip().endswith(":"):
            code[int(parts[0].strip()[:-1], 16)] = " ".join(p.strip() for p in parts[2:4])
    assert code[0].startswith("jmp")  # the reset vector
    first = code[int(code[0].split()[1], 16)]
    assert first == "sbi 0x0d, 4"  # DDRE |= 1 << PE4: DE an output, low (PORTE is 0)
    fuses = subprocess.run(
        ["avr-objcopy", "-O", "binary", "-j", ".fuse", str(ELF), "/dev/stdout"],
        capture_output=True,
        check=True,
    ).stdout
    assert fuses == bytes([0xFF, 0xD8, 0xFC])  # brown-out at 4.3 V


# -- the hardware e-stop input (protocol 1.2) -------------------------------------------

F_ESTOP_INPUT = 0x10
HELLO_12 = 2


def _hello(bridge: BenchBridge, seq: int, minor: int) -> Frame:
    (reply,) = bridge.ask(frame(HELLO, seq, payload=struct.pack("<IB", bridge.digest, minor)))
    return reply


def test_the_input_trips_after_two_samples_and_ignores_a_shorter_spike(
    bridge: BenchBridge,
) -> None:
    bridge.run(25)
    reply = _hello(bridge, 1, HELLO_12)
    assert struct.unpack("<IBBHHBHB", reply.payload)[5] == 2  # the session speaks 1.2
    assert bridge.ask(frame(ESTOP_RESET, 2)) == [ack(2, ESTOP_RESET)]
    bridge.bus()
    # a spike shorter than a sample period: nothing happens
    bridge.lib.fw_estop_input(1)
    bridge.run(0.9)
    bridge.lib.fw_estop_input(0)
    bridge.run(20)
    assert not bridge.state(bridge.states()[-1])[2] & F_ESTOP
    assert bridge.debug().estop_input_trips == 0
    # held open: tripped within 2 ms, the stop on the bus at once
    bridge.bus_timed()
    bridge.lib.fw_estop_input(1)
    start = bridge.lib_now_us()
    bridge.run(5)
    stops = [t for t, body in bridge.bus_timed() if body[1] == 0x02]
    assert stops and stops[0] - start <= 2_000 + 2_500  # two samples + an exchange in flight
    flags = bridge.state(bridge.states()[-1])[2]
    assert flags & F_ESTOP and flags & F_ESTOP_INPUT
    assert bridge.debug().estop_input_trips == 1 and bridge.lib.fw_led() == 1
    # latched until the host resets it, and not while the contact is open
    assert bridge.ask(frame(ESTOP_RESET, 3)) == [nack(3, ESTOP_RESET, NOT_READY)]
    bridge.lib.fw_estop_input(0)
    bridge.run(30)  # closed, but not for 50 ms yet
    assert bridge.ask(frame(ESTOP_RESET, 4)) == [nack(4, ESTOP_RESET, NOT_READY)]
    bridge.run(40)
    assert bridge.state(bridge.states()[-1])[2] & F_ESTOP_INPUT  # still latched
    assert bridge.ask(frame(ESTOP_RESET, 5)) == [ack(5, ESTOP_RESET)]
    flags = bridge.state(bridge.states()[-1])[2]
    assert not flags & (F_ESTOP | F_ESTOP_INPUT)
    bridge.run(2)
    assert bridge.lib.fw_led() == 0


def test_a_1_1_session_sees_the_latch_but_never_the_new_flag(bridge: BenchBridge) -> None:
    bridge.run(25)
    reply = _hello(bridge, 1, 1)
    assert struct.unpack("<IBBHHBHB", reply.payload)[5] == 1
    bridge.lib.fw_estop_input(1)
    bridge.run(25)
    flags = bridge.state(bridge.states()[-1])[2]
    assert flags & F_ESTOP and not flags & 0xF0
    assert _hello(bridge, 2, 3).kind == NACK  # minor 3: BAD_LAYOUT
