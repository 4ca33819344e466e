"""What the run's process holds back when the Foxglove server's process lags.

The run hands each tick to the server's process through a pipe of 1 MiB and
never waits for room in it (:class:`pirate_bt.interop.foxglove_live.FoxgloveServer`).
When the pipe is full, the tick is not written: it is *merged* into the one
tick message held back for its recorder (:func:`merge_ticks`), and each later
tick is merged into that, until the pipe takes it. A tick message holds what
moved since the one before, so the merged message holds what moved since the
last one written: when it goes out, the server's process and every client are
up to date again. What is lost are the ticks in between as ticks (their
number, time and the order of their changes), counted as *dropped*; the
commands and events of those ticks are kept, the newest
:data:`KEEP_COMMANDS` and :data:`KEEP_EVENTS` of them. So the memory held back
is one message per recorder, whatever the lag.

:class:`Feed` is the run's end of that pipe. This module needs only the standard
library and :mod:`pirate_bt.trace.sink`.
"""

from __future__ import annotations

import json
import os
import select
import threading
import time
from collections.abc import Callable
from typing import Any

from pirate_bt.trace.sink import TICK, encode_json, frame

__all__ = ["KEEP_COMMANDS", "KEEP_EVENTS", "KEEP_WAIT_S", "Feed", "merge_ticks"]

# The message kinds of pirate_bt.interop.foxglove_process this module needs.
_STREAM, _DROPPED = 20, 21

KEEP_COMMANDS = 64
"""Commands (verdicts) of merged ticks kept, the newest."""
KEEP_EVENTS = 64
"""Events of merged ticks kept, the newest."""
KEEP_WAIT_S = 5.0
"""How long a message that must not be dropped (a run's header or end) waits for room."""


def _members(text: str | None) -> dict[str, Any]:
    """``',"bb":{...},"bb_unset":[...]'`` → ``{"bb": {...}, "bb_unset": [...]}``."""
    if not text:
        return {}
    members: dict[str, Any] = json.loads("{" + text[1:] + "}")
    return members


def _pairs(older: list[Any] | None, newer: list[Any] | None) -> list[Any] | None:
    """Two lists of ``(index, value)`` as one, the newer value winning."""
    if not older:
        return newer
    if not newer:
        return older
    merged = dict(older)
    merged.update(newer)
    return list(merged.items())


def _blackboard(older: str | None, newer: str | None) -> str | None:
    if not older:
        return newer
    if not newer:
        return older
    old, new = _members(older), _members(newer)
    values: dict[str, Any] = dict(old.get("bb") or {})
    unset = [k for k in old.get("bb_unset") or () if k not in (new.get("bb") or {})]
    for key in new.get("bb_unset") or ():
        values.pop(key, None)
        if key not in unset:
            unset.append(key)
    values.update(new.get("bb") or {})
    text = ""
    if values:
        text += ',"bb":' + encode_json(values)
    if unset:
        text += ',"bb_unset":' + encode_json(unset)
    return text or None


def _events(older: str | None, newer: str | None) -> str | None:
    if not older:
        return newer
    if not newer:
        return older
    events = (_members(older).get("events") or []) + (_members(newer).get("events") or [])
    return ',"events":' + encode_json(events[-KEEP_EVENTS:])


def merge_ticks(older: tuple[Any, ...], newer: tuple[Any, ...]) -> tuple[Any, ...]:
    """One ``TICK`` message (:mod:`pirate_bt.trace.sink`) holding what both hold.

    The newer tick's number and time; statuses, feedback and the blackboard as
    they stand after both; the newest state, link health and counters given (whole
    values); the commands and events of both, the newest kept.
    """
    (_, _, _, status, feedback, bb, keys, raw, commands, link, sim, events) = older
    commands_new = newer[8]
    if commands and commands_new:
        commands = (commands + commands_new)[-KEEP_COMMANDS:]
    else:
        commands = commands or commands_new
    return (
        TICK,
        newer[1],
        newer[2],
        _pairs(status, newer[3]),
        _pairs(feedback, newer[4]),
        _blackboard(bb, newer[5]),
        newer[6] if newer[6] is not None else keys,
        newer[7] if newer[7] is not None else raw,
        commands,
        newer[9] if newer[9] is not None else link,
        newer[10] if newer[10] is not None else sim,
        _events(events, newer[11]),
    )


