"""The link session: acks, retries, heartbeats, duplicates, link loss, e-stop first.

A :class:`Session` sits on a connected byte link (after :func:`~pirate_bt.link.transport.handshake`)
and does everything ``docs/protocol.md`` asks of the host:

- decodes incoming frames and keeps the latest ``STATE`` with its arrival time,
  dropping (and counting) duplicate and out-of-date ones by sequence number;
- sends requests **stop-and-wait**: one tracked request in flight, acknowledged by
  sequence number, retried with the *same* sequence number after an ack timeout
  derived from the baud rate, and given up after a bounded number of retries.
  Every request ends in exactly one :class:`Outcome`; none is dropped silently;
- a newer bulk setpoint supersedes an older one that is queued or in flight (it
  carries the full desired table, so nothing is lost);
- an e-stop is written at once, ahead of the queue and of anything in flight;
- keeps the bridge's watchdog fed: whenever no frame at all has gone out for a
  heartbeat period (a tenth of the watchdog), it sends a ``HEARTBEAT``, whatever
  else is queued or in flight. Heartbeats are never retried and never wait for one
  another: a lost one is simply followed by the next a period later, so at 5 % frame
  loss the bridge would need about ten frames in a row to vanish before it trips;
- declares the link lost (:class:`~pirate_bt.errors.LinkLost`) when nothing valid
  was heard for the link timeout;
- keeps health figures (RTT, loss ratio, CRC errors, retries, last heard).

**Polled, not threaded.** All of this happens in :meth:`Session.poll`, which
handles whatever bytes are available and whatever is due at the injected
clock's time, and never blocks. A blocking :meth:`Session.wait` loops ``poll()`` +
``clock.sleep(step)``; with a :class:`~pirate_bt.clock.SimClock` the sleep
advances simulated time, so the simulator steps and answers: runs are
deterministic. On a real port :meth:`Session.start_reader` runs the same
``poll()`` in a background thread; callers then only wait.
"""

from __future__ import annotations

import collections
import logging
import math
import threading
from collections.abc import Sequence

from pirate_bt.clock import Clock
from pirate_bt.errors import FrameError, LinkError, LinkLost, LinkTimeout
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BridgeHeartbeat,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    HelloReply,
    Message,
    Nack,
    Setpoint,
    State,
    seq_newer,
)
from pirate_bt.link.requests import (
    HEARTBEATS_PER_WATCHDOG,
    Outcome,
    Request,
    SessionConfig,
    SessionStats,
)
from pirate_bt.link.transport import ByteLink
from pirate_bt.robot.description import ControlMode

__all__ = [
    "HEARTBEATS_PER_WATCHDOG",
    "Outcome",
    "Request",
    "Session",
    "SessionConfig",
    "SessionStats",
]

_log = logging.getLogger(__name__)


