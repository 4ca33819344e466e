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
from typing import Protocol

from pirate_bt.clock import WallClock
from pirate_bt.errors import FrameError
from pirate_bt.link import FrameCodec, FrameDecoder, Message, State
from pirate_bt.link.messages import BridgeHeartbeat
from pirate_bt.link.testing import FdPort
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for


class BridgeUnderTest(Protocol):
    """A bridge seen through its bytes only.

    Attributes:
        name: For test ids.
        robot: The robot description the bridge was built for (its layout).
        virtual_time: :meth:`advance` moves a virtual clock (hours take seconds);
            false for a real-time bridge, where it sleeps.
    """

    name: str
    robot: RobotDescription
    virtual_time: bool

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

    def close(self) -> None:
        pass


class PtySimBridge:
    """The simulated bridge on the far end of a pty, in real time (as simavr will be)."""

    virtual_time = False

    def __init__(self, robot: RobotDescription) -> None:
        self.name = "sim-pty"
        self.robot = robot
        clock = WallClock()
        self._master, self._slave = os.openpty()
        self._host = os.open(os.ttyname(self._slave), os.O_RDWR | os.O_NOCTTY)
        import tty

        tty.setraw(self._host)
        self._port = BridgeOnPort(
            FdPort(self._master), bridge_for(robot, start_s=clock.now(), record_applied=False)
        )
        self._port.start(clock, period_s=0.0005)

    def write(self, data: bytes) -> None:
        os.write(self._host, data)

    def read(self, timeout_s: float) -> bytes:
        deadline = time.monotonic() + timeout_s
        out = bytearray()
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return bytes(out)
            ready, _, _ = select.select([self._host], [], [], left)
            if ready:
                out += os.read(self._host, 65536)

    def advance(self, seconds: float) -> None:
        time.sleep(seconds)

    def reset(self) -> None:
        with self._port._lock:  # the far end reboots between two of its steps
            self._port.bridge.reset()

    def close(self) -> None:
        self._port.stop()
        for fd in (self._host, self._slave, self._master):
            with contextlib.suppress(OSError):
                os.close(fd)


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

    def ask(self, msg: Message | bytes, timeout_s: float = 0.05) -> list[Message]:
        """Send a message (or raw bytes) and return the answers within ``timeout_s``."""
        if isinstance(msg, bytes):
            self.bridge.write(msg)
        else:
            self.send(msg)
        return self.collect(timeout_s)
