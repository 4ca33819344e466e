"""Link findings of probe 12 (a fake bridge and a fake host written from docs/protocol.md),
each pinned by a test that failed before its fix.

1. A bridge answering the release of its boot latch ``ACK STALE`` (at once, not applied)
   ended the connect with *did not acknowledge the release ... within 0.238 s (stale;
   round trip too long?)*: a timeout that never happened. The cause line now says what
   the bridge answered.
"""

from __future__ import annotations

import pytest
from session_wire import CONFIG, Peer

from pirate_bt.errors import LinkError, LinkTimeout
from pirate_bt.link.codec import Ack, AckStatus, EStopReset, Heartbeat, Message
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
