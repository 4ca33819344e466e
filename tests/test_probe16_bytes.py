"""Probe 16: bytes no frame should contain, from the bridge to the host's link.

1. A line flooded with bytes that make no good frame (a bridge at another baud rate,
   noise, a flood of 0xFF between frames) ended the link with *nothing heard from the
   bridge for 0.510 s*, as if the bridge were silent: 561 unreadable frames had come in
   those 0.5 s. The link's ``LinkLost`` now says what came instead (*no good frame from
   the bridge for 0.510 s: 561 unreadable frames (cobs 510, short 51) in 2346 bytes*),
   counted since the last good frame only; a silent line is still *nothing heard*.
"""

from __future__ import annotations

import pytest
from session_wire import CODEC, Wire, reply, state

from pirate_bt.errors import LinkLost
from pirate_bt.link.codec import Heartbeat

# -- 1. a flooded line is not a silent one -------------------------------------------------

_GARBAGE = b"\x11\x22\x33\x00" * 3 + b"\xff" * 300 + b"\x00"  # 3 cobs, 1 oversize


def _flood(wire: Wire, batch: bytes, polls: int = 60) -> LinkLost:
    with pytest.raises(LinkLost) as caught:
        for _ in range(polls):
            wire.far.write(batch)
            wire.poll(0.01)
    return caught.value


def test_a_flood_of_unreadable_frames_is_named_not_taken_for_silence() -> None:
    wire = Wire(hello=reply())
    wire.answer(state(1))
    wire.poll(0.01)
    text = str(_flood(wire, _GARBAGE))
    assert "nothing heard" not in text, text
    assert text.startswith("no good frame from the bridge for 0.5"), text
    # 51 batches of 4 unreadable frames each, by reason, and every byte of them
    assert "204 unreadable frames (cobs 153, oversize 51)" in text, text
    assert f"in {51 * len(_GARBAGE)} bytes" in text, text
    # the next call says the same, not "nothing heard"
    with pytest.raises(LinkLost, match=r"^no good frame from the bridge for over 0\.5 s: 204 "):
        wire.session.poll()


def test_bytes_with_no_delimiter_at_all_are_named() -> None:
    wire = Wire(hello=reply())
    text = str(_flood(wire, b"\x55" * 100))  # a bridge at another baud rate, say
    assert "nothing heard" not in text, text
    assert "bytes with no frame delimiter" in text or "oversize" in text, text


def test_the_hosts_own_frames_echoed_back_are_named_an_echo() -> None:
    wire = Wire(hello=reply())
    echo = CODEC.encode(Heartbeat(5))
    text = str(_flood(wire, echo))
    assert "of the host's own frames (an echo" in text, text


def test_garbage_before_the_last_good_frame_is_not_counted() -> None:
    wire = Wire(hello=reply())
    for _ in range(5):
        wire.far.write(_GARBAGE)
        wire.poll(0.01)
    wire.answer(state(1))  # a good frame: what came before it does not count
    wire.poll(0.01)
    with pytest.raises(LinkLost, match=r"^nothing heard from the bridge for 0\.5"):
        for _ in range(60):
            wire.poll(0.01)
