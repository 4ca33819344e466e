"""Probe 20 of the embedded side, as a bench engineer reads docs/board-bus.md and
docs/firmware.md: the reference PICO's scalings at the ends of int16, and its IMU as a
BNO055 behaves on a bench.

The PICO's host build (``make -C firmware/pico host``) is driven through ctypes, in
virtual time, with robot descriptions ``pirate-bt validate`` accepts; its AVR build runs
in simavr, in virtual time (``make -C firmware/pico imu-probe``: a run to its end, no
wall clock), with a BNO055 that starts in CONFIGMODE as the datasheet says.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from pico_support import PICO, build_pico_elf, build_pico_host

from pirate_bt.link.codec import cobs_decode
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


IMU_BOARD = 24  # rotational: roll, pitch, yaw (0.1 mrad), then its motor's velocity, current
STALE = 0x08


@pytest.fixture(scope="module")
def imu_probe(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(pico.elf, imu-probe), built into one folder."""
    if shutil.which("avr-gcc") is None:
        pytest.skip("avr-gcc missing: install Debian's gcc-avr and avr-libc (make firmware does)")
    if subprocess.run(["pkg-config", "--exists", "simavr"], check=False).returncode != 0:
        pytest.skip("libsimavr-dev missing (make firmware installs it)")
    build = tmp_path_factory.mktemp("pico-imu")
    elf = build_pico_elf(build)
    done = subprocess.run(
        ["make", "-s", "-C", str(PICO), f"BUILD={build}", "imu-probe"],
        capture_output=True,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return elf, build / "imu-probe"


@pytest.mark.parametrize(
    ("euler", "channels"),
    [
        # heading 10, roll 20, pitch -30 degrees (1/16 degree on the IMU's registers);
        # the heading grows clockwise, the yaw counter-clockwise in (-180, 180]
        ((160, 320, -480), [3491, -5236, -1745]),
        ((4320, -720, 1200), [-7854, 13090, 15708]),  # heading 270, roll -45, pitch 75
    ],
)
def test_the_board_reads_its_bno055_s_angles_not_the_zeros_of_its_config_mode(
    imu_probe: tuple[Path, Path], euler: tuple[int, int, int], channels: list[int]
) -> None:
    """docs/board-bus.md: the PICO's IMU is BNO055-style at 0x28 and its axes are the
    IMU's Euler angles. A BNO055 powers up in CONFIGMODE, where every output register
    reads 0 (datasheet 3.3.1: another mode must be chosen to read any sensor data); the
    board only ever read the Euler registers, so a real one gave roll, pitch and yaw 0
    for good, fresh (every read succeeded, no STALE): the host saw a level robot in a
    riser. The board must put the IMU in a fusion mode and read the angles there."""
    elf, probe = imu_probe
    heading, roll, pitch = euler
    request = request_hex(IMU_BOARD, 1, [(0, 0)])  # EXCHANGE: the rotation motor, pwm 0
    done = subprocess.run(
        [str(probe), str(elf), str(IMU_BOARD), str(heading), str(roll), str(pitch), request],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    lines = dict(
        x.split(" ", 1) for x in done.stdout.splitlines() if x.startswith(("reply", "opr"))
    )
    assert lines["opr_mode"] == "8"  # IMU: accelerometer and gyroscope fusion
    wire = bytes.fromhex(lines["reply"])
    assert wire.endswith(b"\x00")
    body = cobs_decode(wire[:-1])
    assert body[:2] == bytes((IMU_BOARD, 0x81))
    assert not body[2] & STALE
    values = [int.from_bytes(body[3 + 2 * i : 5 + 2 * i], "little", signed=True) for i in range(5)]
    assert values[:3] == channels  # roll, pitch, yaw in 0.1 mrad
