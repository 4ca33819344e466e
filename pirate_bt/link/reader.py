"""The link's reader thread (a mixin of :class:`~pirate_bt.link.session.Session`).

On a real port, or a network URL, a daemon thread runs the session's ``poll()`` every
millisecond, so that acks, retries and heartbeats go on whatever the program does
(docs/protocol.md, Timing). Its heartbeats stop at the time
:meth:`ReaderMixin.feed_watchdog_until` gives (:mod:`pirate_bt.link.deadman`: a drive
left turning by a program that stopped calling in). Split out of
:mod:`pirate_bt.link.session`.
"""

from __future__ import annotations

import math
import threading
from typing import TYPE_CHECKING

from pirate_bt.clock import Clock

__all__ = ["ReaderMixin"]


class ReaderMixin:
    """The reader thread of a session, and how long its heartbeats go on."""

    clock: Clock
    _lock: threading.RLock
    _reader: threading.Thread | None
    _reader_stop: threading.Event
    _reader_error: BaseException | None
    _feed_until_s: float

    if TYPE_CHECKING:  # the session's

        def poll(self) -> None: ...

    def _init_reader(self) -> None:
        self._reader = None
        self._reader_stop = threading.Event()
        self._reader_error = None
        self._feed_until_s = math.inf  # heartbeats go out until then (feed_watchdog_until)

    def start_reader(self, period_s: float = 0.001) -> None:
        """Run :meth:`poll` in a daemon thread every ``period_s`` (real ports).

        An error in the thread (link lost, port failed) stops it and is raised to the
        next caller of :meth:`wait` or :meth:`check_reader`.
        """
        if self._reader is not None:
            return
        self._reader_stop.clear()

        def run() -> None:
            while not self._reader_stop.is_set():
                try:
                    self.poll()
                except BaseException as exc:  # keep I/O errors apart from callers
                    self._reader_error = exc
                    return
                self.clock.sleep(period_s)

        self._reader = threading.Thread(target=run, name="pirate-link-reader", daemon=True)
        self._reader.start()

    def feed_watchdog_until(self, until_s: float) -> None:
        """Send heartbeats until clock time ``until_s`` only (``inf``: always); every other
        frame still feeds the bridge's watchdog. Set by :mod:`pirate_bt.link.deadman`."""
        with self._lock:
            self._feed_until_s = until_s

    @property
    def threaded(self) -> bool:
        """A reader thread drives :meth:`poll`."""
        return self._reader is not None

    def check_reader(self) -> None:
        """Raise the reader thread's error, if it stopped on one."""
        self._raise_reader_error()

    def stop_reader(self) -> None:
        """Stop the reader thread (if any) and wait for it."""
        if self._reader is not None:
            self._reader_stop.set()
            self._reader.join(timeout=1.0)  # it stops within one poll
            self._reader = None

    def _raise_reader_error(self) -> None:
        err = self._reader_error
        if err is not None:
            raise err
