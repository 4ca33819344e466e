"""Probe 22: a PICO board whose drive is not on slot 0 reads its wheel at boot.

The reference PICO (``firmware/pico/sensors.c``) measures a drive's speed as the
change of its encoder's count over the last 40 ms, from a ring of counts it fills at
boot. It filled motor k's ring from encoder ``k``, where every later sample reads the
encoder of the motor's slot: on board 24 of the default robot (its one motor,
``rotational_drive_a``, on slot 1) the ring started with slot 0's count. With the AVR's
counters at 0 after a reset the two agree; with a counter that keeps its count through
the board's reset (a port whose HAL reads a hardware quadrature counter, docs/board-bus.md
"The reference PICO board": hal.h is the seam) a wheel at rest read as turning fast for
the first 40 ms after a boot: the reply's velocity channel, and the speed the velocity
loop closes on, jumped. The host build (``make host``), driven through ctypes.
"""

from __future__ import annotations

import ctypes
import shutil
from pathlib import Path

import pytest
from pico_support import build_pico_host

from pirate_bt.robot.loader import load_robot

ROBOT = load_robot()
BOARD = 24  # rotational_drive_a alone, on slot 1


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_pico_host(tmp_path_factory.mktemp("fw22-pico"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the PICO logic cannot be built")
        raise


def test_a_drive_on_slot_1_at_rest_reads_0_from_its_boot(library: Path, tmp_path: Path) -> None:
    board = ROBOT.board(BOARD)
    (drive,) = board.motors
    assert drive.slot == 1 and drive.feedback.velocity is not None  # the case of interest
    channels = [c.name for c in ROBOT.state_channels() if c.board == BOARD]
    velocity = channels.index(f"{drive.name}.velocity")
    copy = tmp_path / "pico.so"
    shutil.copy(library, copy)
    lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
    lib.pk_speed.restype = ctypes.c_int16
    lib.pk_channel.restype = ctypes.c_int16
    lib.pk_encoder(1, ctypes.c_int16(4000))  # the drive's counter, kept through the reset
    lib.pk_encoder(0, ctypes.c_int16(0))  # slot 0: no motor on this board
    lib.pk_boot(BOARD, 1)  # a warm boot (its watchdog, say)
    seen = []
    for _ in range(100):  # the wheel stands still: every sample is 4000
        lib.pk_run_us(1000)
        seen.append((lib.pk_speed(0), lib.pk_channel(velocity)))
    assert set(seen) == {(0, 0)}, f"speed and velocity channel, each ms after boot: {seen}"
