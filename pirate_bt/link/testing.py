"""Test doubles for the link: an in-memory byte pipe, a pty end, and a scripted bridge.

:class:`ScriptedBridge` is a small, honest bridge that follows ``docs/protocol.md``
(duplicate filter, acks, state frames, e-stop latch, counters, watchdog) with no
physics: it records every request it *applies*, so tests can check that a request
was applied at most once. Knobs (``silent``, ``ignore``, ``layout_digest``,
``version``) let a test script misbehaviour. It runs either stepped by a clock
listener (``clock.add_listener(bridge.step)``: deterministic with a
:class:`~pirate_bt.clock.SimClock`) or in its own thread (:meth:`ScriptedBridge.start`)
on the far end of a pty.

:func:`memory_pair` returns two connected in-memory byte links, for tests that
need no operating-system I/O at all.
"""

from __future__ import annotations

import collections
import contextlib
import errno
import os
import threading

from pirate_bt.clock import Clock
from pirate_bt.errors import FrameError
from pirate_bt.link.codec import (
    PROTOCOL_VERSION,
    Ack,
    AckStatus,
    BoardCounters,
    BridgeFlags,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    Nack,
    NackCode,
    Setpoint,
    State,
    seq_newer,
)
from pirate_bt.link.transport import ByteLink

__all__ = ["FdPort", "MemoryLink", "ScriptedBridge", "memory_pair"]


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


