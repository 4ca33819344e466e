"""The output pipe of a live view's process back to the run's process.

The Foxglove server process (:mod:`pirate_bt.interop.foxglove_process`) and the ROS 2
publishing process (:mod:`pirate_bt.interop.ros2_process`) each tell the run's process
what happens (ready, failed, a client subscribed, an e-stop) on their standard output,
in the trace's framing (:func:`pirate_bt.trace.sink.frame`: length, then ``marshal``).
They send from their main thread and from their library's threads, so the writes are
serialised; once the run's process has gone, there is nobody to tell and sends are
dropped. Standard library only, as those processes are.
"""

from __future__ import annotations

import os
import threading
from typing import Any

from pirate_bt.trace.sink import frame

__all__ = ["PipeOutput"]


class PipeOutput:
    """Whole messages to a pipe, from any thread; quiet once the reader has gone.

    Args:
        fd: The pipe's file descriptor (the process's standard output).
    """

    def __init__(self, fd: int) -> None:
        self._fd = fd
        self._lock = threading.Lock()
        self.gone = False
        """Set once a write failed: the run's process has gone."""

    def send(self, message: tuple[Any, ...]) -> None:
        """Write ``message`` whole (``ValueError`` if ``marshal`` cannot carry it)."""
        data = frame(message)
        with self._lock:
            if self.gone:
                return
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(self._fd, view) :]
            except OSError:  # the run's process has gone: nobody to tell
                self.gone = True
