"""Time, injected.

Every timeout, rate and timestamp in the library reads a :class:`Clock` handed to
it, never ``time`` directly. On hardware that is a :class:`WallClock`. In tests
and in the in-process simulator it is a :class:`SimClock`, which only moves when
someone advances it: a ten-minute mission then runs in seconds, and a timing
test gives the same answer on a loaded CI machine as on a fast laptop.

Sleeping on a :class:`SimClock` advances it, and listeners registered with
:meth:`SimClock.add_listener` (the simulator is one) are called with the new time,
so "wait 10 ms" in host code steps the simulated world by 10 ms.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Protocol, runtime_checkable

__all__ = ["Clock", "SimClock", "WallClock"]

_INF = float("inf")


@runtime_checkable
class Clock(Protocol):
    """What the library needs of time: a monotonic reading in seconds, and a way to wait."""

    def now(self) -> float:
        """Return monotonic time in seconds (arbitrary origin)."""
        ...

    def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of this clock's time (a no-op for non-positive values)."""
        ...

    @property
    def is_simulated(self) -> bool:
        """True when time only moves when the program moves it."""
        ...


class WallClock:
    """The real monotonic clock (``time.monotonic``)."""

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)

    @property
    def is_simulated(self) -> bool:
        return False

    def __repr__(self) -> str:
        return "WallClock()"


class SimClock:
    """A clock that moves only when advanced; thread-safe.

    Args:
        start_s: The reading before the first advance.
    """

    def __init__(self, start_s: float = 0.0) -> None:
        self._now = float(start_s)
        self._lock = threading.RLock()
        self._listeners: list[Callable[[float], None]] = []

    def now(self) -> float:
        return self._now

    @property
    def is_simulated(self) -> bool:
        return True

    def add_listener(self, listener: Callable[[float], None]) -> None:
        """Call ``listener(now)`` after every advance (the simulator steps itself here)."""
        with self._lock:
            self._listeners.append(listener)

    def remove_listener(self, listener: Callable[[float], None]) -> None:
        """Stop calling ``listener``; unknown listeners are ignored."""
        with self._lock:
            if listener in self._listeners:
                self._listeners.remove(listener)

    def advance(self, seconds: float) -> float:
        """Move time forward by ``seconds`` and notify listeners.

        Raises:
            ValueError: if ``seconds`` is negative (monotonic time never goes back), or
                not finite (the clock would read ``nan`` or ``inf`` from then on).
        """
        if not 0 <= seconds < _INF:  # also nan, for which every comparison is false
            if seconds < 0:
                raise ValueError(f"a clock cannot go back ({seconds} s)")
            raise ValueError(f"a clock moves by a finite time, not {seconds} s")
        with self._lock:
            self._now += seconds
            now = self._now
            listeners = tuple(self._listeners)
        for listener in listeners:
            listener(now)
        return now

    def advance_to(self, when_s: float) -> float:
        """Advance to ``when_s`` if it lies in the future; return the reading."""
        delta = when_s - self._now
        if delta > 0:
            self.advance(delta)
        return self._now

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self.advance(seconds)

    def __repr__(self) -> str:
        return f"SimClock(now={self._now:.6f})"
