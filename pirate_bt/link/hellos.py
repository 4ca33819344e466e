"""What the session does with a ``HELLO_REPLY`` and a bridge reset (docs/protocol.md,
Sessions and Boot and bridge reset).

:class:`HelloMixin` holds the part of the receive side that starts, checks and ends
sessions: the reply to a mid-session ``HELLO`` (its layout, minor, flags and boot id), a
reply no ``HELLO`` in flight asked for, and a bridge reset seen in a frame with
``NO_SESSION``. :class:`~pirate_bt.link.inbound.InboundMixin` builds on it (split from
``inbound`` with behaviour unchanged).
"""

from __future__ import annotations

import dataclasses
import logging

from pirate_bt.errors import LinkError, ProtocolMismatch
from pirate_bt.link.codec import BridgeFlags, FrameCodec, Hello, HelloReply
from pirate_bt.link.requests import Outcome, Request, SessionConfig

__all__ = ["STALE_RESETS_BEFORE_MISMATCH", "HelloMixin"]

_log = logging.getLogger("pirate_bt.link.session")
_NO_SESSION = int(BridgeFlags.NO_SESSION)
_LATCH_BITS = int(BridgeFlags.ESTOP | BridgeFlags.ESTOP_INPUT)
_INPUT_ONLY = int(BridgeFlags.ESTOP_INPUT)
STALE_RESETS_BEFORE_MISMATCH = 3
"""New sessions in a row started by a ``NO_SESSION`` frame whose ``HELLO_REPLY`` showed the
same boot id (no ``STATE`` without ``NO_SESSION`` between them) before the session ends on
a protocol mismatch. One or two are boot frames a reordering link delivered late; more is
a bridge that answers ``HELLO`` but never leaves ``NO_SESSION``."""


class HelloMixin:
    """Sessions started, checked and ended from the bridge's frames (mixed into
    :class:`~pirate_bt.link.session.Session` through
    :class:`~pirate_bt.link.inbound.InboundMixin`)."""

    # set by the session
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
        if item.layout_digest != layout.digest:
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
            _log.warning(
                "a stale NO_SESSION frame (reordered link?) started a new session;"
                " the bridge was not reset (boot id %d unchanged)",
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
        self._other_session_said = False
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
        A session of the host's own puts the filter ahead of them."""
        previous = self.last_hello_reply
        if (
            self._hello is not None
            or previous is None
            or item.boot_id != previous.boot_id
            or item.sessions == previous.sessions
            or item.layout_digest != self.codec.layout.digest
        ):
            return
        self.last_hello_reply = dataclasses.replace(previous, sessions=item.sessions)
        _log.error(
            "the bridge started session %d for HELLO seq %d, which the host did not send now"
            " (a replayed or late frame): its duplicate filter went back to that seq",
            item.sessions,
            item.seq,
        )
        self._start_session(now, "the bridge took a HELLO the host did not send now")

    def _bridge_reset(self, now: float) -> None:
        if self._hello is not None:
            return  # a new session is already on its way
        self.bridge_resets += 1
        previous = self.last_hello_reply
        self._reset_boot_id = None if previous is None else previous.boot_id
        _log.error("the bridge was reset (NO_SESSION): in-flight requests failed")
        self._start_session(now, "the bridge was reset")