class ScriptedBridge:
    """A protocol-faithful bridge without physics, for tests and benchmarks.

    Args:
        port: The bridge's end of the line (``read_available()``, ``write(bytes)``).
        codec: Codec for the robot's layout.
        state_period_s: Time between STATE frames (0 = send none).
        watchdog_s: Host silence after which the bridge sets the WATCHDOG flag.

    Attributes:
        applied: Every SETPOINT/BULK_SETPOINTS/ESTOP/ESTOP_RESET the bridge applied.
        silent: When true the bridge reads but never answers (link-loss tests).
        ignore: Message types the bridge reads but does not answer.
        raw_values: The values it reports in STATE frames.
    """

    def __init__(
        self,
        port: ByteLink,
        codec: FrameCodec,
        *,
        state_period_s: float = 0.01,
        watchdog_s: float = 0.25,
    ) -> None:
        self.port = port
        self.codec = codec
        self.decoder = FrameDecoder(codec)
        self.state_period_s = state_period_s
        self.watchdog_s = watchdog_s
        self.layout_digest = codec.layout.digest
        self.version = PROTOCOL_VERSION
        self.silent = False
        self.ignore: set[type] = set()
        self.applied: list[Message] = []
        self.raw_values = [0] * codec.layout.n_channels
        self.estopped = False
        self.watchdog = False
        self.last_seq: int | None = None
        self.ack_seq = 0
        self.counters = collections.Counter[str]()
        self._tx_seq = 0
        self._next_state_s: float | None = None
        self._last_rx_s: float | None = None
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    # I/O helpers ------------------------------------------------------------------------

    def _read(self) -> bytes:
        return self.port.read_available()

    def _send(self, msg: Message) -> None:
        if self.silent or type(msg) in self.ignore:
            return
        wire = self.codec.encode(msg)
        if self.version != PROTOCOL_VERSION:
            wire = self._rewrite_version(wire)
        self.port.write(wire)

    def _rewrite_version(self, wire: bytes) -> bytes:
        import binascii  # only for the misbehaving-bridge case

        from pirate_bt.link.codec import cobs_decode, cobs_encode

        body = bytearray(cobs_decode(wire[:-1]))
        body[0] = self.version
        crc = binascii.crc_hqx(bytes(body[:-2]), 0)
        body[-2:] = crc.to_bytes(2, "little")
        return cobs_encode(bytes(body)) + b"\x00"

    def _tx(self) -> int:
        self._tx_seq = (self._tx_seq + 1) & 0xFFFF
        return self._tx_seq

    # behaviour ---------------------------------------------------------------------------

    def step(self, now_s: float) -> None:
        """Handle received frames and send what is due at ``now_s`` (a clock listener)."""
        with self._lock:
            for item in self.decoder.feed(self._read()):
                if isinstance(item, FrameError):
                    self.counters["frame_errors" if item.reason != "crc" else "crc_errors"] += 1
                    continue
                self._last_rx_s = now_s
                self.counters["rx_frames"] += 1
                self._handle(item)
            if self._last_rx_s is not None and now_s - self._last_rx_s > self.watchdog_s:
                if not self.watchdog:
                    self.counters["watchdog_trips"] += 1
                self.watchdog = True
            if self.state_period_s > 0:
                if self._next_state_s is None:
                    self._next_state_s = now_s
                if now_s >= self._next_state_s:
                    self._next_state_s = max(self._next_state_s + self.state_period_s, now_s)
                    self._send(self.state())

    def state(self) -> State:
        """The STATE frame the bridge would send now (consumes a bridge seq)."""
        flags = BridgeFlags.NONE
        if self.estopped:
            flags |= BridgeFlags.ESTOP
        if self.watchdog:
            flags |= BridgeFlags.WATCHDOG
        lay = self.codec.layout
        return State(
            self._tx(),
            flags,
            self.ack_seq,
            (1 << lay.n_channels) - 1,
            (1,) * lay.n_boards,
            tuple(self.raw_values),
        )

    def _handle(self, msg: Message) -> None:
        if isinstance(msg, Hello):
            self.last_seq = msg.seq
            lay = self.codec.layout
            self._send(
                HelloReply(msg.seq, self.layout_digest, lay.n_channels, lay.n_motors, 250, 1)
            )
            return
        if isinstance(msg, Heartbeat):
            self.watchdog = False
            self._send(Ack(msg.seq, msg.TYPE))
            return
        if isinstance(msg, EStop):
            self.estopped = True
            self.applied.append(msg)
            self._send(Ack(msg.seq, msg.TYPE))
            return
        if isinstance(msg, EStopReset):
            self.estopped = False
            self.applied.append(msg)
            self._send(Ack(msg.seq, msg.TYPE))
            return
        if isinstance(msg, CountersRequest):
            c = self.counters
            boards = tuple(BoardCounters(b) for b in range(1, self.codec.layout.n_boards + 1))
            self._send(
                Counters(
                    msg.seq,
                    c["rx_frames"],
                    c["crc_errors"],
                    c["frame_errors"],
                    c["duplicates"],
                    c["watchdog_trips"],
                    boards,
                )
            )
            return
        if isinstance(msg, Setpoint | BulkSetpoints):
            self.watchdog = False
            if self.last_seq is not None and not seq_newer(msg.seq, self.last_seq):
                self.counters["duplicates"] += 1
                status = AckStatus.DUPLICATE if msg.seq == self.last_seq else AckStatus.STALE
                if isinstance(msg, Setpoint):
                    self._send(Ack(msg.seq, msg.TYPE, status))
                return
            if self.estopped:
                self._send(Nack(msg.seq, msg.TYPE, NackCode.ESTOP_LATCHED))
                return
            self.last_seq = msg.seq
            self.applied.append(msg)
            if isinstance(msg, Setpoint):
                self._send(Ack(msg.seq, msg.TYPE))
            else:
                self.ack_seq = msg.seq
            return
        self.counters["unexpected"] += 1

    # threaded mode -----------------------------------------------------------------------

    def start(self, clock: Clock, period_s: float = 0.0005) -> None:
        """Run :meth:`step` in a daemon thread every ``period_s`` of ``clock`` time."""

        def run() -> None:
            while not self._stop.is_set():
                self.step(clock.now())
                clock.sleep(period_s)

        self._stop.clear()
        self._thread = threading.Thread(target=run, name="scripted-bridge", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the thread started by :meth:`start`."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None
