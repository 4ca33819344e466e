"""Link findings of probe 12 (a fake bridge and a fake host written from docs/protocol.md),
each pinned by a test that failed before its fix.

1. A bridge answering the release of its boot latch ``ACK STALE`` (at once, not applied)
   ended the connect with *did not acknowledge the release ... within 0.238 s (stale;
   round trip too long?)*: a timeout that never happened. The cause line now says what
   the bridge answered.
2. A bridge that answered ``HELLO`` with ``NO_SESSION`` still set in its ``HELLO_REPLY``
   (and in every ``STATE``) had the host start a new session on every ``STATE``: 185
   ``HELLO`` in 5 s, four log lines each, and the run ended after 6 s on *no state from
   the robot within 5 s*. Such a reply is now refused (``ProtocolMismatch``, exit 3).
3. A bridge whose ``HELLO_REPLY`` was clean but whose every ``STATE`` after it said
   ``NO_SESSION`` (the same boot id each time) looped the same way and ended on
   *link_silent: no state frame ...*. The third such session in a row is now a protocol
   mismatch naming it; one or two (boot frames a reordering link delivered late) are not.
"""

from __future__ import annotations

import pytest
from session_wire import CONFIG, Peer, Wire, reply, state

from pirate_bt.errors import LinkError, LinkTimeout, ProtocolMismatch
from pirate_bt.link.codec import Ack, AckStatus, BridgeFlags, EStopReset, Heartbeat, Hello, Message
from pirate_bt.link.inbound import STALE_RESETS_BEFORE_MISMATCH
from pirate_bt.link.opening import _release_boot_latch


def _answer_reset(status: AckStatus | None) -> list[Message] | object:
    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, EStopReset) and status is not None:
            return [Ack(msg.seq, msg.TYPE, status)]
        if isinstance(msg, Heartbeat):  # the link stays heard
            return [Ack(msg.seq, msg.TYPE)]
        return []

    return answer


def test_a_release_answered_stale_is_named_stale_not_a_slow_round_trip() -> None:
    peer = Peer(_answer_reset(AckStatus.STALE))  # type: ignore[arg-type]
    session = peer.session()
    with pytest.raises(LinkError) as exc:
        _release_boot_latch(session, 7, CONFIG.give_up_s)
    assert not isinstance(exc.value, LinkTimeout)
    assert exc.value.exit_code == 3
    text = str(exc.value)
    assert "ACK STALE" in text and "round trip" not in text
    assert [type(m).__name__ for m in peer.seen] == ["EStopReset"]  # answered at once


def test_a_release_never_answered_is_still_a_link_timeout() -> None:
    peer = Peer(_answer_reset(None))  # type: ignore[arg-type]
    with pytest.raises(LinkTimeout, match="round trip too long"):
        _release_boot_latch(peer.session(), 7, CONFIG.give_up_s)


# -- 2. and 3. a bridge that never leaves NO_SESSION --------------------------------------------

_LATCHED = BridgeFlags.ESTOP


def _new_session_after_no_session(wire: Wire, seq: int, reply_flags: BridgeFlags) -> None:
    """A STATE with NO_SESSION, then the reply (same boot id 7) to the HELLO it causes."""
    wire.answer(state(seq, flags=BridgeFlags.NO_SESSION | _LATCHED))
    wire.poll(0.01)
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello)
    wire.answer(reply(seq=hello.seq, flags=reply_flags, sessions=2))
    wire.poll()


def test_a_hello_reply_with_no_session_set_is_a_protocol_mismatch() -> None:
    wire = Wire(hello=reply(flags=_LATCHED))
    with pytest.raises(ProtocolMismatch, match="answered HELLO with NO_SESSION still set") as exc:
        _new_session_after_no_session(wire, 3, BridgeFlags.NO_SESSION | _LATCHED)
        wire.poll(0.01)
    assert exc.value.exit_code == 3


def test_sessions_that_every_state_ends_with_no_session_are_a_protocol_mismatch() -> None:
    wire = Wire(hello=reply(flags=_LATCHED))
    with pytest.raises(ProtocolMismatch, match="3 HELLOs in a row without a reset") as exc:
        for i in range(STALE_RESETS_BEFORE_MISMATCH):
            _new_session_after_no_session(wire, 3 + i, _LATCHED)
        wire.poll(0.01)
    assert "boot id 7 unchanged" in str(exc.value)
    assert STALE_RESETS_BEFORE_MISMATCH == 3


def test_a_good_state_between_stale_no_session_frames_starts_the_count_again() -> None:
    wire = Wire(hello=reply(flags=_LATCHED))
    seq = 3
    for _ in range(2):
        for _ in range(STALE_RESETS_BEFORE_MISMATCH - 1):
            _new_session_after_no_session(wire, seq, _LATCHED)
            seq += 1
        wire.answer(state(seq, flags=_LATCHED))  # the bridge keeps this session
        wire.poll(0.01)
        seq += 1
    stats = wire.session.stats()
    assert (stats.connected, stats.bridge_resets) == (True, 0)
