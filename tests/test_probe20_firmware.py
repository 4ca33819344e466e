"""Probe 20 of the embedded side, as a bench engineer reads docs/board-bus.md and
docs/firmware.md: the reference PICO's scalings at the ends of int16.

The PICO's host build (``make -C firmware/pico host``) is driven through ctypes, in
virtual time, with robot descriptions ``pirate-bt validate`` accepts.
"""

from __future__ import annotations

import ctypes
import shutil
from pathlib import Path

import pytest
from pico_support import build_pico_host

from pirate_bt.sim.board_vectors import request_hex

ROBOT = Path(__file__).parents[1] / "hardware" / "pirate.yaml"
HAL_RUN = 2
PWM, TORQUE = 0, 1
BEND_BOARD = 22  # bend_1: its joint (motor 0) takes pwm, torque and position


def pico_for(tmp: Path, old: str, new: str) -> Path:
    """The PICO host library built for the default robot with ``old`` replaced."""
    text = ROBOT.read_text()
    assert old in text
    robot = tmp / "robot.yaml"
    robot.write_text(text.replace(old, new))
    try:
        return build_pico_host(tmp, robot=robot)
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the PICO logic cannot be built")
        raise


@pytest.fixture(scope="module")
def int16_min_torque(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The joints' torque range from INT16_MIN: [-32768, 1023] (pirate-bt validate takes
    it; the top of the range is 32768)."""
    return pico_for(
        tmp_path_factory.mktemp("pico-int16-min"),
        "torque: {raw: [-1023, 1023], per_raw: 1 mN*m}",
        "torque: {raw: [-32768, 1023], per_raw: 1 mN*m}",
    )


def joint_duty(library: Path, tmp_path: Path, mode: int, raw: int) -> tuple[int, int]:
    """(drive, duty) of board 22's joint once it executes ``mode raw``."""
    copy = tmp_path / "pico.so"
    shutil.copy(library, copy)
    lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
    lib.pk_boot(BEND_BOARD, 0)
    lib.pk_run_us(2000)
    request = bytes.fromhex(request_hex(BEND_BOARD, 1, [(mode, raw), (PWM, 0)]))
    lib.pk_write(request, len(request))
    lib.pk_run_us(2000)
    out = (ctypes.c_int16 * 2)()
    lib.pk_state(0, out)
    assert list(out) == [mode, raw]  # taken
    lib.pk_motor(0, out)
    return out[0], out[1]


@pytest.mark.parametrize(
    ("raw", "duty"),
    [(-1023, -7), (1023, 7), (-32768, -255), (-16384, -127), (0, 0)],
)
def test_a_torque_range_from_int16_min_scales_to_its_top_of_32768(
    int16_min_torque: Path, tmp_path: Path, raw: int, duty: int
) -> None:
    """docs/board-bus.md: torque's duty is raw / the top of the torque range. With the
    range [-32768, 1023] the PICO took -(-32768) in 16 bits, -32768 again, so the top
    came out as 1023: torque -1023 (3 % of the range) drove the joint at full duty
    (-255) and -16384 too, where the scale gives -7 and -127."""
    drive, got = joint_duty(int16_min_torque, tmp_path, TORQUE, raw)
    assert got == duty, f"torque {raw}: duty {got}"
    assert drive == (HAL_RUN if duty else 1)  # 1: brake
