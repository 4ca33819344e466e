"""The simulated bridge on the far end of a byte link: in memory, on a pty, or in a thread.

:class:`BridgeOnPort` moves bytes between a :class:`~pirate_bt.sim.bridge.SimBridge`
and one end of a byte link (anything with ``read_available()`` and ``write()``:
the in-memory pair and the pty end of :mod:`pirate_bt.link.testing`), so a host
talks to the reference bridge exactly as to a real one. It is stepped by a clock
listener (``clock.add_listener(port.step)``: deterministic on a
:class:`~pirate_bt.clock.SimClock`) or runs in its own thread
(:meth:`BridgeOnPort.start`, real time on a pty). ``silent`` makes the bridge
stop answering (a board that stops talking), for link-loss tests.

:func:`bridge_for` builds a bridge for a robot in a plain straight pipe, for tests
and benchmarks that need the protocol and not the pipe.
"""

from __future__ import annotations

import threading
from typing import Protocol

from pirate_bt.clock import Clock
from pirate_bt.pipes import network_from_data
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.bridge import SimBridge
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["BridgeOnPort", "bridge_for"]


class _Port(Protocol):
    def read_available(self) -> bytes: ...

    def write(self, data: bytes) -> None: ...


_STRAIGHT = {
    "schema_version": 1,
    "name": "bench",
    "diameter": "63 mm",
    "segments": [{"id": "run", "type": "straight", "length": "5 m"}],
}


def bridge_for(
    robot: RobotDescription, *, start_s: float = 0.0, record_applied: bool = True
) -> SimBridge:
    """A simulated bridge for ``robot`` in a 5 m straight, 63 mm pipe.

    Args:
        robot: The robot description (its layout is the bridge's).
        start_s: Clock time of the bridge's boot.
        record_applied: Keep every applied ordered request in ``bridge.applied``.

    Returns:
        The bridge, booted (latched, no session).
    """
    model = PipeRobotModel(robot, network_from_data(_STRAIGHT))
    model.time_s = start_s
    return SimBridge(model, start_s=start_s, record_applied=record_applied)


class BridgeOnPort:
    """Runs a :class:`SimBridge` behind one end of a byte link.

    Args:
        port: The bridge's end of the line.
        bridge: The simulated bridge.

    Attributes:
        silent: When true the bridge reads (and is fed) but its answers are lost.
    """

    def __init__(self, port: _Port, bridge: SimBridge) -> None:
        self.port = port
        self.bridge = bridge
        self.silent = False
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    def step(self, now_s: float) -> None:
        """Take the bytes that arrived, run the bridge up to ``now_s``, send its output."""
        with self._lock:
            self.bridge.receive(self.port.read_available())
            self.bridge.advance_to(now_s)
            out = self.bridge.read()
            if out and not self.silent:
                self.port.write(out)

    def start(self, clock: Clock, period_s: float = 0.0005) -> None:
        """Run :meth:`step` in a daemon thread every ``period_s`` of ``clock`` time."""

        def run() -> None:
            while not self._stop.is_set():
                self.step(clock.now())
                clock.sleep(period_s)

        self._stop.clear()
        self._thread = threading.Thread(target=run, name="sim-bridge-port", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the thread started by :meth:`start`."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None
