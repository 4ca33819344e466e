"""Whether the ROS 2 node's Zenoh session reaches anyone, told to the run's log.

rmw_zenoh's nodes meet through a router. Ours connects to one as a peer (the
``--ros2`` endpoint) and, when none is there, goes on trying in the background, as
rmw_zenoh's own nodes do: a router started later finds the run. Until 2026-11-30
nothing said whether it had found one. A run whose router was not running, or whose
endpoint named a host that does not exist (``--ros2 tcp/robot-pc.lan:7447`` with a
typo), printed ``ROS 2 node /pirate/pirate_bt on Zenoh tcp/...`` as a run that was
seen, and went on seen by nobody, its ``/pirate/estop`` heard by nobody, without a
word. The node's process now looks (:class:`ReachWatch`, a thread of its own) and
tells the run's process ``(REACH, reached)`` when nobody was reached
:data:`GRACE_S` after the session opened, and whenever that changes afterwards (a
router that stops, or starts at last).
"""

from __future__ import annotations

import threading
from typing import Any

__all__ = ["EVERY_S", "GRACE_S", "REACH", "ReachWatch", "reached"]

REACH = 17
"""``(REACH, reached)``: publishing process -> run's process (see ``ros2_process``)."""

GRACE_S = 2.0
"""How long after the session opened nobody reached is said (a router on the same
machine or network is reached in milliseconds)."""

EVERY_S = 0.5
"""How often the session is looked at after that (each look costs under a microsecond)."""


def reached(session: Any) -> bool:
    """Whether a Zenoh session is connected to a router or a peer."""
    info = session.info
    return any(True for _ in info.routers_zid()) or any(True for _ in info.peers_zid())


class ReachWatch:
    """Tells ``out`` when ``session`` reaches nobody, and when that changes.

    Args:
        session: The node's Zenoh session.
        out: The pipe to the run's process (a ``PipeOutput``).
        grace_s: The first look, this long after :meth:`start`.
        every_s: The looks after it.
    """

    def __init__(
        self, session: Any, out: Any, grace_s: float = GRACE_S, every_s: float = EVERY_S
    ) -> None:
        self.session = session
        self.out = out
        self.grace_s = grace_s
        self.every_s = every_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="pirate-ros2-reach", daemon=True)

    def start(self) -> None:
        """Start looking."""
        self._thread.start()

    def stop(self) -> None:
        """Stop looking (before the session closes)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)

    def _watch(self) -> None:
        told = True  # the run's process takes the node as seen until told otherwise
        wait = self.grace_s
        while not self._stop.wait(wait):
            wait = self.every_s
            try:
                now = reached(self.session)
            except Exception:  # the session is closing: the process is ending
                return
            if now != told:
                self.out.send((REACH, now))
                told = now
