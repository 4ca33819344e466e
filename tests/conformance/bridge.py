"""The bridge under test: one small interface, and the implementations plugged into it.

A conformance test sees a bridge only as a :class:`BridgeUnderTest`: bytes in,
bytes out, time that passes, and a DTR reset. It never touches the bridge's
objects, so any implementation that can move bytes (the simulated bridge in
process, the same on a pty in real time, the C firmware in simavr on a pty) runs
the same tests. To plug in another one, write a class with these members and add
it to the ``bridge`` fixture in ``tests/conformance/conftest.py``.

:class:`Wire` is the tests' side: it encodes messages with the host's codec,
reads what comes back, and keeps the newest ``STATE`` apart from the answers.
"""

from __future__ import annotations

import contextlib
import os
import select
import time
from collections.abc import Callable
from typing import Protocol

from pirate_bt.clock import WallClock
from pirate_bt.errors import FrameError
from pirate_bt.link import FrameCodec, FrameDecoder, Message, State
from pirate_bt.link.messages import BridgeHeartbeat
from pirate_bt.link.testing import FdPort
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for

REAL_TIME_PATIENCE_S = 1.0
"""Longest wait for answers that are due from a real-time bridge."""


class BridgeUnderTest(Protocol):
    """A bridge seen through its bytes only.

    Attributes:
        name: For test ids.
        robot: The robot description the bridge was built for (its layout).
        virtual_time: :meth:`advance` moves a virtual clock (hours take seconds);
            false for a real-time bridge, where it sleeps.
        line_limited: Its serial line runs at the robot's baud rate both ways and
            at most a few answers wait (a real bridge); a test must then not ask
            for more answers per state period than the line carries. The
            reference bridge has no line model (false), so the long tests run
            faster against it.
    """

    name: str
    robot: RobotDescription
    virtual_time: bool
    line_limited: bool

    def write(self, data: bytes) -> None:
        """Bytes to the bridge."""

    def read(self, timeout_s: float) -> bytes:
        """The bytes the bridge sent within ``timeout_s`` (virtual seconds when virtual)."""

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` pass (virtual, or a sleep in real time)."""

    def reset(self) -> None:
        """A DTR reset: the bridge reboots, as when a host opens its port."""

    def close(self) -> None:
        """Release it."""


class InProcessSimBridge:
    """The simulated bridge in process, bytes in and out, on a virtual clock."""

    virtual_time = True
    line_limited = False

    def __init__(self, robot: RobotDescription) -> None:
        self.name = "sim"
        self.robot = robot
        self.now_s = 0.0
        self._bridge = bridge_for(robot, record_applied=False)

    def write(self, data: bytes) -> None:
        self._bridge.receive(data)

    def read(self, timeout_s: float) -> bytes:
        self.advance(timeout_s)
        return self._bridge.read()

    def advance(self, seconds: float) -> None:
        self.now_s += seconds
        self._bridge.advance_to(self.now_s)

    def reset(self) -> None:
        self._bridge.reset()

    def disconnect_board(self, board: int, seconds: float) -> None:
        """Optional capability: a board stops answering its polls for ``seconds``."""
        from pirate_bt.pipes import FaultSpec

        fault = FaultSpec(kind="board_reset", target=str(board), at=self.now_s, duration=seconds)
        self._bridge.schedule([fault])
        self.advance(self._bridge.period_s)

    def set_estop_input(self, pressed: bool) -> None:
        """Optional capability: press or release the hardware e-stop input (protocol 1.2)."""
        self._bridge.set_estop_input(pressed)

    def close(self) -> None:
        pass


class PtyBridge:
    """Any bridge behind a pseudo-terminal (or serial device), in real time.

    The firmware in simavr plugs in through this: its harness exposes a pty, and a
    ``reset`` callable reboots the simulated AVR (the DTR reset).

    Args:
        name: For test ids.
        robot: The robot description the bridge was built for.
        device: The device path the host side opens (``/dev/pts/N``).
        reset: Reboots the bridge.
        close: Releases whatever runs the bridge (called after the device is closed).
    """

    virtual_time = False
    line_limited = True

    def __init__(
        self,
        name: str,
        robot: RobotDescription,
        device: str,
        reset: Callable[[], None],
        close: Callable[[], None] = lambda: None,
    ) -> None:
        import tty

        self.name = name
        self.robot = robot
        self._reset = reset
        self._close = close
        self._fd = os.open(device, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self._fd)

    def write(self, data: bytes) -> None:
        os.write(self._fd, data)

    def read(self, timeout_s: float) -> bytes:
        deadline = time.monotonic() + timeout_s
        out = bytearray()
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return bytes(out)
            ready, _, _ = select.select([self._fd], [], [], left)
            if ready:
                out += os.read(self._fd, 65536)

    def advance(self, seconds: float) -> None:
        time.sleep(seconds)

    def reset(self) -> None:
        self._reset()

    def close(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self._fd)
        self._close()


def pty_sim_bridge(robot: RobotDescription) -> PtyBridge:
    """The simulated bridge on the far end of a pty, in real time (as simavr will be)."""
    import tty

    clock = WallClock()
    master, slave = os.openpty()
    tty.setraw(slave)  # before the bridge writes: a cooked pty would echo its frames back
    port = BridgeOnPort(
        FdPort(master), bridge_for(robot, start_s=clock.now(), record_applied=False)
    )
    port.start(clock, period_s=0.0005)

    def reset() -> None:
        with port._lock:  # the far end reboots between two of its steps
            port.bridge.reset()

    def close() -> None:
        port.stop()
        for fd in (slave, master):
            with contextlib.suppress(OSError):
                os.close(fd)

    return PtyBridge("sim-pty", robot, os.ttyname(slave), reset, close)


class Wire:
    """The test's end: send messages or raw bytes, collect answers and the newest STATE.

    Args:
        bridge: The bridge under test.
    """

    def __init__(self, bridge: BridgeUnderTest) -> None:
        self.bridge = bridge
        self.codec = FrameCodec.for_robot(bridge.robot)
        self.decoder = FrameDecoder(self.codec)
        self.state: State | None = None
        self.states = 0
        self.errors: list[FrameError] = []

    def send(self, msg: Message) -> None:
        """Write one message."""
        self.bridge.write(self.codec.encode(msg))

    def collect(self, timeout_s: float) -> list[Message]:
        """Everything but STATE and BRIDGE_HEARTBEAT frames received within ``timeout_s``."""
        answers: list[Message] = []
        for item in self.decoder.feed(self.bridge.read(timeout_s)):
            if isinstance(item, FrameError):
                self.errors.append(item)
            elif isinstance(item, State):
                self.state = item
                self.states += 1
            elif not isinstance(item, BridgeHeartbeat):
                answers.append(item)
        return answers

    def ask(
        self, msg: Message | bytes, timeout_s: float = 0.05, expect: int | None = None
    ) -> list[Message]:
        """Send a message (or raw bytes) and return the answers within ``timeout_s``.

        On a real-time bridge, when ``expect`` answers are known to be due, it waits
        for them up to a second (a loaded machine delays them), then ``timeout_s``
        more for any extra answer.
        """
        if isinstance(msg, bytes):
            self.bridge.write(msg)
        else:
            self.send(msg)
        answers = self.collect(timeout_s)
        if expect is not None and not self.bridge.virtual_time:
            deadline = time.monotonic() + REAL_TIME_PATIENCE_S
            while len(answers) < expect and time.monotonic() < deadline:
                answers += self.collect(0.01)
        return answers
