"""What the session does with each frame the bridge sends (docs/protocol.md, host rules).

:class:`InboundMixin` holds the receive side of :class:`~pirate_bt.link.session.Session`:
answers matched to their request by type and seq (``ACK STALE`` is a failure, never
an acknowledgement), a bulk setpoint acknowledged only by a ``STATE`` whose
``ack_seq`` equals its seq, a new session's ``HELLO_REPLY``, and a bridge reset seen
in a ``STATE`` with ``NO_SESSION``. The send side, the retries and the heartbeats
stay in the session.
"""

from __future__ import annotations

import collections
import logging
import math
import threading

from pirate_bt.errors import FrameError, ProtocolMismatch
from pirate_bt.link.away import away_since
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BadCrc,
    BoardStatus,
    BridgeFlags,
    BridgeHeartbeat,
    BulkSetpoints,
    Counters,
    FrameCodec,
    FrameDecoder,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    OtherVersion,
    State,
    StateLengthError,
    UnknownAckStatus,
    seq_newer,
)
from pirate_bt.link.hellos import STALE_RESETS_BEFORE_MISMATCH, HelloMixin
from pirate_bt.link.noise import LineNoise
from pirate_bt.link.requests import Outcome, Request, SessionConfig

__all__ = [
    "BAD_STATES_BEFORE_MISMATCH",
    "LATCHED_STATES_AFTER_RELEASE",
    "STALE_RESETS_BEFORE_MISMATCH",
    "STATES_KEPT",
    "STATE_REFUSALS",
    "InboundMixin",
    "unasked_text",
]

_log = logging.getLogger("pirate_bt.link.session")
_NO_SESSION = int(BridgeFlags.NO_SESSION)
_FAULT = int(BoardStatus.FAULT)
_STATE = int(MsgType.STATE)
_LATCH_BITS = int(BridgeFlags.ESTOP | BridgeFlags.ESTOP_INPUT)
_ESTOP = int(BridgeFlags.ESTOP)
_INPUT_ONLY = int(BridgeFlags.ESTOP_INPUT)
_NO_REFUSALS = (0, 0, 0, 0)
_UNTRACKED = frozenset({int(MsgType.HEARTBEAT), int(MsgType.COUNTERS_REQUEST)})
_ORDERED_TYPES = frozenset(
    int(t)
    for t in (
        MsgType.HELLO,
        MsgType.SETPOINT,
        MsgType.BULK_SETPOINTS,
        MsgType.ESTOP,
        MsgType.ESTOP_RESET,
    )
)
STATE_REFUSALS = (
    "with a bad CRC",
    "of another length",
    "out of sequence",
    "of another protocol version",
)
"""Why a ``STATE`` frame was not taken, in the order of :meth:`InboundMixin.refused_states`
(a bad CRC is the frame's own, unchecked, type byte saying ``STATE``)."""
OLD_STATES_BEFORE_RESYNC = 10
"""STATEs dropped in a row as not newer than the held one before the next is taken."""
LATCHED_STATES_AFTER_RELEASE = 2
"""``STATE`` frames after an acknowledged ``ESTOP_RESET`` whose ``ESTOP`` flag is not
believed while no ``STATE`` without it came between: on a line that reorders (a relay, a
link with jitter) they were sent before the release and delivered after its ``ACK``. The
next one is believed (a latch the bridge took again at once, 30 ms late: its own latch
holds meanwhile, and it refuses setpoints ``ESTOP_LATCHED``)."""
ESTOP_UNSHOWN_STATES = 3
"""``STATE`` frames in a row without ``ESTOP`` after an ``ESTOP`` the bridge acknowledged
(no ``ESTOP_RESET`` acknowledged since) before the session takes it as not latched
(:meth:`~pirate_bt.link.session.Session.take_estop_not_taken`): a bridge that answers
``ACK APPLIED`` and drives on (docs/protocol.md: an ``ESTOP`` latches at once). One or
two could have been sent before the ``ESTOP`` was read and delivered after its ``ACK``."""
UNMATCHED_KEPT = 64
"""Answers to requests the host never made whose arrival the session keeps
(:meth:`InboundMixin.answers_unasked_since`)."""
STATES_KEPT = 64
"""STATE frames taken that the session keeps, newest last (:meth:`InboundMixin.states_taken`):
a reader of the state folds those it has not seen, so that a reading fresh in one of them
only is not lost (640 ms at a 10 ms state period)."""
BAD_STATES_BEFORE_MISMATCH = 3
"""STATE frames in a row (no good STATE between) whose CRC is good but whose length is
not the layout's before the session ends on a protocol mismatch. One could be line
noise that passed the CRC (about 1 in 65 536 damaged frames); three in a row is a
bridge built for another layout."""


