"""The AVR build of the bridge firmware in simavr, as a conformance bridge under test.

The ELF (``firmware/piratebay/build/piratebay.elf``) runs in the simavr harness
(``firmware/simavr/``) in real time; the test talks to it through the host's end
of the harness's pty, exactly as ``pirate-bt run --port`` does, and the boards on
its RS485 bus are the Python ones (:mod:`pirate_bt.sim.boardbus`) with the pipe
physics. Real time only: tests that need virtual hours skip it with their reason.

Register it in ``conftest.py``'s ``BRIDGES`` as ``"firmware-simavr": SimavrBridge``
(:func:`available` says why not, when the toolchain is missing).
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
import tty

from firmware_sim_support import build, missing_toolchain

from pirate_bt.pipes import load_network
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.boardbus import FirmwareBridge
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["SimavrBridge", "available"]


def available() -> str | None:
    """None when the firmware can run in simavr here, else the reason it cannot."""
    return missing_toolchain()


class SimavrBridge:
    """The firmware in simavr behind a pty, in real time (``BridgeUnderTest``)."""

    virtual_time = False

    def __init__(self, robot: RobotDescription) -> None:
        self.name = "firmware-simavr"
        self.robot = robot
        elf, harness = build()
        model = PipeRobotModel(robot, load_network("straight"))
        self._bridge = FirmwareBridge(elf, model, harness=harness, boot_ms=0)
        device = self._bridge.start()
        self._fd = os.open(device, os.O_RDWR | os.O_NOCTTY)  # the DTR edge: a fresh boot
        tty.setraw(self._fd)
        self._timers: list[threading.Timer] = []
        self._pending = b""
        self._settle()

    def _settle(self) -> None:
        """Wait until the reset is done and drop what came before, up to a frame's end.

        The drain may cut the first frame of the new boot: its tail, up to its 0x00,
        goes too, so the tests start on a frame boundary.
        """
        time.sleep(0.05)
        self._pending = b""
        data = self.read(0.0)
        while not data.endswith(b"\x00"):
            more = self.read(0.05)
            if not more:
                break
            data += more
        self._pending = data[data.rfind(b"\x00") + 1 :]

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view) :]

    def read(self, timeout_s: float) -> bytes:
        deadline = time.monotonic() + timeout_s
        out = bytearray(self._pending)
        self._pending = b""
        while True:
            ready, _, _ = select.select([self._fd], [], [], max(0.0, deadline - time.monotonic()))
            if ready:
                out += os.read(self._fd, 65536)
            elif time.monotonic() >= deadline:
                return bytes(out)

    def advance(self, seconds: float) -> None:
        time.sleep(seconds)

    def reset(self) -> None:
        self._bridge.reset_mcu()
        self._settle()

    def disconnect_board(self, board: int, seconds: float) -> None:
        """A board stops answering its polls for ``seconds`` (then answers again)."""
        self._bridge.set_silent(board, True)
        timer = threading.Timer(seconds, self._bridge.set_silent, (board, False))
        timer.daemon = True
        timer.start()
        self._timers.append(timer)
        time.sleep(self.robot.bridge.state_period)

    def close(self) -> None:
        for timer in self._timers:
            timer.cancel()
        with contextlib.suppress(OSError):
            os.close(self._fd)
        self._bridge.close()
