"""What the session does with a ``HELLO_REPLY`` and a bridge reset (docs/protocol.md,
Sessions and Boot and bridge reset).

:class:`HelloMixin` holds the part of the receive side that starts, checks and ends
sessions: the reply to a mid-session ``HELLO`` (its layout, minor, flags and boot id), a
reply no ``HELLO`` in flight asked for, and a bridge reset seen in a frame with
``NO_SESSION``. :class:`~pirate_bt.link.inbound.InboundMixin` builds on it (split from
``inbound`` with behaviour unchanged).
"""

from __future__ import annotations

import collections
import dataclasses
import logging
import math
from typing import TYPE_CHECKING

from pirate_bt.errors import LinkError, ProtocolMismatch
from pirate_bt.link.codec import BridgeFlags, FrameCodec, Hello, HelloReply
from pirate_bt.link.framing import frame_time_s
from pirate_bt.link.requests import Outcome, Request, SessionConfig

if TYPE_CHECKING:
    from pirate_bt.link.transport import ByteLink

__all__ = [
    "SESSIONS_CHURN_LIMIT",
    "STALE_RESETS_BEFORE_MISMATCH",
    "STALE_RESETS_CHURN_LIMIT",
    "HelloMixin",
    "reply_problem",
]

_log = logging.getLogger("pirate_bt.link.session")
_NO_SESSION = int(BridgeFlags.NO_SESSION)
_LATCH_BITS = int(BridgeFlags.ESTOP | BridgeFlags.ESTOP_INPUT)
_INPUT_ONLY = int(BridgeFlags.ESTOP_INPUT)
STALE_RESETS_BEFORE_MISMATCH = 3
"""New sessions in a row started by a ``NO_SESSION`` frame whose ``HELLO_REPLY`` showed the
same boot id (no ``STATE`` without ``NO_SESSION`` between them) before the session ends on
a protocol mismatch. One or two are boot frames a reordering link delivered late; more is
a bridge that answers ``HELLO`` but never leaves ``NO_SESSION``."""
SESSIONS_CHURN_LIMIT = 4
"""Sessions that replies (``HELLO_REPLY``) the host did not ask for may start within the link
timeout before the session ends on a protocol mismatch: each makes the bridge apply its
stop category. A replayed ``HELLO`` or a late retry of the host's own makes one or two;
one every period is a bridge that does not follow the protocol, or frames forged on the
line."""
STALE_RESETS_CHURN_LIMIT = 16
"""Sessions that stale ``NO_SESSION`` frames (the reply showing the boot unchanged) may
start within ten link timeouts, whatever came between them, before the session ends on a
protocol mismatch (:data:`STALE_RESETS_BEFORE_MISMATCH` counts those in a row). A
reordering link delivers late only the boot frames sent before the first ``HELLO``, a
few; a bridge that sends ``NO_SESSION`` between good ``STATE`` frames every period restarted
the session every period for as long as a run went on (before 2026-11-30)."""
_HEARTBEAT_FRAME_BYTES = 9
"""A HEARTBEAT on the wire: COBS, header, CRC and delimiter (docs/protocol.md)."""


def reply_problem(reply: HelloReply, baud: int) -> str | None:
    """Why the host cannot take ``reply``, a ``HELLO_REPLY`` to its own ``HELLO`` (the
    connect's or a new session's), or ``None``; checked after the layout, the minor and
    the flags:

    - a watchdog its own line cannot keep fed: the host heartbeats ten times a watchdog
      period (docs/protocol.md, Timing), and half the line is the most heartbeats may
      take (a bridge saying 1 ms had the host heartbeat every 0.1 ms, and trip all the
      same); 0 is a bridge that does not say;
    - a session count of 0: the count includes the session the ``HELLO`` started, and
      the host releases a latch it finds on the first session only.

    Before 2026-11-30 the connect took both; until 2026-11-30 a new session's reply in
    the middle of a connection did.
    """
    if reply.watchdog_ms > 0:
        frame_ms = 1000 * frame_time_s(_HEARTBEAT_FRAME_BYTES, baud)
        least_ms = math.ceil(2 * 10 * frame_ms)
        if reply.watchdog_ms < least_ms:
            return (
                f"the bridge's watchdog is {reply.watchdog_ms} ms, shorter than its line can"
                f" keep fed (ten heartbeats a period, each {frame_ms:.2f} ms at {baud} baud:"
                f" at least {least_ms} ms); a firmware built for another robot description?"
            )
    if reply.sessions < 1:
        return (
            f"the bridge's HELLO_REPLY counts {reply.sessions} sessions since boot: the count"
            " includes the session it starts, so it is at least 1 (a bridge that does not"
            " follow the protocol)"
        )
    return None


