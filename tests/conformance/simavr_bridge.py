"""The AVR build of the bridge firmware in simavr, as a conformance bridge under test.

The ELF (``firmware/piratebay/build/piratebay.elf``) runs in the simavr harness
(``firmware/simavr/``) in real time; the test talks to it through the host's end
of the harness's pty, exactly as ``pirate-bt run --port`` does, and the boards on
its RS485 bus are the Python ones (:mod:`pirate_bt.sim.boardbus`) with the pipe
physics. Real time only: tests that need virtual hours skip it with their reason.
Its time is the MCU's, and it passes only inside ``read`` and ``advance`` (the
harness holds the MCU in between): on a loaded machine the tests still see their
own timing (a watchdog test waits 350 ms of MCU time, and nothing trips while the
test itself is descheduled).

Register it in ``conftest.py``'s ``BRIDGES`` as ``"firmware-simavr": SimavrBridge``
(:func:`available` says why not, when the toolchain is missing).
"""

from __future__ import annotations

import contextlib
import os
import select
import tty

from firmware_sim_support import build, missing_toolchain

from pirate_bt.pipes import load_network
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.firmware_bridge import FirmwareBridge
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["SimavrBridge", "available"]


def available() -> str | None:
    """None when the firmware can run in simavr here, else the reason it cannot."""
    return missing_toolchain()


class SimavrBridge:
    """The firmware in simavr behind a pty (``BridgeUnderTest``).

    The MCU's clock runs only inside :meth:`read` and :meth:`advance`, paced to the
    wall clock there, and stands still in between (the harness's hold): bytes the
    test writes wait for the MCU as on a line, and a test that is slow to send its
    next frame on a loaded machine does not trip the firmware's 250 ms watchdog.
    """

    virtual_time = False
    line_limited = True

    def __init__(self, robot: RobotDescription) -> None:
        self.name = "firmware-simavr"
        self.robot = robot
        elf, harness = build()
        model = PipeRobotModel(robot, load_network("straight"))
        self._bridge = FirmwareBridge(elf, model, harness=harness, boot_ms=0)
        device = self._bridge.start()
        self._bridge.hold()
        self._fd = os.open(device, os.O_RDWR | os.O_NOCTTY)  # the DTR edge: a fresh boot
        tty.setraw(self._fd)
        self._bridge.wait_resets(1)
        self._silent_until: dict[int, float] = {}
        self._pending = bytearray()
        self._boot()

    def _boot(self) -> None:
        """Just after a reset, held: drop what the old boot sent, let the new one start.

        The firmware's start-up (stack painting, USART set-up) takes about 1.5 ms of
        MCU time: bytes arriving before its receiver is on are lost, as on a Mega.
        """
        self._drain(bytearray())
        self._pending = bytearray()
        self.advance(0.005)

    def _drain(self, out: bytearray) -> None:
        while True:
            ready, _, _ = select.select([self._fd], [], [], 0.0)
            if not ready:
                return
            out += os.read(self._fd, 65536)

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self._fd, view) :]

    def _run(self, seconds: float) -> None:
        """Let the MCU run ``seconds`` of its time, collecting what it sends."""
        deadline = self._bridge.mcu_time_s + seconds
        self._bridge.go()
        while self._bridge.mcu_time_s < deadline:
            for board, until in list(self._silent_until.items()):
                if self._bridge.mcu_time_s >= until:
                    del self._silent_until[board]
                    self._bridge.set_silent(board, False)
            ready, _, _ = select.select([self._fd], [], [], 0.002)
            if ready:
                self._pending += os.read(self._fd, 65536)
        self._bridge.hold()
        self._drain(self._pending)

    def read(self, timeout_s: float) -> bytes:
        self._run(timeout_s)
        out = bytes(self._pending)
        self._pending = bytearray()
        return out

    def advance(self, seconds: float) -> None:
        self._run(seconds)

    def reset(self) -> None:
        self._bridge.reset_mcu()
        self._boot()

    def disconnect_board(self, board: int, seconds: float) -> None:
        """A board stops answering its polls for ``seconds`` of MCU time."""
        self._bridge.set_silent(board, True)
        self._silent_until[board] = self._bridge.mcu_time_s + seconds
        self.advance(self.robot.bridge.state_period)

    def set_estop_input(self, pressed: bool) -> None:
        """The e-stop contact on the bridge's D22 opens (pressed) or closes."""
        self._bridge.set_estop_input(pressed)

    def close(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self._fd)
        self._bridge.close()