class Session:
    """Request tracking and liveness over a connected byte link.

    Args:
        link: A transport after a successful handshake.
        codec: The codec for the robot's layout.
        clock: The clock every timeout reads.
        config: Timing; see :meth:`SessionConfig.from_robot`.
        first_seq: The sequence number after the HELLO's.
    """

    def __init__(
        self,
        link: ByteLink,
        codec: FrameCodec,
        clock: Clock,
        config: SessionConfig | None = None,
        *,
        first_seq: int = 2,
    ) -> None:
        self.link = link
        self.codec = codec
        self.clock = clock
        self.config = config or SessionConfig()
        self._decoder = FrameDecoder(codec)
        self._lock = threading.RLock()
        self._next_seq = first_seq & 0xFFFF or 1
        self._queue: collections.deque[Request] = collections.deque()
        self._ordered: Request | None = None  # the one SETPOINT/BULK in flight
        self._oob: dict[int, Request] = {}  # e-stop, reset, heartbeat, counters in flight
        now = clock.now()
        self._last_sent_s = now
        self._last_heard_s = now  # the handshake reply was heard just now
        self._state: State | None = None
        self._state_at_s = -math.inf
        self._rtt_s = math.nan
        self.rtt_samples: collections.deque[float] = collections.deque(maxlen=10_000)
        self._recent: collections.deque[bool] = collections.deque(maxlen=self.config.loss_window)
        self.crc_errors = 0
        self.retries = 0
        self.failed = 0
        self.duplicates = 0
        self.superseded = 0
        self.completed = 0
        self.unexpected = 0
        self._flags = BridgeFlags.NONE
        self._lost = False
        self._closed = False
        self._reader: threading.Thread | None = None
        self._reader_stop = threading.Event()
        self._reader_error: BaseException | None = None
        self.last_hello_reply: HelloReply | None = None
        self._pending_failures: list[Request] = []
        self._due_s = -math.inf  # no retry, give-up or heartbeat is due before this time

    # --- public -----------------------------------------------------------------------------

    def latest_state(self) -> tuple[State, float] | None:
        """The newest ``STATE`` frame and the clock time it arrived, or ``None``."""
        with self._lock:
            return None if self._state is None else (self._state, self._state_at_s)

    def send_setpoint(self, board: int, slot: int, mode: ControlMode, raw_value: int) -> Request:
        """Queue one motor's setpoint.

        Raises:
            LinkLost: the link was declared lost.
        """
        with self._lock:
            return self._submit(Setpoint(self._seq(), board, slot, mode, raw_value))

    def send_bulk(self, modes: Sequence[ControlMode | None], raw_values: Sequence[int]) -> Request:
        """Queue a bulk setpoint; it supersedes any bulk not yet acknowledged.

        Args:
            modes: One mode per motor in layout order (``None`` = keep).
            raw_values: One raw value per motor.

        Returns:
            The request handle.

        Raises:
            LinkLost: the link was declared lost.
            ValueError: the lists do not match the layout.
        """
        if len(modes) != self.codec.layout.n_motors or len(raw_values) != len(modes):
            raise ValueError("bulk setpoints do not match the layout")
        with self._lock:
            self._check_alive()
            now = self.clock.now()
            for old in list(self._queue):
                if isinstance(old.msg, BulkSetpoints):
                    self._queue.remove(old)
                    self._finish(old, Outcome.SUPERSEDED, now)
            if self._ordered is not None and isinstance(self._ordered.msg, BulkSetpoints):
                self._finish(self._ordered, Outcome.SUPERSEDED, now)
                self._ordered = None
            return self._submit(BulkSetpoints(self._seq(), tuple(modes), tuple(raw_values)))

    def estop(self) -> Request:
        """Write an e-stop now, ahead of every queue; never raises for a busy link."""
        with self._lock:
            req = Request(EStop(self._seq()), self.clock.now())
            self._oob[req.seq] = req
            try:
                self._transmit(req)
            except LinkError as exc:
                _log.error("e-stop write failed (will retry): %s", exc)
                self._due_s = -math.inf
            return req

    def estop_reset(self) -> Request:
        """Send an e-stop reset (out of band, like the e-stop).

        Raises:
            LinkLost: the link was declared lost.
        """
        return self._out_of_band(EStopReset)

    def request_counters(self) -> Request:
        """Ask the bridge for its counters; the reply lands in :attr:`Request.reply`.

        Raises:
            LinkLost: the link was declared lost.
        """
        return self._out_of_band(CountersRequest)

    def _out_of_band(self, message: type[EStopReset] | type[CountersRequest]) -> Request:
        """Send a request outside the setpoint order, tracked by its seq until answered."""
        with self._lock:
            self._check_alive()
            req = Request(message(self._seq()), self.clock.now())
            self._oob[req.seq] = req
            self._transmit(req)
            return req

    def wait(self, request: Request, timeout_s: float | None = None) -> Request:
        """Wait until ``request`` has an outcome, at most ``timeout_s`` of clock time.

        Without a reader thread this polls; with one it only sleeps.

        Args:
            request: A handle from this session.
            timeout_s: Longest wait; default: the request's whole retry budget plus
                one step.

        Returns:
            ``request`` (check :attr:`Request.outcome`).

        Raises:
            LinkTimeout: still pending after ``timeout_s``.
            LinkLost: the link was declared lost while waiting.
        """
        if timeout_s is None:
            timeout_s = self.config.give_up_s + 2 * self.config.poll_step_s
        deadline = self.clock.now() + timeout_s
        while not request.done:
            if self._reader is None:
                self.poll()
            else:
                self._raise_reader_error()
            if request.done:
                break
            now = self.clock.now()
            if now >= deadline:
                raise LinkTimeout(f"{request!r} not answered within {timeout_s:.3f} s")
            self.clock.sleep(min(self.config.poll_step_s, deadline - now))
        return request

    def ensure_alive(self) -> None:
        """Raise if the link was declared lost or the session closed.

        Raises:
            LinkLost: the link was declared lost.
            LinkError: the session is closed.
        """
        with self._lock:
            self._check_alive()

    def take_failures(self) -> list[Request]:
        """Requests that failed or were refused since the last call (oldest first)."""
        with self._lock:
            out, self._pending_failures = self._pending_failures, []
            return out

    def poll(self) -> None:
        """Handle available input and due retries, heartbeats and loss; never blocks.

        Raises:
            LinkLost: nothing valid heard for ``link_timeout_s`` (then on every call).
            LinkError: the transport failed.
        """
        with self._lock:
            if self._closed:
                raise LinkError("session closed")
            data = self.link.read_available()
            now = self.clock.now()
            if data:
                handle = self._handle
                for item in self._decoder.feed(data):
                    handle(item, now)
            if self._lost or now - self._last_heard_s > self.config.link_timeout_s:
                self._check_alive(now)
            if now >= self._due_s:  # most polls (one per state frame) have nothing due
                self._service(now)

    def stats(self) -> SessionStats:
        """Current figures."""
        with self._lock:
            recent = self._recent
            return SessionStats(
                connected=not (self._lost or self._closed),
                last_heard_s=self._last_heard_s,
                rtt_s=self._rtt_s,
                loss_ratio=(sum(recent) / len(recent)) if recent else 0.0,
                crc_errors=self.crc_errors,
                retries=self.retries,
                failed=self.failed,
                duplicates=self.duplicates,
                superseded=self.superseded,
                sent=self.completed,
                estopped=bool(self._flags & BridgeFlags.ESTOP),
                watchdog=bool(self._flags & BridgeFlags.WATCHDOG),
            )

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
            self._reader.join(timeout=1.0)
            self._reader = None

    def close(self) -> None:
        """Stop the reader, fail what is pending, close the link (idempotent)."""
        self.stop_reader()
        with self._lock:
            if self._closed:
                return
            now = self.clock.now()
            for req in [*self._queue, *self._oob.values()] + (
                [self._ordered] if self._ordered else []
            ):
                self._finish(req, Outcome.FAILED, now)
            self._queue.clear()
            self._oob.clear()
            self._ordered = None
            self._closed = True
            self.link.close()

    # --- internals --------------------------------------------------------------------------

    def _raise_reader_error(self) -> None:
        err = self._reader_error
        if err is not None:
            raise err

    def _seq(self) -> int:
        seq = self._next_seq
        self._next_seq = (seq + 1) & 0xFFFF or 1
        return seq

    def _check_alive(self, now: float | None = None) -> None:
        if self._lost:
            raise LinkLost(f"nothing heard from the bridge for over {self.config.link_timeout_s} s")
        if self._closed:
            raise LinkError("session closed")
        if now is None:
            return
        if now - self._last_heard_s > self.config.link_timeout_s:
            self._lost = True
            silent = now - self._last_heard_s
            _log.error("link lost: bridge silent for %.3f s", silent)
            for req in [*self._queue, *self._oob.values()] + (
                [self._ordered] if self._ordered else []
            ):
                self._finish(req, Outcome.FAILED, now)
            self._queue.clear()
            self._oob.clear()
            self._ordered = None
            raise LinkLost(f"nothing heard from the bridge for {silent:.3f} s")

    def _submit(self, msg: Setpoint | BulkSetpoints) -> Request:
        self._check_alive()
        req = Request(msg, self.clock.now())
        self._queue.append(req)
        if self._ordered is None:
            self._service(self.clock.now())
        return req

    def _transmit(self, req: Request) -> None:
        now = self.clock.now()
        if req.tries:
            self.retries += 1
        else:
            req.first_sent_s = now
        req.tries += 1
        req.sent_at_s = now
        self._last_sent_s = now
        due = req.next_try_s(self.config.ack_timeout_s)
        if due < self._due_s:
            self._due_s = due
        self.link.write(self.codec.encode(req.msg))

    def _finish(self, req: Request, outcome: Outcome, now: float) -> None:
        if req.done:
            return
        req.outcome = outcome
        req.acked_at_s = now
        self.completed += 1
        if outcome is Outcome.SUPERSEDED:
            self.superseded += 1
            return
        if outcome is Outcome.FAILED:
            self.failed += 1
            if isinstance(req.msg, Heartbeat):
                # expected now and then on a lossy line; the next one is already due
                _log.debug("%r not acknowledged", req)
            else:
                _log.warning("%r gave up after %d tries", req, req.tries)
        if outcome in (Outcome.FAILED, Outcome.NACKED) and not isinstance(req.msg, Heartbeat):
            self._pending_failures.append(req)
        self._recent.append(outcome is Outcome.FAILED or req.tries > 1)

    def _service(self, now: float) -> None:
        cfg = self.config
        # retries and give-ups; the e-stop and other out-of-band requests first
        timeout = cfg.ack_timeout_s
        for req in list(self._oob.values()):
            due = req.next_try_s(timeout)
            if now >= due or due != due:  # due, or never written (nan)
                if isinstance(req.msg, Heartbeat) or req.tries > cfg.max_retries:
                    del self._oob[req.seq]
                    self._finish(req, Outcome.FAILED, now)
                else:
                    self._transmit(req)
        ordered = self._ordered
        if ordered is not None and now >= ordered.next_try_s(timeout):
            if ordered.tries > cfg.max_retries:
                self._ordered = None
                self._finish(ordered, Outcome.FAILED, now)
            else:
                self._transmit(ordered)
        if self._ordered is None and self._queue:
            self._ordered = self._queue.popleft()
            self._transmit(self._ordered)
        # Keep-alive, independent of what is in flight: a retried request whose frames
        # are lost must not hold heartbeats back, and any frame feeds the watchdog.
        if now - self._last_sent_s >= cfg.heartbeat_period_s:
            hb = Request(Heartbeat(self._seq()), now)
            self._oob[hb.seq] = hb
            self._transmit(hb)
        # the next time anything above can be due (a conservative bound: acks only delay it)
        due = self._last_sent_s + cfg.heartbeat_period_s
        for req in self._oob.values():
            next_s = req.next_try_s(timeout)
            due = min(due, now if next_s != next_s else next_s)  # nan: not written yet
        if self._ordered is not None:
            due = min(due, self._ordered.next_try_s(timeout))
        self._due_s = due

    def _settle(self, req: Request, outcome: Outcome, now: float) -> None:
        if outcome is Outcome.ACKED and req.tries == 1:
            sample = now - req.sent_at_s
            self.rtt_samples.append(sample)
            # Karn: only first-try samples; smoothed like TCP's SRTT (alpha = 1/8)
            self._rtt_s = (
                sample if math.isnan(self._rtt_s) else self._rtt_s + (sample - self._rtt_s) / 8
            )
        self._finish(req, outcome, now)

    def _handle(self, item: Message | FrameError, now: float) -> None:
        if type(item) is State:  # the common case first: one every state period
            self._last_heard_s = now
            self._on_state(item, now)
            return
        if isinstance(item, FrameError):
            self.crc_errors += 1
            _log.debug("dropped frame: %s", item)
            return
        if item.TYPE < 0x80:
            self.unexpected += 1  # our own frames (loop://) or a confused peer
            return
        self._last_heard_s = now
        if isinstance(item, State):
            self._on_state(item, now)
            return
        if isinstance(item, Ack | Nack | Counters):
            req = self._match(item.seq)
            if req is None:
                self.duplicates += 1
                return
            if isinstance(item, Ack):
                req.ack_status = item.status
                outcome = Outcome.ACKED
            elif isinstance(item, Nack):
                req.nack = item.error
                outcome = Outcome.NACKED
            else:
                req.reply = item
                outcome = Outcome.ACKED
            self._settle(req, outcome, now)
            if self._ordered is None and self._queue:  # the next queued request may go
                self._service(now)
            return
        if isinstance(item, BridgeHeartbeat):
            self._flags = item.flags
            return
        if isinstance(item, HelloReply):
            self.last_hello_reply = item
            return

    def _on_state(self, item: State, now: float) -> None:
        last = self._state
        if last is not None and not seq_newer(item.seq, last.seq):
            self.duplicates += 1
            return
        self._state = item
        self._state_at_s = now
        self._flags = item.flags
        ordered = self._ordered
        if (
            ordered is not None
            and isinstance(ordered.msg, BulkSetpoints)
            and (item.ack_seq == ordered.seq or seq_newer(item.ack_seq, ordered.seq))
        ):
            self._ordered = None
            ordered.ack_status = AckStatus.APPLIED
            self._settle(ordered, Outcome.ACKED, now)
            self._service(now)

    def _match(self, seq: int) -> Request | None:
        req = self._oob.pop(seq, None)
        if req is not None:
            return req
        if self._ordered is not None and self._ordered.seq == seq:
            req, self._ordered = self._ordered, None
            return req
        return None
