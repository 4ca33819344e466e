"""Session 21: a hostile bridge at connect that answers with another seq than asked is
named for that, not for a silence or a slow line (docs/protocol.md, Versions and Boot)."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from session_wire import CODEC, ROBOT, reply, state

from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkTimeout
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    EStopReset,
    FrameDecoder,
    Heartbeat,
    Hello,
    Message,
    MsgType,
)
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.testing import memory_pair


def _bridge(clock: SimClock, far: object, answer: Callable[[Message], list[Message]]) -> None:
    """A bridge on ``far`` that answers each host frame with ``answer(msg)`` and sends a
    STATE every 10 ms."""
    decoder = FrameDecoder(CODEC)
    n = [0]

    def step(_now: float) -> None:
        out: list[Message] = []
        for msg in decoder.feed(far.read_available()):  # type: ignore[attr-defined]
            if not isinstance(msg, Exception):
                out += answer(msg)
        n[0] += 1
        out.append(state(n[0], flags=BridgeFlags.ESTOP))
        far.write(b"".join(CODEC.encode(m) for m in out))  # type: ignore[attr-defined]

    clock.add_listener(step)


def test_a_hello_answered_with_another_seq_is_named_so() -> None:
    """*it sent 16 HELLO_REPLY, 96 STATE but never answered*: it did answer, each time
    with another seq than the HELLO's."""
    clock = SimClock()
    host, far = memory_pair()

    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, Hello):
            return [reply(msg.seq + 5, flags=BridgeFlags.ESTOP)]
        return []

    _bridge(clock, far, answer)
    with pytest.raises(LinkTimeout) as caught:
        wrap_link(host, ROBOT, clock)
    said = str(caught.value)
    assert said.startswith("the bridge did not answer HELLO (16 tries): it sent 16 HELLO_REPLY")
    assert "16 HELLO_REPLY (each to seq 6, not the HELLO's seq 1)" in said, said


def test_a_boot_latch_release_answered_with_another_seq_is_not_a_slow_line() -> None:
    """*did not acknowledge the release of its boot latch within 0.238 s (failed; round
    trip too long?)*: the bridge answered every try at once, with the next seq."""
    clock = SimClock()
    host, far = memory_pair()

    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, Hello):
            return [reply(msg.seq, flags=BridgeFlags.ESTOP)]
        if isinstance(msg, EStopReset):
            return [Ack(msg.seq + 1, MsgType.ESTOP_RESET, AckStatus.APPLIED)]
        if isinstance(msg, Heartbeat):
            return [Ack(msg.seq, MsgType.HEARTBEAT, AckStatus.APPLIED)]
        return []

    _bridge(clock, far, answer)
    with pytest.raises(LinkTimeout) as caught:
        wrap_link(host, ROBOT, clock)
    said = str(caught.value)
    assert said.startswith("the bridge did not acknowledge the release of its boot latch"), said
    assert "round trip too long" not in said, said
    assert said.endswith(
        "answers meanwhile to requests the host never made (another seq or type than any"
        " asked: does it follow the protocol?))"
    ), said
