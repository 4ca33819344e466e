"""A bridge that answers but whose STATEs arrive garbled is not a bridge that sends none
(session 22, brief C item 2).

The bridge's heartbeats (good frames) came, its STATEs did not: the run ended
*link_silent: no state frame from the bridge for 0.150 s (the last frame heard, 0.000 s
ago, held no state)*, the same words whether the line carried nothing or a STATE's worth
of unreadable bytes every 10 ms: the line's noise is counted since the last good frame,
and each heartbeat started it again. The unreadable frames since the last STATE taken
are named now.
"""

from __future__ import annotations

import pytest
from session_wire import CODEC, LAYOUT, ROBOT, Wire, reply

from pirate_bt.link.codec import BridgeFlags, BridgeHeartbeat, State
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.safety.supervisor import Supervisor


def _state(seq: int) -> State:
    """A STATE with every reading fresh."""
    every = (1 << LAYOUT.n_channels) - 1
    return State(seq, BridgeFlags.NONE, 0, every, (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels)


def _why_states_stopped(line: str) -> str:
    """The safe state's cause when, after one good STATE, the bridge sends its heartbeat
    every 50 ms and, every 10 ms, what ``line`` says instead of a STATE."""
    wire = Wire(hello=reply(sessions=1))
    link = RobotLink(ROBOT, wire.session)
    wire.answer(_state(1))
    wire.poll(0.01)
    sup = Supervisor(link, wire.clock)
    sup.tick()
    assert not sup.in_safe_state
    for i in range(100):
        frame = bytearray(CODEC.encode(_state(2 + i)))
        if line == "cut":  # a frame whose bytes were damaged: it does not decode
            frame[5] ^= 0xFF
            wire.far.write(bytes(frame))
        elif line == "crc":  # a STATE damaged in its CRC: known by its type
            frame[-3] ^= 0x01
            wire.far.write(bytes(frame))
        if i % 5 == 0:
            wire.answer(BridgeHeartbeat(100 + i))
        wire.clock.advance(0.01)
        if i % 5 == 4:
            sup.tick()
        if sup.in_safe_state:
            break
    why = sup.safe_state_reason
    assert why is not None and "\n" not in why
    assert sup.safe_state_error is not None  # a link error: exit 3
    return why


def test_garbled_states_between_heartbeats_are_named_in_the_link_silent_cause() -> None:
    why = _why_states_stopped("cut")
    assert why.startswith("link_silent: no state frame from the bridge for 0.1"), why
    # was: '... held no state), so its readings are stale: ...', nothing more
    assert "unreadable frames (" in why and "came since the last STATE taken" in why, why
    assert why.index("unreadable frames") < why.index("so its readings are stale")


def test_a_bridge_that_only_answers_is_still_said_to_send_no_state() -> None:
    why = _why_states_stopped("nothing")
    assert "held no state), so its readings are stale" in why, why
    assert "unreadable" not in why


@pytest.mark.parametrize("line", ["crc"])
def test_states_refused_for_their_crc_are_named_as_before(line: str) -> None:
    why = _why_states_stopped(line)
    assert why.startswith("link_silent: no state frame taken for 0.1"), why
    assert "were refused (" in why and "with a bad CRC" in why, why
    assert "unreadable" not in why  # the refused STATEs are not counted twice
