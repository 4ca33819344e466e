"""The ring of shared memory that carries tick messages to the trace's writer process.

Handing each tick to the writer process through its pipe costs a system call in
the tick (about half a microsecond, more while the writer reads on the other
core), and a pipe holds 1 MiB at most, so a writer that falls behind on a busy
machine soon makes the ticks wait for it. So the recorder copies each tick's
message (framed as on the pipe: a 4-byte length, then ``marshal``) into a ring
of shared memory that both processes map (a ``memfd``, 4 MiB), and notes in the
ring how far it has written. The pipe carries only *bells*: a small message
``(BELL, position)`` saying "the ring holds messages up to here", when the last
bell is more than :data:`BELL_S` old, and before any other message on the pipe
(the header, the end record), so order is kept. Only ticks that come less than
:data:`PAUSE_S` after the one before (a run going as fast as it can) go into the
ring: a tick after a pause (every tick of a run paced to a clock) goes through
the pipe, one write as before, since a bell would cost as much.

Crash safety is what it was with the pipe: a tick is in memory the kernel keeps
for the writer process as soon as :meth:`Ring.put` returns, so a SIGKILL of the
run (or of its process group) loses none. When its pipe closes, the writer
process reads the ring up to the position the recorder last noted, and writes
those ticks too.

Memory order, on any CPU: the writer reads ring bytes only up to a position it
learnt from the pipe (a bell), or after the pipe has closed; the pipe's lock
orders the recorder's earlier copies into the ring before that. It gives space
back (its read position, noted in the ring) only after it has slept, a context
switch after its last read of those bytes. A bell is also what tells the
recorder that the writer process has died (its write fails), so a failure shows
at the next tick, or within :data:`BELL_S` while ticks come less than
:data:`PAUSE_S` apart (the ring's ticks).

Layout: a 64-byte header holding the bytes ever written (``head``, at 0) and ever
read (``tail``, at 8), little-endian 64-bit; then :data:`CAPACITY` bytes of data,
a power of two, position ``p`` at offset ``64 + p % CAPACITY``. A frame may wrap
around the end. Like the rest of the writer process, this module needs only the
standard library.
"""

from __future__ import annotations

import contextlib
import marshal
import mmap
import os
import struct
from typing import Any

__all__ = ["BELL_S", "CAPACITY", "HEADER", "PAUSE_S", "Ring", "RingReader"]

HEADER = 64
"""Bytes before the data: ``head`` and ``tail``, with room to spare."""
CAPACITY = 1 << 22
"""Data bytes of a ring (4 MiB, about 13 000 ticks of a 50-node tree with a robot state)."""
BELL_S = 1e-3
"""Longest time between bells while ticks come fast (the writer process reads what was
rung every 2 ms)."""
PAUSE_S = 100e-6
"""A tick that comes this long after the one before goes through the pipe, not the
ring: a system call per tick is then at most 1 % of the tick."""

_POSITION = struct.Struct("<Q")
_LENGTH = struct.Struct("<I")
_HEAD, _TAIL = 0, 8
_pack_length_into = _LENGTH.pack_into
_pack_position_into = _POSITION.pack_into
_MADV_POPULATE_WRITE = getattr(mmap, "MADV_POPULATE_WRITE", 23)
"""Linux's ``madvise`` advice that faults pages in, writable (Python 3.11 has no name
for it)."""


