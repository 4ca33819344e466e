"""The session over ``loop://``: the line hands every written byte back.

Over a loop the session hears its own frames. They travel host -> bridge, so the
session must never take them for the bridge's answers; and a bridge that only
ever echoes is no bridge: connecting fails in bounded time. The test plays the
bridge by writing bridge frames into the loop, which hands them to the session.
"""

from __future__ import annotations

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkTimeout
from pirate_bt.link import open_link
from pirate_bt.link.codec import BoardStatus, BridgeFlags, FrameCodec, State
from pirate_bt.link.session import Session
from pirate_bt.link.transport import Transport
from pirate_bt.robot import load_robot

ROBOT = load_robot()


def _state(codec: FrameCodec, seq: int, raw: int) -> bytes:
    n = len(ROBOT.state_channels())
    return codec.encode(
        State(
            seq=seq,
            flags=BridgeFlags.NONE,
            ack_seq=0,
            fresh_mask=(1 << n) - 1,
            board_status=tuple(BoardStatus(0) for _ in ROBOT.board_ids()),
            raw_values=tuple(raw for _ in range(n)),
        )
    )


def test_connecting_to_an_echo_fails_in_bounded_time() -> None:
    clock = SimClock()
    with pytest.raises(LinkTimeout, match="did not answer HELLO") as info:
        open_link("loop://", ROBOT, clock)
    assert isinstance(info.value, TimeoutError)
    assert clock.now() < 2.0  # simulated seconds: bounded retries, then give up


def test_session_takes_bridge_frames_and_ignores_its_own_echo() -> None:
    clock = SimClock()
    transport = Transport.open("loop://", baud=ROBOT.bridge.baud)
    codec = FrameCodec.for_robot(ROBOT)
    session = Session(transport, codec, clock)
    try:
        transport.port.write(_state(codec, seq=10, raw=100))
        session.poll()
        latest = session.latest_state()
        assert latest is not None and latest[0].seq == 10
        assert latest[0].raw_values[0] == 100

        # Silence makes the session send a heartbeat; the loop echoes it back, and the
        # session counts it as a frame nobody should send it, not as an answer.
        assert session.unexpected == 0
        clock.advance(0.2)
        session.poll()
        clock.advance(0.001)
        session.poll()
        assert session.unexpected >= 1
        latest = session.latest_state()
        assert latest is not None and latest[0].seq == 10

        # A replayed (out-of-date) state frame is ignored and counted.
        before = session.stats().duplicates
        transport.port.write(_state(codec, seq=9, raw=555))
        session.poll()
        latest = session.latest_state()
        assert latest is not None and latest[0].raw_values[0] == 100
        assert session.stats().duplicates == before + 1

        # A corrupted frame is rejected and counted, never accepted.
        bad = bytearray(_state(codec, seq=11, raw=777))
        bad[5] ^= 0x40
        errors = session.stats().crc_errors
        transport.port.write(bytes(bad))
        session.poll()
        latest = session.latest_state()
        assert latest is not None and latest[0].seq == 10
        assert session.stats().crc_errors == errors + 1
    finally:
        session.close()
