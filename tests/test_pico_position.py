"""The reference PICO firmware's position target at every position raw value its layout
takes.

A joint's position setpoint becomes a target in its angle sensor's raw units once per
setpoint (docs/board-bus.md, "Modes on the board"): zero + raw x (angle raw per position
raw). The host build of the firmware (``make host``) is driven through ctypes with a
robot description whose position unit is coarse against its angle sensor's.
"""

from __future__ import annotations

import ctypes
import shutil
from pathlib import Path

import pytest
from pico_support import build_pico_host

from pirate_bt.sim.board_vectors import request_hex

HAL_RUN = 2
POSITION, PWM = 2, 0
BOARD = 22  # bend_1: its joint (motor 0) holds a position on its angle sensor (ADC 0)


@pytest.fixture(scope="module")
def coarse(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The PICO built for the 2018 robot with its joints' position unit 2 degrees (the
    angle sensor's 0.088 degrees): 22.76 angle raw per position raw."""
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    old = "position: {raw: [-2048, 2047], per_raw: 0.087890625 deg}"
    assert old in text
    build = tmp_path_factory.mktemp("pico-coarse")
    robot = build / "coarse.yaml"
    robot.write_text(text.replace(old, "position: {raw: [-2048, 2047], per_raw: 2 deg}"))
    try:
        return build_pico_host(build, robot=robot)
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the PICO logic cannot be built")
        raise


@pytest.mark.parametrize("raw", [1500, -1500, 2047, -2048])
def test_a_position_beyond_the_angle_sensor_drives_towards_it(
    coarse: Path, tmp_path: Path, raw: int
) -> None:
    """Position 1500 (3000 degrees; the protective layer clips to the joint's limits, a
    caller below it does not) made the target 2048 + 1500 x 1491308 / 65536 in 32 bits:
    the product overflowed and the target came out as -29354 (the sensor reads 0 to
    4095), so a joint at its zero asked to go up drove down at its hold duty, into the
    other end. The target is worked in 64 bits and held to what the angle sensor reads:
    the joint drives towards the end it was sent to and stops there."""
    copy = tmp_path / "pico.so"
    shutil.copy(coarse, copy)
    lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
    lib.pk_boot(BOARD, 0)
    lib.pk_adc(0, 512)  # the joint at its zero (2048 of 0..4095)
    lib.pk_run_us(2000)
    request = bytes.fromhex(request_hex(BOARD, 1, [(POSITION, raw), (PWM, 0)]))
    lib.pk_write(request, len(request))
    lib.pk_run_us(2000)
    out = (ctypes.c_int16 * 2)()
    lib.pk_state(0, out)
    assert list(out) == [POSITION, raw]  # taken
    lib.pk_motor(0, out)
    assert out[0] == HAL_RUN
    assert (out[1] > 0) == (raw > 0), f"position {raw}: duty {out[1]}"
    lib.pk_adc(0, 1023 if raw > 0 else 0)  # at the sensor's end: nothing further to go
    lib.pk_run_us(2000)
    lib.pk_motor(0, out)
    assert out[1] == 0, f"position {raw} at the sensor's end: duty {out[1]}"