def unasked_text(n: int) -> str:
    """``n`` answers to requests never made, for a failure's words (after *the bridge*)."""
    return (
        f"sent {n} answer{'s' * (n != 1)} meanwhile to requests the host never made (another"
        " seq or type than any asked: does it follow the protocol?)"
    )


class InboundMixin(HelloMixin):
    """The receive side of a session (mixed into :class:`~pirate_bt.link.session.Session`);
    the frames that start and end sessions in :class:`~pirate_bt.link.hellos.HelloMixin`."""

    # set by the session
    codec: FrameCodec
    config: SessionConfig
    rtt_samples: collections.deque[float]
    crc_errors: int
    duplicates: int
    unexpected: int
    _last_heard_s: float
    _noise: LineNoise
    # the arrival of the last answers (ACK, NACK) to requests the host never made
    _unmatched: collections.deque[float]
    _next_useq: int
    _decoder: FrameDecoder
    _oob: dict[tuple[int, int], Request]
    _ordered: Request | None
    _queue: collections.deque[Request]
    _lock: threading.RLock
    # the STATEs taken, with their arrival, newest last (see states_taken)
    _taken: collections.deque[tuple[State, float]] | None = None
    _stale_run: int
    _state: State | None
    _state_at_s: float
    _faulted: tuple[int, ...]
    _rtt_s: float
    # STATEs dropped in a row as not newer than the one held, and the first one's arrival
    # (see _on_state)
    _old_state_run: int = 0
    _latch_discount: int = 0  # STATEs still not believed on ESTOP, after a release
    # an acknowledged ESTOP no STATE has shown yet, and the STATEs since (ESTOP_UNSHOWN_STATES)
    _estop_unshown: Request | None = None
    _estop_unshown_run: int = 0
    _estop_not_taken: Request | None  # the session's (see Session.take_estop_not_taken)
    _old_run_from_s: float = 0.0
    # STATEs of another length in a row, since the last good one (see _bad_state)
    _bad_state_run: int = 0
    # STATE frames refused since the last one taken: bad CRC, another length, not newer
    _refused: tuple[int, ...] = _NO_REFUSALS
    # frames dropped unread since the last STATE taken, by reason, and how many: what the
    # refused STATE counts cannot name (see unreadable_since_state)
    _unreadable: collections.Counter[str] | None = None
    _unreadable_n: int = 0
    # the next ordered seq to send
    _next_seq: int
    # ESTOP_INPUT without ESTOP was seen (and logged) in this session
    _input_unlatched_seen: bool = False
    # (board position, arrival of the last STATE that showed it answering) for each board
    # the newest STATE reports in TIMEOUT (see boards_away)
    _away_since: tuple[tuple[int, float], ...] = ()

    def _estop_input(self, flags: BridgeFlags) -> bool:
        """``ESTOP_INPUT`` in ``flags``, read in a 1.2 session only (in 1.1 bits 4-7 are
        0, whatever a bridge sends)."""
        return self.config.protocol_minor >= 2 and bool(flags & BridgeFlags.ESTOP_INPUT)

    def _estopped(self, flags: BridgeFlags) -> bool:
        """The e-stop taken as latched: ``ESTOP``, or ``ESTOP_INPUT`` without it (which
        docs/protocol.md rules out: the input latches the e-stop, so the safe side)."""
        return bool(flags & BridgeFlags.ESTOP) or self._estop_input(flags)

    @property
    def latch_reported(self) -> bool:
        """The bridge's own ``ESTOP`` flag (not inferred from ``ESTOP_INPUT``): whether an
        ``ESTOP`` would change anything."""
        return bool(self._flags & BridgeFlags.ESTOP)

    def states_taken(self) -> tuple[tuple[State, float], ...]:
        """The last :data:`STATES_KEPT` ``STATE`` frames taken, oldest first, each with the
        clock time it arrived."""
        with self._lock:
            return () if self._taken is None else tuple(self._taken)

    def refused_states(self) -> tuple[int, ...]:
        """``STATE`` frames refused since the last one taken (or the session's start), by
        reason (:data:`STATE_REFUSALS`): a bad CRC, another length, not newer than the
        one held, another protocol version."""
        return self._refused

    def unreadable_since_state(self) -> str:
        """The frames that came since the last ``STATE`` taken (or the session's start)
        and could not be read, and are not among :meth:`refused_states` (a frame cut or
        damaged before its type could be trusted: ``cobs``, ``crc``, ``oversize``, ...),
        for people: ``"15 unreadable frames (cobs 12, crc 3)"``, ``""`` when none came.
        Unlike :meth:`line_noise`, a good frame that is no ``STATE`` (an ``ACK``, the
        bridge's heartbeat) does not start it again: a bridge that answers but whose
        STATEs all arrive garbled is told from one that sends none."""
        with self._lock:
            n, counts = self._unreadable_n, self._unreadable
            if not n or counts is None:
                return ""
            why = ", ".join(f"{reason} {k}" for reason, k in sorted(counts.items()))
            return f"{n} unreadable frame{'s' * (n != 1)} ({why})"

    def answers_unasked_since(self, since_s: float) -> int:
        """``ACK`` and ``NACK`` frames that answer a request the host never made (another
        seq or type than any it sent: not a late answer to one retried or given up),
        arrived at or after the clock time ``since_s`` (the last :data:`UNMATCHED_KEPT`)."""
        return sum(1 for at_s in tuple(self._unmatched) if at_s >= since_s)

    def _never_asked(self, kind: int, seq: int) -> bool:
        """Whether no request of type ``kind`` ever had ``seq``: a type the host never
        sends, or a seq its counter for that type has not reached (0 it never gives)."""
        if kind in _UNTRACKED:
            after = self._next_useq
        elif kind in _ORDERED_TYPES:
            after = self._next_seq
        else:
            return True
        return seq == 0 or seq_newer(seq, (after - 2) % 0xFFFF + 1)  # newer than the last

    def line_noise(self) -> str:
        """What came from the bridge since its last good frame that made no good frame
        (``""``: nothing), e.g. ``"204 unreadable frames (cobs 153, oversize 51) in 15963
        bytes"`` (:mod:`pirate_bt.link.noise`). A frame begun in the read of the last good
        frame and never ended (a bridge silent mid-frame) is named by its bytes, as when
        they came in a read of their own (before 2026-11-30: *nothing heard*)."""
        said = self._noise.text(self._last_heard_s)
        if said or not self._decoder.pending_bytes:
            return said
        return f"{self._decoder.pending_bytes} bytes that made no frame"

    def _input_unlatched(self, flags: BridgeFlags) -> None:
        """``flags`` has ``ESTOP_INPUT`` but not ``ESTOP``: say so, once a session."""
        if self._input_unlatched_seen or self.config.protocol_minor < 2:
            return
        self._input_unlatched_seen = True
        _log.error(
            "the bridge reports its hardware e-stop input (ESTOP_INPUT) without its e-stop"
            " latched (ESTOP), which the protocol rules out: taken as latched (flags %#04x)",
            int(flags),
        )

    def boards_away(self) -> tuple[tuple[int, float], ...]:
        """The boards the newest ``STATE`` reports in ``TIMEOUT``: for each, its position in
        the frame's board order and the arrival time of the last ``STATE`` that showed it
        answering (the newest fresh reading it can have: its readings' age is at least
        the time since), or of the first ``STATE`` heard if none did."""
        return self._away_since

    @property
    def pending_hello(self) -> Request | None:
        """The ``HELLO`` of a new session on its way, or ``None``."""
        return self._hello

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
            self._noise.note_frame(self._last_heard_s, item.reason)
            _log.debug("dropped frame: %s", item)
            if isinstance(item, StateLengthError):
                self._refuse_state(1)
                self._bad_state(item)
            elif isinstance(item, BadCrc | OtherVersion) and item.claimed_type == _STATE:
                self._refuse_state(0 if isinstance(item, BadCrc) else 3)
            elif isinstance(item, UnknownAckStatus):
                self._unknown_ack(item)
            else:  # no STATE refusal names it: counted till the next STATE taken
                if self._unreadable is None:
                    self._unreadable = collections.Counter()
                self._unreadable[item.reason] += 1
                self._unreadable_n += 1
            return
        if item.TYPE < 0x80:  # pragma: no mutate (no message type is 0x80)
            self.unexpected += 1  # our own frames (loop://) or a confused peer
            self._noise.note_echo(self._last_heard_s)
            return
        self._last_heard_s = now
        if isinstance(item, Ack | Nack):
            self._on_answer(item, now)
        elif isinstance(item, Counters):
            req = self._oob.pop((MsgType.COUNTERS_REQUEST, item.seq), None)
            if req is None:
                self.duplicates += 1
                return
            req.reply = item
            self._settle(req, Outcome.ACKED, now)
        elif isinstance(item, BridgeHeartbeat):
            self._flags = item.flags
            if int(item.flags) & _LATCH_BITS == _INPUT_ONLY:
                self._input_unlatched(item.flags)
            if item.flags & BridgeFlags.NO_SESSION:
                self._bridge_reset(now)
        elif isinstance(item, HelloReply):
            self._on_hello_reply(item, now)

    def _refuse_state(self, why: int) -> None:
        """Count a refused ``STATE`` frame, by its index in :data:`STATE_REFUSALS`."""
        counts = list(self._refused)
        counts[why] += 1
        self._refused = tuple(counts)

    def _bad_state(self, item: StateLengthError) -> None:
        """A STATE of another length: counted; :data:`BAD_STATES_BEFORE_MISMATCH` in a
        row (a good STATE ends a run) are a bridge of another layout, a link error."""
        self._bad_state_run += 1
        if self._bad_state_run >= BAD_STATES_BEFORE_MISMATCH and self._protocol_error is None:
            why = (
                f"the bridge sent {self._bad_state_run} STATE frames in a row of another"
                f" layout: a {item.received}-byte payload, the robot description's layout"
                f" needs {item.expected} bytes (a bridge built for another robot description?)"
            )
            self._protocol_error = ProtocolMismatch(why)
            _log.error(why)

    def _unknown_ack(self, item: UnknownAckStatus) -> None:
        """An ``ACK`` with a status (a ``NACK`` with a code) outside the protocol's table:
        when it answers a request in flight (its type and seq), the bridge speaks another
        protocol, a link error; else it is counted as a bad frame only (noise that passed
        the CRC). Before 2026-11-30 such a ``NACK`` was only counted: the request was sent
        again and failed as *not acknowledged*, though the bridge had answered it."""
        kind, seq = item.acked_type, item.seq
        ordered, hello = self._ordered, self._hello
        in_flight = (kind, seq) in self._oob or any(
            r is not None and r.seq == seq and kind == r.msg.TYPE for r in (ordered, hello)
        )
        if not in_flight or self._protocol_error is not None:
            return
        name = MsgType(kind).name
        table = (
            "ACK statuses are 0 APPLIED, 1 DUPLICATE and 2 STALE"
            if item.answer == "ACK"
            else f"NACK codes are 1 to {int(max(NackCode))}"
        )
        what = "status" if item.answer == "ACK" else "code"
        why = (
            f"the bridge answered {name} seq {seq} with an unknown {item.answer} {what}"
            f" {item.status}: a protocol mismatch (the protocol's {table})"
        )
        self._protocol_error = ProtocolMismatch(why)
        _log.error(why)

    def _on_answer(self, item: Ack | Nack, now: float) -> None:
        kind = item.acked_type
        ordered = self._ordered
        if ordered is not None and ordered.seq == item.seq and kind == ordered.msg.TYPE:
            self._ordered = None
            self._answered = item.seq
            if isinstance(item, Nack):
                ordered.nack = item.error
                outcome = Outcome.NACKED
            else:
                ordered.ack_status = item.status
                outcome = Outcome.STALE if item.status is AckStatus.STALE else Outcome.ACKED
                if outcome is Outcome.ACKED and kind == MsgType.ESTOP_RESET:
                    self._flags &= ~BridgeFlags.ESTOP  # released now; the next STATE says so too
                    self._latch_discount = LATCHED_STATES_AFTER_RELEASE
                    self._estop_unshown = None  # released: no STATE need show it now
            self._settle(ordered, outcome, now)
            if outcome is not Outcome.STALE:
                self._stale_run = 0
            else:
                # One STALE is an e-stop overtaking a request in flight. Two in a row mean
                # the bridge's duplicate filter is ahead of this host (a damaged frame
                # that passed the CRC with a far seq, say): every request would be
                # STALE until the counter caught up, so a HELLO resets the filter.
                self._stale_run += 1
                if self._stale_run >= 2 and self._hello is None:
                    self._stale_run = 0
                    self._start_session(now, "the bridge answered STALE twice in a row")
                    return
            if self._queue:  # the next queued request may go
                self._service(now)
            return
        hello = self._hello
        if (
            hello is not None
            and isinstance(item, Nack)
            and hello.seq == item.seq
            and kind == MsgType.HELLO
        ):
            self._refused_session(hello, f"the bridge refused a new session: {item.error.name}")
            return
        req = self._oob.pop((kind, item.seq), None)
        if req is None:
            self.duplicates += 1  # a late answer to a retried or given-up request
            if self._never_asked(kind, item.seq):  # or one with another seq or type
                self._unmatched.append(now)
            return
        if isinstance(item, Nack):
            req.nack = item.error
            if kind == MsgType.ESTOP and req.tries <= self.config.max_retries:
                # A frame that fails the bridge's checks is no command (docs/protocol.md,
                # Checks): it did not latch. Damaged past its CRC, or mangled on the way:
                # sent again at once, the same frame, as a lost copy is (it is applied
                # whatever its seq); after every try, the link says so (estop_not_taken)
                _log.warning(
                    "the bridge refused e-stop seq %d (NACK %s): not latched; sent again",
                    item.seq,
                    item.error.name,
                )
                self._oob[(kind, item.seq)] = req
                self._transmit(req)
                return
            self._settle(req, Outcome.NACKED, now)
        elif item.status is AckStatus.STALE:
            req.ack_status = item.status  # not applied: a failure, never an acknowledgement
            self._settle(req, Outcome.STALE, now)
        else:
            req.ack_status = item.status
            self._settle(req, Outcome.ACKED, now)
            if kind == MsgType.ESTOP:
                self._flags |= BridgeFlags.ESTOP
                self._latch_discount = 0  # the host's own e-stop: every STATE shows it
                self._estop_unshown, self._estop_unshown_run = req, 0
                if seq_newer(item.seq, self._answered):
                    self._answered = item.seq

    def _of_another_session(self, item: State) -> bool:
        """Whether ``item``, a ``STATE`` come before any of this session was taken, is one
        the bridge sent before it took the session's ``HELLO`` (delivered late or out of
        order, or left in a buffer): its ``ack_seq`` names a ``BULK_SETPOINTS`` the host did
        not send in this session, where a new session's is 0 until one of its own is
        applied (docs/protocol.md, Sessions). Such a frame is refused as out of sequence,
        counted, and logged once a session."""
        ack, hello = item.ack_seq, self._session_hello
        if not ack or (seq_newer(ack, hello) and not seq_newer(ack, self._next_seq - 1)):
            return False
        self.duplicates += 1
        self._refuse_state(2)
        if not self._other_session_said:
            self._other_session_said = True
            _log.warning(
                "STATE seq %d refused: it acknowledges BULK_SETPOINTS seq %d, which the host"
                " did not send in this session (started by HELLO seq %d): a frame of the"
                " session before, delivered late",
                item.seq,
                ack,
                hello,
            )
        return True

    def _on_state(self, item: State, now: float) -> None:
        last = self._state
        self._bad_state_run = 0
        bits = int(item.flags)  # int tests: IntFlag's own & builds a flag
        if bits & _NO_SESSION:
            self._flags = item.flags
            self._bridge_reset(now)
            return
        self._stale_reset_run = 0
        first = self._accept_any_state  # of the session: its seq is free after a reset
        if first:
            if self._hello is not None:
                return  # a state of the old session, before the new one's reply
            if self._of_another_session(item):
                return
        if (
            (not first or self._same_boot)
            and last is not None
            and not seq_newer(item.seq, last.seq)
        ):
            self._old_state_run += 1
            if self._old_state_run == 1:
                self._old_run_from_s = now
            # A bridge sends its STATEs a period apart: only refused frames that kept
            # coming for an ack timeout tell a far-ahead held frame. Old ones that come
            # in a burst (a relay that held back or replays a stretch of traffic) are
            # dropped however many: taking the eleventh made every later one "newer".
            # The held frame itself again (a relay or adapter that repeats it) is never
            # one to resynchronise on: taken, it hid that no new STATE came.
            if (
                self._old_state_run <= OLD_STATES_BEFORE_RESYNC
                or now - self._old_run_from_s < self.config.ack_timeout_s
                or item.seq == last.seq
            ):
                self.duplicates += 1
                self._refuse_state(2)
                return
            # So many in a row: the held STATE is the odd one (a damaged frame that
            # passed the CRC with a far seq, say), and every genuine STATE would be
            # dropped until the bridge's counter caught up with it. Take this one.
            _log.warning(
                "%d STATEs in a row not newer than seq %d: resynchronised on seq %d",
                self._old_state_run - 1,
                last.seq,
                item.seq,
            )
        self._accept_any_state = False  # pragma: no mutate (None is falsy as False is)
        self._old_state_run = 0
        self._refused = _NO_REFUSALS
        if self._unreadable_n:
            self._unreadable_n = 0
            if self._unreadable is not None:
                self._unreadable.clear()
        previous_s = self._state_at_s
        self._state = item
        self._state_at_s = now
        taken = self._taken
        if taken is None:
            taken = self._taken = collections.deque(maxlen=STATES_KEPT)
        taken.append((item, now))
        if self._latch_discount and bits & _ESTOP:
            # sent before the release its ACK acknowledged (a reordering line): the
            # latch it shows is gone, unless a later STATE still shows it
            self._latch_discount -= 1
            _log.debug("STATE seq %d: ESTOP from before the release, not taken", item.seq)
            self._flags = BridgeFlags(bits & ~_ESTOP)
        else:
            self._latch_discount = 0
            self._flags = item.flags
        if bits & _LATCH_BITS == _INPUT_ONLY:
            self._input_unlatched(item.flags)
        if self._estop_unshown is not None:  # an acknowledged ESTOP the STATEs must show
            self._estop_unshown_run = 0 if bits & _ESTOP else self._estop_unshown_run + 1
            if bits & _ESTOP:
                self._estop_unshown = None
            elif self._estop_unshown_run >= ESTOP_UNSHOWN_STATES:
                self._estop_not_taken, self._estop_unshown = self._estop_unshown, None
        status = item.board_status
        if last is None or status != last.board_status:  # a tuple compare: one changed
            self._faulted = tuple(i for i, s in enumerate(status) if s & _FAULT)
            before = None if last is None else last.board_status
            self._away_since = away_since(self._away_since, status, before, previous_s, now)
        ordered = self._ordered
        if (
            ordered is not None
            and isinstance(ordered.msg, BulkSetpoints)
            and item.ack_seq == ordered.seq
        ):
            self._ordered = None
            self._answered = ordered.seq
            ordered.ack_status = AckStatus.APPLIED
            self._settle(ordered, Outcome.ACKED, now)
            self._service(now)