class HelloMixin:
    """Sessions started, checked and ended from the bridge's frames (mixed into
    :class:`~pirate_bt.link.session.Session` through
    :class:`~pirate_bt.link.inbound.InboundMixin`)."""

    # set by the session
    link: ByteLink
    codec: FrameCodec
    config: SessionConfig
    last_hello_reply: HelloReply | None
    duplicates: int
    sessions: int
    bridge_resets: int
    _last_heard_s: float
    _hello: Request | None
    _answered: int
    _flags: BridgeFlags
    _protocol_error: LinkError | None
    _accept_any_state: bool
    # the boot id when a NO_SESSION frame started a new session, until its reply
    _reset_boot_id: int | None = None
    # the frame that showed that reset, for the log when it was a stale one
    _reset_seen: str = "NO_SESSION frame"
    # when the bridge's frames last started a session that was not its own reset, by kind
    _churn: dict[str, collections.deque[float]] | None = None
    # sessions in a row a stale NO_SESSION frame started (see _on_hello_reply)
    _stale_reset_run: int = 0
    # the seq of the HELLO that started the session
    _session_hello: int = 0
    # the session's HELLO_REPLY shows the boot of the session before: STATE seqs run on
    _same_boot: bool = False
    # a STATE of another session was refused (and logged) since the last HELLO_REPLY
    _other_session_said: bool = False

    # the rest of the session
    def _finish(self, req: Request, outcome: Outcome, now: float) -> None:
        raise NotImplementedError

    def _settle(self, req: Request, outcome: Outcome, now: float) -> None:
        raise NotImplementedError

    def _service(self, now: float) -> None:
        raise NotImplementedError

    def _transmit(self, req: Request) -> None:
        raise NotImplementedError

    def _start_session(self, now: float, why: str) -> None:
        raise NotImplementedError

    def _input_unlatched(self, flags: BridgeFlags) -> None:
        raise NotImplementedError

    def _refused_session(self, hello: Request, why: str) -> None:
        self._hello = None  # pragma: no mutate (refused: every call raises before reading it)
        self._finish(hello, Outcome.NACKED, self._last_heard_s)
        self._protocol_error = ProtocolMismatch(why)
        _log.error(why)

    def _on_hello_reply(self, item: HelloReply, now: float) -> None:
        hello = self._hello
        if hello is None or item.seq != hello.seq:
            self.duplicates += 1
            self._unasked_session(item, now)
            return
        layout = self.codec.layout
        assert isinstance(hello.msg, Hello)  # a new session's request is always a HELLO
        asked = hello.msg.minor
        if (
            item.layout_digest != layout.digest
            or item.n_channels != layout.n_channels
            or item.n_motors != layout.n_motors
        ):  # the counts too, as the connect checks them (until 2026-11-30 not here)
            self._refused_session(hello, "the bridge answered a new session with another layout")
            return
        if item.minor != asked:
            self._refused_session(
                hello,
                f"the bridge answered a new session with protocol 1.{item.minor}; the host"
                f" asked for 1.{asked} (same layout)",
            )
            return
        if int(item.flags) & _NO_SESSION:  # the reply's flags are those after the HELLO
            self._refused_session(
                hello,
                "the bridge answered HELLO with NO_SESSION still set: it took no session"
                " (a bridge that does not follow the protocol)",
            )
            return
        problem = reply_problem(item, self.link.baud)
        if problem is not None:  # as the connect's (docs/protocol.md, Payloads and Timing)
            self._refused_session(hello, problem)
            return
        previous = self.last_hello_reply
        reset_from, self._reset_boot_id = self._reset_boot_id, None
        if previous is not None and previous.boot_id != item.boot_id:
            _log.warning("the bridge was reset (boot id %d -> %d)", previous.boot_id, item.boot_id)
        elif reset_from == item.boot_id:
            # The same boot: the NO_SESSION frame was stale, a boot STATE sent before the
            # bridge took the first HELLO and delivered after its reply (a reordering
            # link). Not a reset: not counted. What it failed stays failed.
            self.bridge_resets -= 1
            self._stale_reset_run += 1
            if self._stale_reset_run >= STALE_RESETS_BEFORE_MISMATCH:
                self._refused_session(
                    hello,
                    f"the bridge took {self._stale_reset_run} HELLOs in a row without a reset"
                    f" (boot id {item.boot_id} unchanged) but sent NO_SESSION after each:"
                    " it never keeps a session (a bridge that does not follow the protocol)",
                )
                return
            seen = (
                "NO_SESSION frames of a boot it is still in"
                if self._reset_seen.startswith("NO_SESSION")
                else "stale HELLO_REPLYs of another boot"
            )
            if self._churned(now, seen, STALE_RESETS_CHURN_LIMIT, 10):
                self._refused_session(hello, str(self._protocol_error))
                return
            _log.warning(
                "a stale %s (reordered link?) started a new session;"
                " the bridge was not reset (boot id %d unchanged)",
                self._reset_seen,
                item.boot_id,
            )
        self.last_hello_reply = item
        self.config = self.config.heeding(item.watchdog_ms)  # a new bridge may differ
        self._flags = item.flags
        if int(item.flags) & _LATCH_BITS == _INPUT_ONLY:
            self._input_unlatched(item.flags)
        self._hello = None
        self._answered = item.seq
        self._accept_any_state = True
        self._session_hello = item.seq
        self._same_boot = previous is not None and previous.boot_id == item.boot_id
        self._other_session_said = False  # pragma: no mutate (None is falsy as False is)
        self.sessions += 1
        self._settle(hello, Outcome.ACKED, now)
        if item.flags & BridgeFlags.ESTOP:
            _log.warning("new session: the bridge's e-stop is latched (reset it to move)")
        self._service(now)

    def _unasked_session(self, item: HelloReply, now: float) -> None:
        """A ``HELLO_REPLY`` no ``HELLO`` in flight asked for: a doubled reply (the same
        session count) is only counted; one of the same boot with another session count
        answered a ``HELLO`` that restarted the session under the host (a replayed frame,
        or a late retry of the host's own): the bridge applied its stop category and moved
        its duplicate filter back to that old seq, so old frames would be applied again.
        A session of the host's own puts the filter ahead of them. One that counts no
        session at all says the bridge holds none: the host's session is lost. One of
        another boot says the bridge was reset and took a ``HELLO`` since (not the
        host's): a bridge reset, as a ``NO_SESSION`` frame shows one (until 2026-11-30 it
        was only counted, and the new boot's ``STATE`` frames, numbered from 1 again,
        were refused as out of sequence until the run ended on *link_silent*)."""
        if item.sessions < 1:
            self._session_lost(item)
            return
        previous = self.last_hello_reply
        if (
            self._hello is None
            and previous is not None
            and item.boot_id != previous.boot_id
            and item.layout_digest == self.codec.layout.digest
        ):
            self._bridge_reset(
                now,
                f"HELLO_REPLY of boot id {item.boot_id}, not {previous.boot_id}, that the"
                " host did not ask for",
            )
            return
        if (
            self._hello is not None
            or previous is None
            or item.boot_id != previous.boot_id
            or item.sessions == previous.sessions
            or item.layout_digest != self.codec.layout.digest
        ):
            return
        self.last_hello_reply = dataclasses.replace(previous, sessions=item.sessions)
        if self._churned(now, "HELLO_REPLYs the host did not ask for", SESSIONS_CHURN_LIMIT, 1):
            return
        _log.error(
            "the bridge started session %d for HELLO seq %d, which the host did not send now"
            " (a replayed or late frame): its duplicate filter went back to that seq",
            item.sessions,
            item.seq,
        )
        self._start_session(now, "the bridge took a HELLO the host did not send now")

    def _bridge_reset(self, now: float, seen: str = "") -> None:
        """A bridge reset, seen in a ``NO_SESSION`` frame or in ``seen`` (a reply of
        another boot): counted, what was in flight failed, and a new session of the
        host's own (whose reply's boot id tells a stale frame from a reset)."""
        if self._hello is not None:
            return  # a new session is already on its way
        self.bridge_resets += 1
        previous = self.last_hello_reply
        self._reset_boot_id = None if previous is None else previous.boot_id
        self._reset_seen = seen or "NO_SESSION frame"
        _log.error("the bridge was reset (%s): in-flight requests failed", seen or "NO_SESSION")
        self._start_session(now, "the bridge was reset")

    def _session_lost(self, item: HelloReply) -> None:
        """A ``HELLO_REPLY`` no ``HELLO`` in flight asked for that counts 0 sessions since
        boot: the bridge says it holds no session while the host is in one, so the session
        the host started is not the bridge's (a bridge that rebooted, or one that does not
        follow the protocol, which counts the session a ``HELLO`` starts). A link error:
        the session ends (exit 3), and the close's stop falls back to the e-stop, which a
        bridge takes in any state. Until 2026-11-30 such a reply restarted the session."""
        if self._protocol_error is not None:
            return
        why = (
            f"the bridge sent a HELLO_REPLY (seq {item.seq}) that counts {item.sessions}"
            " sessions since boot, in the middle of the host's session (started by HELLO seq"
            f" {self._session_hello}): the bridge holds no session, so the host's is lost"
            " (the bridge rebooted, or does not follow the protocol)"
        )
        self._protocol_error = ProtocolMismatch(why)
        _log.error(why)

    def _churned(self, now: float, what: str, limit: int, timeouts: int) -> bool:
        """Note a session the bridge's frames (``what``) started that was not its own
        reset; when ``limit`` of that kind came within ``timeouts`` link timeouts, end the
        session (a protocol mismatch) and say so. Before 2026-11-30 a frame that restarted
        the session every period did so for as long as a run went on."""
        if self._churn is None:
            self._churn = {}
        churn = self._churn.setdefault(what, collections.deque(maxlen=limit))
        churn.append(now)
        window = timeouts * self.config.link_timeout_s
        if len(churn) < limit or now - churn[0] > window:
            return False
        if self._protocol_error is None:
            why = (
                f"the bridge's frames started {len(churn)} sessions within {window:g} s that"
                f" were not the bridge's own reset ({what}): each makes it stop its drives (a"
                " bridge that does not follow the protocol, or frames forged or replayed on"
                " the line)"
            )
            self._protocol_error = ProtocolMismatch(why)
            _log.error(why)
        return True
