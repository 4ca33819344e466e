"""Session 21: a HELLO_REPLY in the middle of a session that counts 0 sessions, or names a
watchdog its line cannot keep fed, is checked as the connect's is (docs/protocol.md,
Payloads and Sessions)."""

from __future__ import annotations

import struct

import pytest
from cleanroom_peer import (
    BULK,
    ESTOP,
    HELLO_REPLY,
    STATE,
    Frame,
    PeerBridge,
    frame,
    hello_reply_payload,
    layout_of,
)
from session_wire import ROBOT, Wire, reply, state

from pirate_bt.errors import ProtocolMismatch
from pirate_bt.link.codec import BridgeFlags, Hello

LAYOUT = layout_of(ROBOT)


def _stopped(frames: list[Frame]) -> bool:
    """The host sent an ESTOP, or a bulk with every drive at velocity 0."""
    for f in frames:
        if f.kind == ESTOP:
            return True
        if f.kind == BULK:
            entries = [struct.unpack_from("<Bh", f.payload, 3 * i) for i in range(16)]
            drives = [e for e, m in zip(entries, LAYOUT.motors, strict=True) if m[2] == "drive"]
            if all(e == (3, 0) for e in drives):
                return True
    return False


def _session() -> Wire:
    wire = Wire(hello=reply(sessions=1))
    wire.answer(state(1))
    wire.poll(0.01)
    return wire


def test_an_unasked_hello_reply_counting_no_session_ends_the_session() -> None:
    """The bridge says it has held no session while the host is in one: the session the
    host started is not the bridge's (it rebooted, or does not follow the protocol)."""
    wire = _session()
    wire.answer(reply(seq=40, sessions=0))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(0.01)
    assert str(caught.value) == (
        "the bridge sent a HELLO_REPLY (seq 40) that counts 0 sessions since boot, in the"
        " middle of the host's session (started by HELLO seq 1): the bridge holds no session,"
        " so the host's is lost (the bridge rebooted, or does not follow the protocol)"
    )
    assert not [m for m in wire.sent() if isinstance(m, Hello)]  # no new session asked
    with pytest.raises(ProtocolMismatch):  # and it stays ended
        wire.session.ensure_alive()


def _mid_session_hello(wire: Wire) -> Hello:
    wire.answer(state(2, flags=BridgeFlags.NO_SESSION | BridgeFlags.ESTOP))  # a reset
    wire.poll(0.01)
    hellos = [m for m in wire.sent() if isinstance(m, Hello)]
    assert len(hellos) == 1
    return hellos[0]


def test_the_reply_to_a_mid_session_hello_counting_no_session_is_refused() -> None:
    wire = _session()
    hello = _mid_session_hello(wire)
    wire.answer(reply(seq=hello.seq, sessions=0, boot_id=8, flags=BridgeFlags.ESTOP))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(0.01)
    assert str(caught.value) == (
        "the bridge's HELLO_REPLY counts 0 sessions since boot: the count includes the session"
        " it starts, so it is at least 1 (a bridge that does not follow the protocol)"
    )
    assert wire.session.last_hello_reply is not None
    assert wire.session.last_hello_reply.boot_id == 7  # the reply was not taken


def test_the_reply_to_a_mid_session_hello_with_a_watchdog_too_short_is_refused() -> None:
    """At 1 ms the host would heartbeat every 0.1 ms, more than its line carries (as the
    connect refuses since 2026-11-30)."""
    wire = _session()
    hello = _mid_session_hello(wire)
    period_s = wire.session.config.heartbeat_period_s
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8, watchdog_ms=1))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(0.01)
    assert str(caught.value).startswith("the bridge's watchdog is 1 ms, shorter than its line")
    assert wire.session.config.heartbeat_period_s == period_s  # not one every 0.1 ms


@pytest.mark.xdist_group("real-time")
def test_a_run_whose_bridge_says_it_holds_no_session_ends_in_one_line_and_stops() -> None:
    """The page's bridge on TCP; after 0.3 s of good STATEs it sends a HELLO_REPLY no HELLO
    asked for, counting 0 sessions: exit 3, one line, the robot stopped."""
    import pirate_bt

    def hostile(n: int, peer: PeerBridge) -> bytes | None:
        if n <= 30 or not peer.session or peer.estopped:
            return None
        good = frame(STATE, n, LAYOUT.state_payload(ack_seq=peer.ack_seq, values=peer.values))
        lying = frame(HELLO_REPLY, 900 + n, hello_reply_payload(LAYOUT, sessions=0))
        return good + lying

    peer = PeerBridge(LAYOUT, state=hostile)
    try:
        result = pirate_bt.run_tree("straight", port=peer.url, params={"distance": "0.1 m"})
        assert result.exit_code == 3, result.why
        assert "counts 0 sessions since boot" in result.why, result.why
        assert "\n" not in result.why, result.why
        assert peer.wait_for(_stopped), [(f.kind, f.seq) for f in peer.received]
    finally:
        peer.close()
