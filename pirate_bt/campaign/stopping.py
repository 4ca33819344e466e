"""A campaign stopping after Ctrl-C or ``SIGTERM``: a second one stops it now.

After the first interrupt the local pool is shut down, which waits for the cases
in flight (at once when the Ctrl-C reached the workers too, at most their
``case_timeout`` when only the campaign's process got it). A second Ctrl-C in
that wait raised out of the shutdown with the workers still running: the command
then sat in ``multiprocessing``'s exit, joining them, and a third printed a
traceback from there. Now a Ctrl-C or ``SIGTERM`` during that shutdown kills the
pool's workers (their case servers and cases end with them, ``PR_SET_PDEATHSIG``)
and the shutdown ends: the first interrupt is the one that propagates.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["pool_killed_on_signal"]


@contextlib.contextmanager
def pool_killed_on_signal(pool: Any) -> Iterator[None]:
    """While inside, ``SIGINT`` and ``SIGTERM`` kill the worker processes of ``pool``.

    Args:
        pool: A :class:`~pirate_bt.campaign.engine.LocalPool` being shut down.

    Signal handlers belong to the main thread: elsewhere this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def kill(_signum: int, _frame: object) -> None:
        inner = getattr(pool, "_pool", None)
        for process in list((getattr(inner, "_processes", None) or {}).values()):
            with contextlib.suppress(OSError, ValueError, AttributeError):
                process.kill()

    old: dict[signal.Signals, Any] = {}
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, kill)
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
