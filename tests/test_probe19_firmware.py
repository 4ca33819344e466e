"""Probe 19, the embedded side: the firmwares and their simulators against hostile inputs.

Each test here failed before the fix it names in its docstring.
"""

from __future__ import annotations

import binascii
import os
import select
import struct
import time
import tty
from collections.abc import Callable

import pytest
from firmware_chain_support import build_chain, missing_chain
from firmware_sim_support import build, missing_toolchain

from pirate_bt.clock import SimClock
from pirate_bt.errors import FrameError
from pirate_bt.link.codec import cobs_decode, cobs_encode
from pirate_bt.pipes import load_network
from pirate_bt.robot import load_robot
from pirate_bt.sim.chain import FirmwareChain
from pirate_bt.sim.firmware_bridge import FirmwareBridge
from pirate_bt.sim.model import PipeRobotModel

HELLO, ESTOP_RESET = 0x01, 0x06
HELLO_REPLY, ACK, NACK = 0x81, 0x83, 0x84
F_ESTOP, F_ESTOP_INPUT = 0x01, 0x10
NOT_READY = 10


def frame(kind: int, seq: int, payload: bytes = b"") -> bytes:
    """A host frame, written from docs/protocol.md (COBS, CRC-16/XMODEM)."""
    body = bytes([1, kind]) + struct.pack("<HB", seq, 0) + payload
    body += struct.pack("<H", binascii.crc_hqx(body, 0))
    return cobs_encode(body) + b"\x00"


def answers(wire: bytes) -> list[tuple[int, int, bytes]]:
    """(type, arg, payload) of every good frame in ``wire`` (a frame a reset cut is none)."""
    out = []
    for raw in wire.split(b"\x00")[:-1]:
        try:
            body = cobs_decode(raw)
        except FrameError:  # the frame a reset cut
            continue
        if len(body) < 7 or binascii.crc_hqx(body[:-2], 0) != struct.unpack("<H", body[-2:])[0]:
            continue
        out.append((body[1], body[4], body[5:-2]))
    return out


def hello_then_reset(ask: Callable[[bytes], list[tuple[int, int, bytes]]]) -> tuple[int, bytes]:
    """A 1.2 session, then ESTOP_RESET: the HELLO_REPLY's flags and the reset's answer."""
    digest = load_robot().layout_digest()
    (reply,) = [
        a
        for a in ask(b"\x00" + frame(HELLO, 1, struct.pack("<IB", digest, 2)))
        if a[0] == HELLO_REPLY
    ]
    (answer,) = [a for a in ask(frame(ESTOP_RESET, 2)) if a[0] in (ACK, NACK)]
    return reply[1], bytes([answer[0]]) + answer[2]


@pytest.mark.skipif(missing_chain() is not None, reason=str(missing_chain()))
def test_the_chain_keeps_the_estop_button_pressed_through_a_bridge_reset() -> None:
    """A reset cleared simavr's PINA and the chain never put the e-stop contact back: a
    bridge reset with its mushroom button held down (a DTR reset, its watchdog) came
    back with the button read released, and released its latch at the host's
    ESTOP_RESET (ACK APPLIED) while the button was still pressed. On a Mega the pin
    stays high through a reset: NACK NOT_READY, and the 1.2 flag ESTOP_INPUT."""
    bridge, pico, harness = build_chain()
    clock = SimClock()
    chain = FirmwareChain(
        bridge,
        pico,
        PipeRobotModel(load_robot(), load_network("straight")),
        clock=clock,
        harness=harness,
    )
    now = [0.0]

    def run(seconds: float) -> list[tuple[int, int, bytes]]:
        now[0] += seconds
        chain.advance_to(now[0])
        return answers(chain.read())

    def ask(data: bytes) -> list[tuple[int, int, bytes]]:
        chain.write(data)
        return run(0.05)

    try:
        run(0.1)
        assert hello_then_reset(ask)[1] == bytes([ACK, ESTOP_RESET, 0])  # released
        chain.set_estop_input(True)
        run(0.05)
        chain._send("X")  # the bridge's core resets, as at a DTR edge
        run(0.2)
        flags, answer = hello_then_reset(ask)
    finally:
        chain.close()
    assert flags & (F_ESTOP | F_ESTOP_INPUT) == F_ESTOP | F_ESTOP_INPUT, flags
    assert answer == bytes([NACK, ESTOP_RESET, NOT_READY])


@pytest.mark.xdist_group("real-time")
@pytest.mark.skipif(missing_toolchain() is not None, reason=str(missing_toolchain()))
def test_the_simavr_harness_keeps_the_estop_button_pressed_through_a_dtr_reset() -> None:
    """The same in `pirate-bt sim --firmware`'s harness: a host that reopened the pty
    (the DTR reset) with the bridge's button held down could release the latch."""
    elf, harness = build()
    model = PipeRobotModel(load_robot(), load_network("straight"))
    with FirmwareBridge(elf, model, harness=harness, boot_ms=0) as sim:
        device = sim.start(timeout_s=30.0)
        sim.hold(timeout_s=30.0)  # the MCU's clock runs only inside run() below
        fd = os.open(device, os.O_RDWR | os.O_NOCTTY)  # the DTR edge: a fresh boot
        try:
            tty.setraw(fd)
            sim.wait_resets(1, timeout_s=30.0)

            def run(seconds: float) -> list[tuple[int, int, bytes]]:
                """``seconds`` of the MCU's time, whatever the wall clock does meanwhile."""
                wire = bytearray()
                until = sim.mcu_time_s + seconds
                give_up = time.monotonic() + 60.0
                sim.go()
                while sim.mcu_time_s < until and time.monotonic() < give_up:
                    if select.select([fd], [], [], 0.01)[0]:
                        wire += os.read(fd, 65536)
                sim.hold(timeout_s=30.0)
                while select.select([fd], [], [], 0.0)[0]:
                    wire += os.read(fd, 65536)
                assert sim.mcu_time_s >= until, "the harness's MCU did not run"
                return answers(bytes(wire))

            def ask(data: bytes) -> list[tuple[int, int, bytes]]:
                os.write(fd, data)
                return run(0.05)

            run(0.05)
            assert hello_then_reset(ask)[1] == bytes([ACK, ESTOP_RESET, 0])  # released
            sim.set_estop_input(True)
            run(0.05)
            sim.reset_mcu(timeout_s=30.0)
            run(0.05)
            flags, answer = hello_then_reset(ask)
        finally:
            os.close(fd)
    assert flags & (F_ESTOP | F_ESTOP_INPUT) == F_ESTOP | F_ESTOP_INPUT, flags
    assert answer == bytes([NACK, ESTOP_RESET, NOT_READY])
