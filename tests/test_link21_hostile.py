"""Session 21: bytes no frame should contain, sent by a hostile bridge to the host.

The session on a simulated clock (tests/session_wire.py), the bridge played by the test;
docs/protocol.md, Bad frames and Timing.
"""

from __future__ import annotations

import re

import pytest
from session_wire import CODEC, Wire, reply, state

from pirate_bt.errors import LinkLost


@pytest.mark.parametrize("same_read", [True, False], ids=["with-a-good-frame", "alone"])
def test_a_bridge_silent_mid_frame_is_named_by_the_bytes_it_sent(same_read: bool) -> None:
    """A frame cut off, then silence: the lost link names the bytes that made no frame,
    whatever reads they came in. When they came in the read of the last good frame it
    said *nothing heard from the bridge*, as for a silent line."""
    wire = Wire(hello=reply(sessions=1))
    wire.answer(state(1))
    wire.poll(0.01)
    cut = CODEC.encode(state(3))[:20]
    if same_read:
        wire.far.write(CODEC.encode(state(2)) + cut)
    else:
        wire.answer(state(2))
        wire.poll(0.01)
        wire.far.write(cut)
    wire.poll(0.01)
    assert re.fullmatch(r"20 bytes that made no frame", wire.session.stats().line_noise)
    with pytest.raises(LinkLost) as caught:
        for _ in range(100):
            wire.poll(0.01)
    assert re.fullmatch(
        r"no good frame from the bridge for 0\.5\d\d s: 20 bytes that made no frame",
        str(caught.value),
    ), str(caught.value)
