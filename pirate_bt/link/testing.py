"""Test doubles for the link: an in-memory byte pipe and a pty end.

The bridge on the far end of them is the reference bridge,
:class:`~pirate_bt.sim.bridge.SimBridge`, put there by
:class:`~pirate_bt.sim.bridge_port.BridgeOnPort` (the scripted bridge that used to
live here disagreed with it and with ``docs/protocol.md``, and is gone).

:func:`memory_pair` returns two connected in-memory byte links, for tests that
need no operating-system I/O at all.
"""

from __future__ import annotations

import collections
import contextlib
import errno
import os
import threading

__all__ = ["FdPort", "MemoryLink", "memory_pair"]


class MemoryLink:
    """One end of an in-memory byte pipe (see :func:`memory_pair`); a ``ByteLink``."""

    def __init__(
        self, inbox: collections.deque[bytes], outbox: collections.deque[bytes], baud: int
    ) -> None:
        self._in = inbox
        self._out = outbox
        self._baud = baud
        self.closed = False

    @property
    def baud(self) -> int:
        return self._baud

    def read_available(self) -> bytes:
        chunks = []
        while self._in:
            chunks.append(self._in.popleft())
        return b"".join(chunks)

    def write(self, data: bytes) -> None:
        if data:
            self._out.append(bytes(data))

    def drain_input(self) -> int:
        return len(self.read_available())

    def close(self) -> None:
        self.closed = True


def memory_pair(baud: int = 115200) -> tuple[MemoryLink, MemoryLink]:
    """Two connected in-memory byte links: ``(host_end, bridge_end)``."""
    a: collections.deque[bytes] = collections.deque()
    b: collections.deque[bytes] = collections.deque()
    return MemoryLink(a, b, baud), MemoryLink(b, a, baud)


class FdPort:
    """A raw file descriptor (e.g. a pty master) as a non-blocking ``ByteLink``."""

    def __init__(self, fd: int, baud: int = 115200) -> None:
        self.fd = fd
        self._baud = baud
        os.set_blocking(fd, False)

    @property
    def baud(self) -> int:
        return self._baud

    def read_available(self) -> bytes:
        try:
            return os.read(self.fd, 65536)
        except BlockingIOError:
            return b""
        except OSError as exc:  # EIO: the other end of the pty is closed
            if exc.errno == errno.EIO:
                return b""
            raise

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            try:
                view = view[os.write(self.fd, view) :]
            except BlockingIOError:
                threading.Event().wait(0.0005)

    def drain_input(self) -> int:
        return len(self.read_available())

    def close(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self.fd)
