"""What the bridge sent since its last good frame that made no good frame.

A session declares the link lost when no valid frame came for its link timeout. The
line may have been silent, or full of bytes that made no good frame (a bridge at
another baud rate, a line flooded with noise, an echo of the host's own frames): the
user is told which (:meth:`LineNoise.text`), not *nothing heard* for both.

Every count is kept since the last good frame only: a good frame starts them again.
The counts are keyed by the clock time of that frame (the session's last-heard time),
so the receive path does nothing on a good frame: a count noted under an older key
is void.
"""

from __future__ import annotations

import collections
import math

__all__ = ["LineNoise"]


class LineNoise:
    """Bytes, unreadable frames (by reason) and echoed host frames since the last good
    frame heard at ``heard_s``."""

    __slots__ = ("_heard_s", "bytes", "echoes", "frames")

    def __init__(self) -> None:
        self._heard_s = -math.inf  # before any good frame: no clock gives it
        self.bytes = 0
        self.echoes = 0
        self.frames: collections.Counter[str] = collections.Counter()

    def _since(self, heard_s: float) -> None:
        if heard_s != self._heard_s:  # a good frame came since: start again
            self._heard_s = heard_s
            self.bytes = 0
            self.echoes = 0
            self.frames.clear()

    def note_bytes(self, heard_s: float, n: int) -> None:
        """``n`` bytes read in which no good frame was, the last one heard at ``heard_s``."""
        self._since(heard_s)
        self.bytes += n

    def note_frame(self, heard_s: float, reason: str) -> None:
        """A frame dropped for ``reason`` (a ``FrameError``'s), the last good one heard
        at ``heard_s``."""
        self._since(heard_s)
        self.frames[reason] += 1

    def note_echo(self, heard_s: float) -> None:
        """A well-formed frame of a host → bridge type (the host's own, echoed)."""
        self._since(heard_s)
        self.echoes += 1

    def text(self, heard_s: float) -> str:
        """What came since the good frame heard at ``heard_s`` (``""``: nothing at all),
        e.g. ``"561 unreadable frames (cobs 500, crc 61) in 2400 bytes"``."""
        if heard_s != self._heard_s or not (self.bytes or self.frames or self.echoes):
            return ""
        parts = []
        total = sum(self.frames.values())
        if total:
            why = ", ".join(f"{reason} {n}" for reason, n in sorted(self.frames.items()))
            parts.append(f"{total} unreadable frame{'s' * (total != 1)} ({why})")
        if self.echoes:
            parts.append(f"{self.echoes} of the host's own frames (an echo: a loopback?)")
        if not parts:  # bytes that made no frame: delimiters only, or no delimiter yet
            return f"{self.bytes} bytes that made no frame"
        return " and ".join(parts) + (f" in {self.bytes} bytes" if self.bytes else "")
