"""The reference PICO firmware's drive speed at every encoder resolution its build takes.

A drive's velocity channel is its encoder's count over the last 40 ms x the wheel
circumference / ``ENCODER_CPR`` (docs/board-bus.md, "The reference PICO board"), in the
velocity feedback's raw unit. The host build of the firmware (``make host``) is driven
through ctypes: the encoder turns at a set speed, and the board's velocity channel (what
its reply carries) and the speed its velocity loop closes on are read back.
"""

from __future__ import annotations

import ctypes
import itertools
import math
import shutil
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import pytest
from pico_support import build_pico_host

from pirate_bt.robot.loader import load_robot

_COPIES = itertools.count()
BOARD = 22  # the front drive's board: its drive motor on slot 1
DRIVE_SLOT = 1


@dataclass(frozen=True)
class Drive:
    """Board 22's drive in a robot description: its motor index, its velocity channel's
    index on the board, wheel circumference in um, one velocity raw unit in um/s, and
    the raw range's top."""

    motor: int
    channel: int
    circumference_um: int
    velocity_um_s: int
    raw_top: int


def _drive(robot_file: Path | None = None) -> Drive:
    robot = load_robot(robot_file)
    board = robot.board(BOARD)
    motors = sorted(board.motors, key=lambda m: m.slot)
    k = [m.slot for m in motors].index(DRIVE_SLOT)
    channels = [c for c in robot.state_channels() if c.board == BOARD]
    drive = motors[k]
    velocity = drive.feedback.velocity
    assert velocity is not None
    c = next(i for i, ch in enumerate(channels) if ch.name.endswith(f"{drive.name}.velocity"))
    radius = robot.module(board.module).wheel_radius
    assert radius
    circumference = round(2 * math.pi * radius * 1e6)
    return Drive(k, c, circumference, round(velocity.per_raw * 1e6), velocity.raw[1])


def _library(tmp: pytest.TempPathFactory, cpr: int, robot_file: Path | None = None) -> Path:
    try:
        return build_pico_host(tmp.mktemp(f"pico-host-{cpr}"), encoder_cpr=cpr, robot=robot_file)
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the PICO logic cannot be built")
        raise


@pytest.fixture(scope="module")
def fine(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The PICO built with the finest resolution its Makefile takes."""
    return _library(tmp_path_factory, 32768)


@pytest.fixture(scope="module")
def default(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _library(tmp_path_factory, 3072)


class Board:
    """One board of a host build (a private copy of the library: its own state)."""

    def __init__(self, library: Path, workdir: Path, cpr: int, drive: Drive) -> None:
        copy = workdir / f"pico-{cpr}-{next(_COPIES)}.so"  # never over a loaded one
        shutil.copy(library, copy)
        self.lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
        self.lib.pk_channel.restype = ctypes.c_int16
        self.lib.pk_speed.restype = ctypes.c_int16
        self.cpr = cpr
        self.drive = drive
        self.lib.pk_boot(BOARD, 0)

    def turn_at(self, speed_mm_s: float, ms: int = 100) -> list[int]:
        """Turn the wheel at ``speed_mm_s`` for ``ms``; the encoder count of each 10 ms.

        The count moves at 5 ms past each 10 ms, half-way between two of the board's
        samples (at each whole 10 ms of its clock), so which count each sample saw is
        known: the last sample in the ``ms`` is at 90 ms, of the count set at 85 ms.
        """
        counts = []
        for t in range(ms):
            if t % 10 == 5:
                count = round(
                    speed_mm_s * 1000 * (t / 1000) * self.cpr / self.drive.circumference_um
                )
                counts.append(count)
                self.lib.pk_encoder(DRIVE_SLOT, ctypes.c_int16(((count + 32768) % 65536) - 32768))
            self.lib.pk_run_us(1000)
        return counts

    def expected(self, counts: list[int]) -> int:
        """The speed the page's formula gives for the last 40 ms, rounded half away from
        zero, in velocity raw units (before the channel's raw range)."""
        window = counts[-2] - counts[-6]  # the samples at 90 ms and 50 ms
        d = self.drive
        exact = Fraction(abs(window) * 25 * d.circumference_um, self.cpr * d.velocity_um_s)
        return int(math.copysign(min(32767, math.floor(exact + Fraction(1, 2))), window))

    def check(self, speeds: list[float]) -> None:
        """At each speed: the loop's speed is the formula's, and the velocity channel
        that, held to the channel's raw range."""
        d = self.drive
        per_count = 25 * d.circumference_um / (self.cpr * d.velocity_um_s)  # raw per count
        for speed in speeds:
            counts = self.turn_at(speed)
            want = self.expected(counts)
            true_raw = speed * 1000 / d.velocity_um_s
            assert abs(want - true_raw) <= per_count + 1  # the test's own arithmetic
            got = self.lib.pk_speed(d.motor)
            assert got == want, f"ENCODER_CPR={self.cpr} at {speed} mm/s: speed {got}, not {want}"
            reported = self.lib.pk_channel(d.channel)
            assert reported == max(-d.raw_top, min(d.raw_top, want)), f"{speed} mm/s: {reported}"


SPEEDS_MM_S = [-200.0, -120.0, -100.0, -80.0, -65.0, 0.0, 30.0, 66.0, 80.0, 100.0, 120.0, 200.0]


@pytest.mark.parametrize("cpr", [32768, 3072])
def test_a_drive_reports_its_speed_at_every_speed_the_robot_reaches(
    fine: Path, default: Path, tmp_path: Path, cpr: int
) -> None:
    """With ENCODER_CPR=32768 (which the Makefile accepts) a wheel turning at 80 mm/s
    read as -511 raw (-51.1 mm/s), one at 200 mm/s as -621, and one at -200 mm/s as
    +621: counts x 25 x the circumference overflowed 32 bits from 66 mm/s, so the
    velocity loop drove a wheel already at its setpoint harder and the host saw it
    reverse. The default 3072 stays as it was."""
    Board(fine if cpr == 32768 else default, tmp_path, cpr, _drive()).check(SPEEDS_MM_S)


def test_a_wheel_whose_speed_scale_needs_more_than_16_bits_is_read_exactly(
    tmp_path_factory: pytest.TempPathFactory, tmp_path: Path
) -> None:
    """A wheel of radius 12.0001 mm (circumference 75399 um, odd): with ENCODER_CPR=32768
    the speed fraction in lowest terms is 75399/131072, beyond the 32-bit path; the
    board works it in 64 bits and reads every speed as exactly."""
    text = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text()
    assert "wheel_radius: 12 mm" in text
    robot_file = tmp_path / "odd-wheel.yaml"
    robot_file.write_text(text.replace("wheel_radius: 12 mm", "wheel_radius: 12.0001 mm"))
    drive = _drive(robot_file)
    assert drive.circumference_um == 75399
    library = _library(tmp_path_factory, 32768, robot_file)
    Board(library, tmp_path, 32768, drive).check(SPEEDS_MM_S)


def test_a_host_build_follows_encoder_cpr_in_the_same_build_directory(
    tmp_path_factory: pytest.TempPathFactory, tmp_path: Path
) -> None:
    """`make host ENCODER_CPR=32768` into a directory built before with the default kept
    the old library: ENCODER_CPR was not among the flags that make a host build again,
    so a board counting 32768 per revolution read 80 mm/s as 10.7 times that."""
    build = tmp_path_factory.mktemp("pico-host-again")
    build_pico_host(build, encoder_cpr=3072)
    library = build_pico_host(build, encoder_cpr=32768)
    Board(library, tmp_path, 32768, _drive()).check([80.0])
