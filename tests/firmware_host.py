"""The bridge firmware's C logic as a bridge under test, in virtual time.

``firmware/piratebay/host/host_hal.c`` replaces the AVR hardware files (USARTs,
timers, the MCU) so the rest of the firmware, as flashed, compiles for the host
as a shared library. :class:`FirmwareHostBridge` drives it through bytes only,
with the members of the conformance suite's ``BridgeUnderTest`` (``write``,
``read``, ``advance``, ``reset``, ``close``, ``disconnect_board``), so the same
tests run against the Python simulated bridge, this, and the AVR build in simavr.
Its line runs at the robot's baud rate and its transmitter follows the spec's
transmit order (at most 4 answers wait), as the real firmware's do. The boards
on its bus answer every poll at once with fixed readings.
"""

from __future__ import annotations

import contextlib
import ctypes
import fcntl
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

from pirate_bt.robot.description import RobotDescription

__all__ = ["FIRMWARE", "FirmwareHostBridge", "build_host_library", "build_lock"]

FIRMWARE = next(
    p / "firmware" / "piratebay"
    for p in Path(__file__).resolve().parents
    if (p / "firmware" / "piratebay" / "Makefile").exists()
)

_built: dict[tuple[Path, Path], Path] = {}


@contextlib.contextmanager
def build_lock() -> Iterator[None]:
    """One firmware build at a time on this checkout, across test processes.

    Tests run in parallel workers may ask make for the same outputs at once; make
    itself does not lock, so two would write the same objects.
    """
    lock_dir = FIRMWARE / "build"
    lock_dir.mkdir(parents=True, exist_ok=True)
    with open(lock_dir / ".build.lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def build_host_library(build: Path, robot_file: Path | None = None) -> Path:
    """Build the host library for ``robot_file`` (default robot) into ``build``.

    Raises:
        RuntimeError: no C compiler or make, or the build failed.
    """
    robot = robot_file or FIRMWARE.parents[1] / "hardware" / "pirate.yaml"
    key = (build, robot)
    if key in _built:
        return _built[key]
    if shutil.which("cc") is None or shutil.which("make") is None:
        raise RuntimeError("no host C compiler (cc) or make")
    with build_lock():
        result = _make_host(build, robot)
    if result.returncode != 0:
        raise RuntimeError(f"building the firmware host library failed:\n{result.stderr}")
    _built[key] = build / "libpiratebay_host.so"
    return _built[key]


def _make_host(build: Path, robot: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            "make",
            "-s",
            "-C",
            str(FIRMWARE),
            "host",
            f"BUILD={build}",
            f"ROBOT={robot}",
            f"PIRATE_BT={sys.executable} -m pirate_bt",
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
        check=False,
    )


class FirmwareHostBridge:
    """The firmware's logic, compiled for the host, one private copy per instance.

    Args:
        robot: The robot description the library was built for.
        library: The built library (:func:`build_host_library`).
        workdir: Where to put this instance's private copy of the library (each
            copy has its own static state).
    """

    virtual_time = True
    line_limited = True

    def __init__(self, robot: RobotDescription, library: Path, workdir: Path) -> None:
        self.name = "firmware-host"
        self.robot = robot
        workdir.mkdir(parents=True, exist_ok=True)
        copy = workdir / f"bridge-{id(self)}.so"
        shutil.copy(library, copy)
        self._lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
        self._copy = copy
        self._boards = sorted(robot.board_ids())
        self._down: dict[int, int] = {}  # board index -> virtual µs it answers again
        self.now_us = 0
        for index in range(len(self._boards)):
            self._lib.fw_board(index, 1, 0)
        self._lib.fw_boot()

    def write(self, data: bytes) -> None:
        self._lib.fw_write(data, len(data))

    def read(self, timeout_s: float) -> bytes:
        self.advance(timeout_s)
        buf = ctypes.create_string_buffer(1 << 16)
        out = bytearray()
        while True:
            n = self._lib.fw_read(buf, len(buf))
            out += buf.raw[:n]
            if n < len(buf):
                return bytes(out)

    def advance(self, seconds: float) -> None:
        end = self.now_us + round(seconds * 1e6)
        while self.now_us < end:
            step = end - self.now_us
            for index, until in list(self._down.items()):
                if until <= self.now_us:
                    self._lib.fw_board(index, 1, 0)
                    del self._down[index]
                else:
                    step = min(step, until - self.now_us)
            self._lib.fw_run_us(ctypes.c_uint32(step))
            self.now_us += step

    def reset(self) -> None:
        self._lib.fw_boot()

    def disconnect_board(self, board: int, seconds: float) -> None:
        """A board stops answering its polls for ``seconds``."""
        index = self._boards.index(board)
        self._lib.fw_board(index, 0, 0)
        self._down[index] = self.now_us + round(seconds * 1e6)
        self.advance(self.robot.bridge.state_period)

    def set_estop_input(self, pressed: bool) -> None:
        """The hardware e-stop contact opens (pressed) or closes."""
        self._lib.fw_estop_input(int(pressed))

    def close(self) -> None:
        self._copy.unlink(missing_ok=True)
