"""The link session: acks, retries, heartbeats, duplicates, sessions, link loss, e-stop first.

A :class:`Session` sits on a connected byte link (after :func:`~pirate_bt.link.transport.handshake`)
and does everything ``docs/protocol.md`` asks of the host:

- decodes incoming frames and keeps the latest ``STATE`` with its arrival time,
  dropping (and counting) duplicate and out-of-date ones by sequence number;
- numbers requests from two counters: the **ordered** one (``SETPOINT``,
  ``BULK_SETPOINTS``, ``ESTOP``, ``ESTOP_RESET``, ``HELLO``), which the bridge's
  duplicate filter follows, and the **untracked** one (``HEARTBEAT``,
  ``COUNTERS_REQUEST``), which it never compares. Heartbeats therefore cannot age
  the filter, however long the session;
- sends ordered requests **stop-and-wait**: one in flight, acknowledged by type and
  sequence number, retried with the *same* sequence number after an ack timeout
  derived from the baud rate, and given up after a bounded number of retries.
  Every request ends in exactly one :class:`Outcome`; none is dropped silently, and
  an ``ACK STALE`` is a failure, never an acknowledgement;
- a newer bulk setpoint supersedes an older one that is queued or in flight (it
  carries the full desired table, so nothing is lost);
- an e-stop is written at once, ahead of the queue and of anything in flight, and
  cancels every queued or in-flight setpoint and e-stop reset;
- keeps the bridge's watchdog fed: whenever no frame at all has gone out for a
  heartbeat period (a tenth of the watchdog), it sends a ``HEARTBEAT``, whatever
  else is queued or in flight. Heartbeats are never retried and never wait for one
  another;
- sees a bridge reset (``NO_SESSION`` in a ``STATE``, a new boot id) and starts a
  new session with a ``HELLO``, failing what was in flight; starts one too before
  its ordered counter runs :data:`SESSION_RENEW_GAP` ahead of the bridge;
- declares the link lost (:class:`~pirate_bt.errors.LinkLost`) when nothing valid
  was heard for the link timeout, or when the bridge's frames report its watchdog
  tripped (it hears nothing from the host) for the link timeout while the host fed it;
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
from pirate_bt.errors import LinkError, LinkLost, LinkTimeout
from pirate_bt.link.codec import (
    BridgeFlags,
    BulkSetpoints,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    MsgType,
    Setpoint,
    State,
)
from pirate_bt.link.inbound import UNMATCHED_KEPT, InboundMixin
from pirate_bt.link.liveness import LivenessMixin
from pirate_bt.link.noise import LineNoise
from pirate_bt.link.reader import ReaderMixin
from pirate_bt.link.requests import (
    HEARTBEATS_PER_WATCHDOG,
    SESSION_RENEW_GAP,
    Outcome,
    Request,
    SessionConfig,
    SessionStats,
)
from pirate_bt.link.transport import ByteLink
from pirate_bt.robot.description import ControlMode

__all__ = [
    "HEARTBEATS_PER_WATCHDOG",
    "SESSION_RENEW_GAP",
    "Outcome",
    "Request",
    "Session",
    "SessionConfig",
    "SessionStats",
]

_log = logging.getLogger(__name__)

HELLO_TRIES = 16
"""Tries of a mid-session HELLO before the link is declared lost."""

_ORDERED = (Setpoint, BulkSetpoints, EStopReset)


def _next(seq: int) -> int:
    return (seq + 1) & 0xFFFF or 1


class Session(InboundMixin, LivenessMixin, ReaderMixin):
    """Request tracking and liveness over a connected byte link.

    Args:
        link: A transport after a successful handshake.
        codec: The codec for the robot's layout.
        clock: The clock every timeout reads.
        config: Timing; see :meth:`SessionConfig.from_robot`.
        first_seq: The ordered sequence number after the HELLO's.
        hello_reply: The handshake's reply (its boot id tells a later reset apart).
        decoder: The handshake's decoder, holding the start of the frame that followed
            the reply (default: a new one).
    """

    def __init__(
        self,
        link: ByteLink,
        codec: FrameCodec,
        clock: Clock,
        config: SessionConfig | None = None,
        *,
        first_seq: int = 2,
        hello_reply: HelloReply | None = None,
        decoder: FrameDecoder | None = None,
    ) -> None:
        self.link = link
        self.codec = codec
        self.clock = clock
        config = config or SessionConfig()
        self.config = config if hello_reply is None else config.heeding(hello_reply.watchdog_ms)
        self._decoder = FrameDecoder(codec) if decoder is None else decoder
        self._lock = threading.RLock()
        self._next_seq = first_seq & 0xFFFF or 1
        self._next_useq = 1
        # the last ordered seq the bridge answered (the HELLO's, to start with)
        self._answered = (self._next_seq - 1) & 0xFFFF
        self._session_hello = self._answered
        self._stale_run = 0  # ordered requests answered STALE in a row
        self._queue: collections.deque[Request] = collections.deque()
        self._ordered: Request | None = None  # the one SETPOINT/BULK/ESTOP_RESET in flight
        self._oob: dict[tuple[int, int], Request] = {}  # (type, seq): e-stop, heartbeat, counters
        self._hello: Request | None = None  # a mid-session HELLO in flight
        self._protocol_error: LinkError | None = None
        now = clock.now()
        self._last_sent_s = now
        self._last_heard_s = now  # the handshake reply was heard just now
        self._noise = LineNoise()  # what came since then that made no good frame
        self._unmatched: collections.deque[float] = collections.deque(maxlen=UNMATCHED_KEPT)
        self._state: State | None = None
        self._faulted: tuple[int, ...] = ()  # positions of the latest STATE's boards in FAULT
        self._accept_any_state = True  # the first STATE after a HELLO_REPLY, whatever its seq
        self._state_at_s = -math.inf  # pragma: no mutate (read only once a STATE is in)
        self._rtt_s = math.nan
        self.rtt_samples: collections.deque[float] = collections.deque(maxlen=10_000)
        self._recent: collections.deque[bool] = collections.deque(maxlen=self.config.loss_window)
        self.crc_errors = 0
        self.heartbeats_sent = 0
        self.heartbeats_answered = 0
        self.retries = 0
        self.failed = 0
        self.duplicates = 0
        self.superseded = 0
        self.stale = 0
        self.cancelled = 0
        self.completed = 0
        self.unexpected = 0
        self.bridge_resets = 0
        self.sessions = 1
        self._flags = BridgeFlags.NONE if hello_reply is None else hello_reply.flags
        self._lost = False  # pragma: no mutate (None is falsy as False is)
        self._lost_why = ""  # why the link was lost, when not for silence
        self._deaf_from_s = now  # the bridge reports WATCHDOG in every poll since then
        self._closed = False  # pragma: no mutate (None is falsy as False is)
        self._init_reader()
        self.last_hello_reply: HelloReply | None = hello_reply
        self._pending_failures: list[Request] = []
        self._estop_not_taken: Request | None = None  # see take_estop_not_taken
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
            ValueError: a field does not fit its wire type (nothing is queued).
        """
        with self._lock:
            self._check_alive()
            return self._submit(Setpoint(self._seq(), board, slot, mode, raw_value))

    def send_bulk(self, modes: Sequence[ControlMode | None], raw_values: Sequence[int]) -> Request:
        """Queue a bulk setpoint; it supersedes any bulk not yet acknowledged.

        Args:
            modes: One mode per motor in layout order (``None`` = keep).
            raw_values: One raw value per motor (a keep entry's is sent as 0, whatever
                it is).

        Returns:
            The request handle.

        Raises:
            LinkLost: the link was declared lost.
            ValueError: the lists do not match the layout, or a raw value does not fit
                an int16 (nothing is queued, nothing superseded).
        """
        if len(modes) != self.codec.layout.n_motors or len(raw_values) != len(modes):
            raise ValueError("bulk setpoints do not match the layout")
        with self._lock:
            self._check_alive()
            # a keep entry's raw value is ignored and sent as 0 (docs/protocol.md): a
            # bridge may refuse anything else
            raws = tuple(0 if m is None else r for m, r in zip(modes, raw_values, strict=True))
            msg = BulkSetpoints(self._seq(), tuple(modes), raws)
            wire = self.codec.encode(msg)  # before superseding: a bad one replaces nothing
            now = self.clock.now()
            for old in list(self._queue):
                if isinstance(old.msg, BulkSetpoints):
                    self._queue.remove(old)
                    self._finish(old, Outcome.SUPERSEDED, now)
            if self._ordered is not None and isinstance(self._ordered.msg, BulkSetpoints):
                self._finish(self._ordered, Outcome.SUPERSEDED, now)
                self._ordered = None
            return self._submit(msg, wire)

    def estop(self) -> Request:
        """Write an e-stop now, ahead of every queue; never raises for a busy link.

        Every queued or in-flight setpoint and e-stop reset is cancelled
        (:attr:`Outcome.CANCELLED`): the e-stop takes a newer ordered seq, so the
        bridge would answer a late copy of any of them ``STALE`` anyway.
        """
        with self._lock:
            now = self.clock.now()
            for req in [*self._queue, *([self._ordered] if self._ordered else [])]:
                self._finish(req, Outcome.CANCELLED, now)
            self._queue.clear()
            self._ordered = None
            self._latch_discount = 0  # a STATE that shows the latch from now on is believed
            req = Request(EStop(self._seq()), now)
            self._oob[(MsgType.ESTOP, req.seq)] = req
            try:
                self._transmit(req)
            except LinkError as exc:
                _log.error("e-stop write failed (will retry): %s", exc)
                self._due_s = -math.inf
            return req

    def estop_reset(self) -> Request:
        """Queue an e-stop reset (an ordered request, like a setpoint).

        Raises:
            LinkLost: the link was declared lost.
        """
        with self._lock:
            self._check_alive()
            return self._submit(EStopReset(self._seq()))

    def request_counters(self) -> Request:
        """Ask the bridge for its counters; the reply lands in :attr:`Request.reply`.

        Raises:
            LinkLost: the link was declared lost.
        """
        with self._lock:
            self._check_alive()
            req = Request(CountersRequest(self._useq()), self.clock.now())
            self._oob[(MsgType.COUNTERS_REQUEST, req.seq)] = req
            self._transmit(req)
            return req

    def wait(self, request: Request, timeout_s: float | None = None) -> Request:
        """Wait until ``request`` has an outcome, at most ``timeout_s`` of clock time.

        Without a reader thread this polls; with one it only sleeps.

        Args:
            request: A handle from this session.
            timeout_s: Longest wait; default: the request's whole retry budget, plus a
                queue's worth when it waits behind another request.

        Returns:
            ``request`` (check :attr:`Request.outcome`).

        Raises:
            LinkTimeout: still pending after ``timeout_s``.
            LinkLost: the link was declared lost while waiting.
        """
        if timeout_s is None:
            queued = 1 + len(self._queue) + (self._ordered is not None) + (self._hello is not None)
            timeout_s = queued * self.config.give_up_s + 2 * self.config.poll_step_s
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
            LinkError: the session is closed, or the bridge refused a new session.
        """
        with self._lock:
            self._check_alive()

    def take_estop_not_taken(self) -> Request | None:
        """An ``ESTOP`` the bridge refused (``NACK``) or never answered on every try, or
        answered ``STALE`` (not applied), since the last call, or ``None``: the bridge did
        not latch, and nothing else will say so (its ``STATE`` frames only show no latch).
        Taken out of :meth:`take_failures`'s list too: it is said once, by the caller of
        this."""
        with self._lock:
            req, self._estop_not_taken = self._estop_not_taken, None
            if req is not None and req in self._pending_failures:
                self._pending_failures.remove(req)
            return req

    def forget_failure(self, req: Request) -> bool:
        """Take ``req`` out of :meth:`take_failures`'s list (a bulk whose table the link
        sends again, :mod:`pirate_bt.link.resend`); whether it was there."""
        with self._lock:
            if req in self._pending_failures:
                self._pending_failures.remove(req)
                return True
            return False

    def take_failures(self) -> list[Request]:
        """Requests that failed, were refused or came back stale since the last call."""
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
                heard_s = self._last_heard_s
                for item in self._decoder.feed(data):
                    handle(item, now)
                if self._last_heard_s == heard_s:  # no good frame in them
                    self._noise.note_bytes(heard_s, len(data))
                self._check_heard(now)
            if self._lost or now - self._last_heard_s > self.config.link_timeout_s:
                self._check_alive()  # lost (for good), closed, refused: raises
                self._lose(now)  # nothing valid heard for the link timeout
            if self._protocol_error is not None:
                raise self._protocol_error
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
                estopped=self._estopped(self._flags),
                watchdog=bool(self._flags & BridgeFlags.WATCHDOG),
                bridge_resets=self.bridge_resets,
                sessions=self.sessions,
                stale=self.stale,
                cancelled=self.cancelled,
                estop_input=self._estop_input(self._flags),
                bus_fault=bool(self._flags & BridgeFlags.BUS_FAULT),
                faulted=self._faulted,
                line_noise=self.line_noise(),
            )

    def close(self) -> None:
        """Stop the reader, fail what is pending, close the link (idempotent)."""
        self.stop_reader()
        with self._lock:
            if self._closed:
                return
            self._fail_all(self.clock.now())
            self._closed = True
            self.link.close()

    # --- internals --------------------------------------------------------------------------

    def _seq(self) -> int:
        seq = self._next_seq
        self._next_seq = _next(seq)
        return seq

    def _useq(self) -> int:
        seq = self._next_useq
        self._next_useq = _next(seq)
        return seq

    def _fail_all(self, now: float) -> None:
        pending = [*self._queue, *self._oob.values()]
        for req in (self._ordered, self._hello):
            if req is not None:
                pending.append(req)
        for req in pending:
            self._finish(req, Outcome.FAILED, now)
        self._queue.clear()
        self._oob.clear()
        # the session is over (closed or lost): nothing reads these two again
        self._ordered = None  # pragma: no mutate (the session is over)
        self._hello = None  # pragma: no mutate (the session is over)

    def _submit(
        self, msg: Setpoint | BulkSetpoints | EStopReset, wire: bytes | None = None
    ) -> Request:
        # Encoded here, once, so that a request that cannot be encoded is refused to its
        # caller (ValueError) instead of failing every later poll() that would send it.
        req = Request(msg, self.clock.now(), self.codec.encode(msg) if wire is None else wire)
        self._queue.append(req)
        if self._ordered is None and self._hello is None:
            self._service(self.clock.now())
        return req

    def _transmit(self, req: Request) -> None:
        now = self.clock.now()
        if req.tries:
            self.retries += 1
        else:
            req.first_sent_s = now
            req.marks = (self.crc_errors, self.heartbeats_sent, self.heartbeats_answered)
        req.tries += 1
        req.sent_at_s = now
        self._last_sent_s = now
        due = req.next_try_s(self.config.ack_timeout_s)
        if due < self._due_s:  # pragma: no mutate (<=: it would set the same value)
            self._due_s = due
        wire = req.wire
        self.link.write(self.codec.encode(req.msg) if wire is None else wire)

    def _finish(self, req: Request, outcome: Outcome, now: float) -> None:
        if req.done:
            return
        req.outcome = outcome
        req.acked_at_s = now
        self.completed += 1
        if outcome is Outcome.ACKED and isinstance(req.msg, Heartbeat):
            self.heartbeats_answered += 1
        if outcome is Outcome.SUPERSEDED:
            self.superseded += 1
            return
        if outcome is Outcome.CANCELLED:
            self.cancelled += 1
            return
        if outcome is Outcome.STALE:
            self.stale += 1
            _log.warning("%r: the bridge answered STALE (not applied)", req)
        if outcome is Outcome.FAILED:
            if isinstance(req.msg, Heartbeat):
                # expected now and then on a lossy line; the next one is already due
                _log.debug("%r not acknowledged", req)
                return
            self.failed += 1
            if req.tries:
                _log.warning("%r gave up after %d tries", req, req.tries)
            else:
                _log.warning("%r not sent: the session ended or a new one started", req)
        if outcome in (Outcome.FAILED, Outcome.NACKED, Outcome.STALE) and not isinstance(
            req.msg, Heartbeat | Hello
        ):
            self._pending_failures.append(req)
            if type(req.msg) is EStop:
                # refused or unanswered on every try, or answered STALE (which
                # docs/protocol.md rules out: an ESTOP latches whatever its seq)
                self._estop_not_taken = req
        self._recent.append(outcome is Outcome.FAILED or req.tries > 1)

    def _start_session(self, now: float, why: str) -> None:
        """Send a HELLO: a new session on the bridge (after a reset, or a long gap)."""
        _log.warning("starting a new session: %s", why)
        self._fail_all_ordered(now)
        hello = Hello(self._seq(), self.codec.layout.digest, self.config.protocol_minor)
        self._hello = Request(
            hello,
            now,  # pragma: no mutate (an internal request's time: nothing reads it)
        )
        self._transmit(self._hello)

    def _fail_all_ordered(self, now: float) -> None:
        for req in [*self._queue, *([self._ordered] if self._ordered else [])]:
            self._finish(req, Outcome.FAILED, now)
        self._queue.clear()
        self._ordered = None

    def _service(self, now: float) -> None:
        cfg = self.config
        # retries and give-ups; the e-stop and other out-of-band requests first
        timeout = cfg.ack_timeout_s
        for key, req in list(self._oob.items()):
            due = req.next_try_s(timeout)
            if now >= due or due != due:  # due, or never written (nan)
                if not isinstance(req.msg, EStop | CountersRequest) or req.tries > cfg.max_retries:
                    del self._oob[key]
                    self._finish(req, Outcome.FAILED, now)
                else:
                    self._transmit(req)
        hello = self._hello
        if hello is not None and now >= hello.next_try_s(timeout):
            if hello.tries >= HELLO_TRIES:
                self._hello = None
                self._finish(hello, Outcome.FAILED, now)
                self._lost = True
                self._fail_all(now)
                raise LinkLost(
                    f"the bridge did not answer a new session's HELLO ({hello.tries} tries)"
                )
            self._transmit(hello)
        ordered = self._ordered
        if ordered is not None and now >= ordered.next_try_s(timeout):
            if ordered.tries > cfg.max_retries:
                self._ordered = None
                self._finish(ordered, Outcome.FAILED, now)
            else:
                self._transmit(ordered)
        if self._ordered is None and self._hello is None:
            if ((self._next_seq - self._answered) & 0xFFFF) >= SESSION_RENEW_GAP:
                self._start_session(now, "the bridge has answered no ordered request for long")
            elif self._queue:
                self._ordered = self._queue.popleft()
                self._transmit(self._ordered)
        # Keep-alive, independent of what is in flight: a retried request whose frames
        # are lost must not hold heartbeats back, and any frame feeds the watchdog.
        if now - self._last_sent_s >= cfg.heartbeat_period_s and now < self._feed_until_s:
            hb = Request(
                Heartbeat(self._useq()),
                now,  # pragma: no mutate (an internal request's time: nothing reads it)
            )
            self._oob[(MsgType.HEARTBEAT, hb.seq)] = hb
            self.heartbeats_sent += 1
            self._transmit(hb)
        # the next time anything above can be due (a conservative bound: acks only delay it)
        # (an earlier bound only costs a poll that finds nothing to do; an oob request is
        # always written when it is made, so its next try is never nan)
        due = self._last_sent_s + cfg.heartbeat_period_s  # pragma: no mutate (a bound)
        for req in self._oob.values():
            next_s = req.next_try_s(timeout)
            due = min(due, now if next_s != next_s else next_s)  # pragma: no mutate (a bound)
        for pending in (self._ordered, self._hello):
            if pending is not None:
                due = min(due, pending.next_try_s(timeout))
        self._due_s = due
