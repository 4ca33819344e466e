"""The reference PICO's yaw channel of a BNO055 heading, and the IMU's raw range.

A BNO055 gives its heading 0..360 degrees, growing clockwise (1/16 degree); the yaw
channel is the simulator's, counter-clockwise in (-180, 180] (an atan2; 0.1 mrad raw,
int16). The firmware (``firmware/pico/sensors.c``) scaled the heading as it came and
clamped: any heading above about 188 degrees read 188 degrees, so a left turn of 90
degrees (heading 270) read as a turn to the right. It wraps the heading first.

The host build of the board logic (``make host``), driven through ctypes.
"""

from __future__ import annotations

import ctypes
import math
import shutil
from pathlib import Path

import pytest
from pico_support import build_pico_host

from pirate_bt.link import BridgeFlags, State
from pirate_bt.link.ranges import ReadingRanges
from pirate_bt.robot import load_robot
from pirate_bt.sim.board_vectors import heading_of_yaw

ROBOT = load_robot()
BOARD = 24  # the rotational module's IMU: roll, pitch, yaw, then its drive's feedback
CHANNELS = [c for c in ROBOT.state_channels() if c.board == BOARD]
YAW = next(i for i, c in enumerate(CHANNELS) if c.name.endswith(".yaw"))
PER_RAW = CHANNELS[YAW].conversion.per_raw  # radians per raw unit


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_pico_host(tmp_path_factory.mktemp("simconf21-pico"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the PICO logic cannot be built")
        raise


def yaw_read(library: Path, tmp_path: Path, heading_deg: float) -> float:
    """The yaw (degrees) the board reports with its IMU's heading at ``heading_deg``."""
    copy = tmp_path / "pico.so"
    shutil.copy(library, copy)
    lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
    lib.pk_boot(BOARD, 0)
    lib.pk_imu(round(heading_deg * 16), 0, 0)
    lib.pk_run_us(30_000)
    lib.pk_channel.restype = ctypes.c_int16
    return math.degrees(lib.pk_channel(YAW) * PER_RAW)


@pytest.mark.parametrize(
    ("heading", "yaw"),
    [
        (0, 0),
        (90, -90),  # a right turn of 90 degrees: clockwise
        (270, 90),  # a left turn of 90 degrees (it read -188: clamped)
        (180, 180),
        (200, 160),  # it read -188
        (359.9375, 0.0625),
    ],
)
def test_the_yaw_of_a_heading_is_counter_clockwise_in_plus_minus_180(
    library: Path, tmp_path: Path, heading: float, yaw: float
) -> None:
    assert yaw_read(library, tmp_path, heading) == pytest.approx(yaw, abs=0.01)


@pytest.mark.parametrize("yaw_lsb", [0, 16, -16, 1440, -1440, 2880, -2879])
def test_the_simulated_imus_heading_reads_back_as_its_yaw(
    library: Path, tmp_path: Path, yaw_lsb: int
) -> None:
    """What the chain and the board vectors feed the board's IMU is a BNO055's heading."""
    heading = heading_of_yaw(yaw_lsb)
    assert 0 <= heading < 5760
    assert yaw_read(library, tmp_path, heading / 16) == pytest.approx(yaw_lsb / 16, abs=0.01)


def test_an_imu_reading_no_imu_gives_is_not_taken() -> None:
    """hardware/pirate.yaml's IMU reads +-pi (raw [-31416, 31416] at 0.1 mrad): a STATE
    whose pitch says 32767 (188 degrees) is refused, not taken."""
    channels = ROBOT.state_channels()
    for c in channels:
        if c.name.startswith("imu."):
            assert c.conversion.raw == (-31416, 31416), c.name
    pitch = next(i for i, c in enumerate(channels) if c.name == "imu.pitch")
    fresh = (1 << len(channels)) - 1
    raw = [c.conversion.zero_raw for c in channels]
    raw[pitch] = 32767
    frame = State(2, BridgeFlags.NONE, 0, fresh, (1,) * len(ROBOT.board_ids()), tuple(raw))
    ranges = ReadingRanges(ROBOT)
    readings = ranges.readings(frame)
    assert readings[pitch] is None
    assert ranges.refused == 1
    raw[pitch] = 31416  # +pi: taken
    frame = State(3, BridgeFlags.NONE, 0, fresh, (1,) * len(ROBOT.board_ids()), tuple(raw))
    assert ranges.readings(frame)[pitch] == 31416


@pytest.mark.parametrize(
    "description",
    sorted(p.name for p in (Path(__file__).parents[1] / "hardware" / "variants").glob("*.yaml")),
)
def test_every_bundled_variants_imu_reading_past_pi_is_not_taken(description: str) -> None:
    """The variants beside hardware/pirate.yaml kept the IMU's int16 range after it
    became +-pi: a STATE saying 32767 (188 degrees) was taken from their IMUs."""
    robot = load_robot(Path(__file__).parents[1] / "hardware" / "variants" / description)
    channels = robot.state_channels()
    imus = [i for i, c in enumerate(channels) if c.dimension == "angle" and "imu" in c.name]
    fresh = (1 << len(channels)) - 1
    raw = [c.conversion.zero_raw for c in channels]
    for i in imus:
        raw[i] = 32767
    frame = State(2, BridgeFlags.NONE, 0, fresh, (1,) * len(robot.board_ids()), tuple(raw))
    ranges = ReadingRanges(robot)
    readings = ranges.readings(frame)
    assert imus and all(readings[i] is None for i in imus)
    assert ranges.refused == len(imus)
