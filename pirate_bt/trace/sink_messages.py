"""The trace writer's messages: their kinds, their framing, and the writer process's loop.

Split out of :mod:`pirate_bt.trace.sink`, which re-exports every public name here
and whose docstring describes each message. The recorder's end
(:class:`~pirate_bt.trace.sink.SinkProcess`) frames messages with :func:`frame`;
the writer process reads them off its pipe (:func:`read_messages`), takes the ticks
out of the ring when a bell says how far it is written, and writes their records
in order (:func:`serve`). Like the rest of the writer process, this module needs
only the standard library and imports nothing from ``pirate_bt`` outside its
siblings.
"""

from __future__ import annotations

import marshal
import os
import struct
import time
from collections.abc import Callable, Iterable, Iterator
from typing import Any

from pirate_bt.trace.sink_encode import TickEncoder
from pirate_bt.trace.sink_formats import TraceFormatWriter
from pirate_bt.trace.sink_ring import Ring, RingReader

__all__ = ["BELL", "END", "LINE", "SETUP", "TICK", "frame", "read_messages", "serve", "unframe"]

SETUP, LINE, TICK, END, BELL = 0, 1, 2, 3, 4

_LENGTH = struct.Struct("<I")
_MARSHAL_VERSION = 2
"""The ``marshal`` version of :func:`frame`: version 2 has no references between objects
(3 and 4 do), which a tick's small message does not need; it encodes a tick in 60 % of
the default version's time and loads the same values."""
_POLL_S = 0.002
"""How long the writer process sleeps after draining the pipe: it is not woken by every
tick's write, and it notices the end of a run within this time."""
_PIPE_BYTES = 1 << 20


def frame(message: tuple[Any, ...]) -> bytes:
    """One message as it goes on a pipe: its length (4 bytes, little-endian), its ``marshal``.

    Raises:
        ValueError: the message holds a value ``marshal`` cannot carry.
    """
    payload = marshal.dumps(message, _MARSHAL_VERSION)
    return _LENGTH.pack(len(payload)) + payload


def unframe(buffer: bytearray) -> list[Any]:
    """The whole messages at the start of ``buffer``, taken out of it."""
    out: list[Any] = []
    start, size = 0, len(buffer)
    while size - start >= 4:
        (length,) = _LENGTH.unpack_from(buffer, start)
        end = start + 4 + length
        if end > size:
            break
        out.append(marshal.loads(memoryview(buffer)[start + 4 : end]))
        start = end
    del buffer[:start]
    return out


def read_messages(
    fd: int, poll_s: float = _POLL_S, rested: Callable[[], None] | None = None
) -> Iterator[Any]:
    """Messages read off ``fd`` until it closes; a cut-off last message is dropped.

    After each read it sleeps ``poll_s``, so that messages gather and the reader is
    not woken once per message (on a busy machine such a wake-up may run before the
    writer's ``os.write`` returns, and the tick would pay for it); then it calls
    ``rested`` (the ring's reader gives space back then, see :mod:`.sink_ring`).
    """
    buffer = b""
    while True:
        chunk = os.read(fd, _PIPE_BYTES)
        if not chunk:
            return
        buffer += chunk
        view = memoryview(buffer)
        start = 0
        while len(buffer) - start >= 4:
            (size,) = _LENGTH.unpack_from(view, start)
            end = start + 4 + size
            if end > len(buffer):
                break
            yield marshal.loads(view[start + 4 : end])
            start = end
        view.release()
        buffer = buffer[start:]
        time.sleep(poll_s)  # let messages gather: no wake-up of this process per tick
        if rested is not None:
            rested()


_messages = read_messages


def serve(fd_in: int, out: TraceFormatWriter, ring: Ring | None = None) -> bool:
    """Write the records of the messages read off ``fd_in`` to ``out``, until it closes.

    Args:
        fd_in: The pipe from the recorder.
        out: The format writer.
        ring: The ring the recorder puts ticks in; its bells come through ``fd_in``.

    Returns:
        Whether the end record came (``False``: the input closed without it, the run
        was cut off).
    """
    records = _Records(out)
    reader = RingReader(ring) if ring is not None else None
    for message in _messages(fd_in, rested=reader.rested if reader is not None else None):
        if message[0] == BELL:
            if reader is None:
                raise ValueError("a bell, but no ring")
            if records.write(reader.messages(message[1])):
                return True
        elif records.write((message,)):
            return True
    # The input closed without an end record: the run was killed, or its recorder
    # failed. What it put in the ring after its last bell is written too.
    return reader is not None and records.write(reader.messages(reader.ring.head()))


class _Records:
    """Writes the records of messages, in order (:func:`serve`'s body)."""

    def __init__(self, out: TraceFormatWriter) -> None:
        self.out = out
        self.encoder: TickEncoder | None = None

    def write(self, messages: Iterable[Any]) -> bool:
        """Write the records of ``messages``; whether the end record was among them.

        The lines go out together, after the last message (one ``os.write`` for
        ``.jsonl``): the recorder has handed them over already, and this process
        writes them all before it reads on, or exits.
        """
        lines: list[str] = []
        try:
            for message in messages:
                kind = message[0]
                if kind == TICK:
                    assert self.encoder is not None, "a tick before the setup message"
                    line = self.encoder.encode(message)
                    if line is not None:
                        lines.append(line)
                elif kind == LINE:
                    lines.append(message[1])
                elif kind == END:
                    lines.append(message[1])
                    return True
                else:
                    self._setup(message)
            return False
        finally:
            if lines:
                self.out.write_lines(lines)

    def _setup(self, message: Any) -> None:
        if message[0] != SETUP:
            raise ValueError(f"unknown message kind {message[0]!r}")
        _, ids, every_tick, full_state, readings, link_fields = message
        self.encoder = TickEncoder(
            ids,
            every_tick=every_tick,
            full_state=full_state,
            readings=readings,
            link_fields=link_fields,
        )