class Feed:
    """The run's end of the pipe to the server's process (non-blocking ``fd``).

    A recorder's ticks never wait (see the module docstring); everything else (set-up,
    header, end record, records as data) waits for room, at most :data:`KEEP_WAIT_S`.
    ``gone(why)`` is called once when the pipe breaks or stops taking anything
    (``why`` may hold ``{exit}``); nothing is written after that.

    Args:
        fd: The pipe's writing end, non-blocking.
        gone: Told why the feed stopped.
    """

    def __init__(self, fd: int, gone: Callable[[str], None]) -> None:
        self._fd = fd
        self._gone = gone
        self._lock = threading.Lock()
        self._tail = b""
        self._pending: dict[int, tuple[Any, ...]] = {}
        self._merged: dict[int, int] = {}
        self.enabled = True
        self.dropped = 0
        """Ticks merged into later ones, and messages left out, so far."""

    def hand_over(self, stream: int | None, message: tuple[Any, ...]) -> None:
        """Hand a recorder's message over (``stream``), or one of its own (``None``).

        Raises:
            ValueError: the message holds a value ``marshal`` cannot carry.
        """
        data = frame(message if stream is None else (_STREAM, stream, message))
        with self._lock:
            if stream is None or message[0] != TICK:
                if self._put_all(wait=True):
                    self._put(data, wait=True)
                return
            flushed = self._put_all(wait=False)
            held = self._pending.get(stream)
            if held is not None:
                self._pending[stream] = merge_ticks(held, message)
                self._merged[stream] = self._merged.get(stream, 0) + 1
                self.dropped += 1
            elif not flushed or not self._put(data):
                self._pending[stream] = message

    def finish(self, stream: int, end: tuple[Any, ...]) -> int:
        """A recorder's end: what it has held back, how many ticks it lost, its end
        message. Returns that number of ticks."""
        merged = self._merged.pop(stream, 0)
        if merged:
            self.hand_over(None, (_DROPPED, stream, merged))
        self.hand_over(stream, end)
        return merged

    def offer(self, message: tuple[Any, ...]) -> None:
        """Hand over a message that may be left out (counted) when the pipe is full."""
        data = frame(message)
        with self._lock:
            if not self._put_all(wait=False) or not self._put(data):
                self.dropped += 1

    def flush(self) -> None:
        """Write everything held back, waiting for room (at most :data:`KEEP_WAIT_S`)."""
        with self._lock:
            self._put_all(wait=True)

    def _put_all(self, wait: bool) -> bool:
        """Write the tail of the last message, then the held ticks; True when all are out."""
        if self._tail and not self._put(b"", wait):
            return False
        for stream in list(self._pending):
            if not self._put(frame((_STREAM, stream, self._pending[stream])), wait):
                return False
            self._pending.pop(stream, None)  # (gone already if the feed stopped)
        return True

    def _put(self, data: bytes, wait: bool = False) -> bool:
        """Write ``data`` after the tail of the last message. Without ``wait``: False if
        the pipe took nothing of ``data`` (nothing of it is kept), True once it is written
        or under way (its rest is the new tail); with ``b""``, True once the tail is out."""
        if not self.enabled:
            return True  # nothing more will be written: nothing to hold back
        try:
            if self._tail:
                self._tail = self._tail[self._write(self._tail) :]
                if wait:
                    self._wait_tail()
                elif self._tail:
                    return False
            if not data:
                return True
            written = self._write(data)
            if written == 0 and not wait:
                return False
            self._tail = data[written:]
            if wait:
                self._wait_tail()
            return True
        except BrokenPipeError:
            self._stop("its process has gone (exit {exit})")
        except TimeoutError:
            self._stop(f"its process stopped reading for {KEEP_WAIT_S:g} s")
        return True

    def _stop(self, why: str) -> None:
        self.enabled = False
        self._tail = b""
        self._pending.clear()
        self._gone(why)

    def _write(self, data: bytes) -> int:
        try:
            return os.write(self._fd, data)
        except BlockingIOError:
            return 0

    def _wait_tail(self) -> None:
        deadline = time.monotonic() + KEEP_WAIT_S
        while self._tail:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError
            select.select([], [self._fd], [], left)
            self._tail = self._tail[self._write(self._tail) :]