class Ring:
    """One process's view of a ring (see the module docstring).

    Args:
        fd: The shared memory's file descriptor (it may be closed once this is made).
        capacity: Its data bytes, a power of two.
    """

    def __init__(self, fd: int, capacity: int = CAPACITY) -> None:
        if capacity <= 0 or capacity & (capacity - 1):
            raise ValueError(f"a ring's capacity is a power of two, not {capacity}")
        self.capacity = capacity
        self._mask = capacity - 1
        self._limit = HEADER + capacity
        self.map = mmap.mmap(fd, HEADER + capacity)
        """The mapping: the header, then the data (shared with the other process)."""
        self._prefaulting: Any = None

    @classmethod
    def create(cls, capacity: int | None = None) -> tuple[Ring, int] | None:
        """A new ring and its file descriptor (to pass on), or ``None`` where there is none.

        Linux only (``os.memfd_create``); elsewhere, or if the kernel refuses, the
        recorder writes every message into the pipe instead. A thread of this process
        maps its memory meanwhile (:meth:`prefault`).

        Args:
            capacity: Data bytes, a power of two (default :data:`CAPACITY`).
        """
        memfd_create = getattr(os, "memfd_create", None)
        if memfd_create is None:
            return None
        capacity = CAPACITY if capacity is None else capacity
        fd = -1
        try:
            fd = memfd_create("pirate-bt-trace", getattr(os, "MFD_CLOEXEC", 1))
            os.ftruncate(fd, HEADER + capacity)
            ring = cls(fd, capacity)
        except (OSError, ValueError):
            if fd >= 0:
                os.close(fd)
            return None
        ring.prefault(fd)
        return ring, fd

    def head(self) -> int:
        """Bytes the recorder has written, ever."""
        value: int = _POSITION.unpack_from(self.map, _HEAD)[0]
        return value

    def tail(self) -> int:
        """Bytes the writer process has read and given back, ever."""
        value: int = _POSITION.unpack_from(self.map, _TAIL)[0]
        return value

    def set_tail(self, position: int) -> None:
        _POSITION.pack_into(self.map, _TAIL, position)

    def put(self, head: int, frame: bytes) -> int:
        """Copy ``frame`` in at ``head`` (room checked by the caller); the new head, noted."""
        start = head & (self.capacity - 1)
        end = start + len(frame)
        if end <= self.capacity:
            self.map[HEADER + start : HEADER + end] = frame
        else:  # wraps around the end
            first = self.capacity - start
            self.map[HEADER + start : HEADER + self.capacity] = frame[:first]
            self.map[HEADER : HEADER + len(frame) - first] = frame[first:]
        head += len(frame)
        _POSITION.pack_into(self.map, _HEAD, head)
        return head

    def put_payload(self, head: int, payload: bytes) -> int:
        """:meth:`put` of the frame of ``payload`` (its 4-byte length, then it), without
        building the frame: the length and the payload are copied in one after the other
        (room checked by the caller); the new head, noted once both are in."""
        size = len(payload)
        start = HEADER + (head & self._mask)
        stop = start + 4 + size
        if stop > self._limit:  # wraps around the end
            return self.put(head, _LENGTH.pack(size) + payload)
        data = self.map
        _pack_length_into(data, start, size)
        data[start + 4 : stop] = payload
        head += 4 + size
        _pack_position_into(data, _HEAD, head)
        return head

    def get(self, start: int, end: int) -> bytes:
        """A copy of the bytes from position ``start`` to ``end`` (at most the capacity)."""
        offset = start & (self.capacity - 1)
        size = end - start
        if offset + size <= self.capacity:
            return self.map[HEADER + offset : HEADER + offset + size]
        first = self.capacity - offset
        return (
            self.map[HEADER + offset : HEADER + self.capacity]
            + self.map[HEADER : HEADER + size - first]
        )

    def prefault(self, fd: int = -1) -> None:
        """Have the kernel allocate and map the whole ring now, in a thread of this process.

        A ``memfd``'s pages are allocated (and zeroed) when first written: each first
        write to a 4 KiB page of the ring is a page fault, about 400 of them in the
        first 5000 ticks of a fast run (0.15 µs a tick of the run's CPU time, measured
        on the 2-core machine; the ring fills for the first time in 13 000 ticks, most
        of a run). ``madvise(MADV_POPULATE_WRITE)`` does the same work at once, in about
        2 ms, in a thread that releases the interpreter lock meanwhile, so the run goes
        on (Linux 5.14 and later; before that, ``posix_fallocate`` on ``fd`` allocates
        the pages and only their mapping is left to the tick). Best effort: where
        neither works, the pages are allocated when first written, as before. Writes to
        the ring meanwhile are safe: neither call changes what the memory holds.

        Args:
            fd: The ring's file descriptor, for the fallback (duplicated: the caller
                may close its own at once).
        """
        if self._prefaulting is not None:
            return
        try:
            import threading
        except ImportError:  # pragma: no cover - an interpreter without threads
            return
        own = -1
        with contextlib.suppress(OSError):
            own = os.dup(fd) if fd >= 0 else -1
        thread = threading.Thread(
            target=self._populate, args=(own,), name="pirate-bt-trace-ring", daemon=True
        )
        try:
            thread.start()
        except RuntimeError:  # the interpreter is shutting down
            if own >= 0:
                os.close(own)
            return
        self._prefaulting = thread

    def _populate(self, fd: int) -> None:
        try:
            try:
                self.map.madvise(_MADV_POPULATE_WRITE)
            except OSError:  # a kernel before 5.14: allocate at least
                fallocate = getattr(os, "posix_fallocate", None)
                if fd >= 0 and fallocate is not None:
                    fallocate(fd, 0, HEADER + self.capacity)
        except (OSError, ValueError):  # best effort (ValueError: the map is closed)
            pass
        finally:
            if fd >= 0:
                os.close(fd)

    def close(self) -> None:
        """Unmap (idempotent)."""
        thread, self._prefaulting = self._prefaulting, None
        if thread is not None:
            thread.join()  # it works on the mapping: done first (within a few ms)
        with contextlib.suppress(BufferError):
            self.map.close()


class RingReader:
    """The writer process's end: messages out of a ring, space given back after a rest."""

    def __init__(self, ring: Ring) -> None:
        self.ring = ring
        self.read_to = ring.tail()
        """Position up to which messages have been taken out."""

    def messages(self, upto: int) -> list[Any]:
        """The messages up to position ``upto`` (whole frames, as the recorder put them)."""
        if upto <= self.read_to:
            return []
        data = self.ring.get(self.read_to, upto)
        self.read_to = upto
        out = []
        view = memoryview(data)
        start, size = 0, len(data)
        while start < size:
            (length,) = _LENGTH.unpack_from(view, start)
            out.append(marshal.loads(view[start + 4 : start + 4 + length]))
            start += 4 + length
        view.release()
        return out

    def rested(self) -> None:
        """Give back what was read before this process's last sleep (see the module docstring)."""
        self.ring.set_tail(self.read_to)
