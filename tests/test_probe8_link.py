"""Probe of the wire protocol's host side as another implementation would drive it.

Each test is a case a hostile or merely different peer produces, found by probing, with
the fix it needed (docs/protocol.md).
"""

from __future__ import annotations

from session_wire import CODEC, reply, state

from pirate_bt.clock import SimClock
from pirate_bt.link.codec import BridgeFlags, FrameCodec, FrameDecoder, Hello
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.testing import memory_pair
from pirate_bt.robot import load_robot

ROBOT = load_robot()


def _connect_to(answer: bytes, then: bytes) -> tuple[SimClock, object]:
    """A host connected to a bridge that answers the HELLO with ``answer`` and, one
    step later, writes ``then``."""
    clock = SimClock()
    host, far = memory_pair()
    decoder = FrameDecoder(CODEC)
    pending: list[bytes] = []

    def bridge(_now: float) -> None:
        if pending:
            far.write(pending.pop())
        for msg in decoder.feed(far.read_available()):
            if isinstance(msg, Hello):
                far.write(CODEC.encode(reply(msg.seq)) + answer)
                pending.append(then)

    clock.add_listener(bridge)
    return clock, wrap_link(host, ROBOT, clock)


def test_a_frame_split_across_the_end_of_the_handshake_is_not_a_bad_frame() -> None:
    # The HELLO_REPLY and the first half of a STATE arrive in one read, the rest of the
    # STATE in the next (on a real line nearly every time): the handshake's decoder
    # kept the half and the session's new one counted the rest as a bad frame.
    frame = FrameCodec.for_robot(ROBOT).encode(state(5, flags=BridgeFlags.NONE))
    clock, link = _connect_to(frame[:20], frame[20:])
    for _ in range(3):
        clock.advance(0.005)
        link.poll()  # type: ignore[attr-defined]
    assert link.health().crc_errors == 0  # type: ignore[attr-defined]
    latest = link.session.latest_state()  # type: ignore[attr-defined]
    assert latest is not None and latest[0].seq == 5  # and the STATE was taken
