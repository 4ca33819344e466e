"""The link under faults, probed from the user docs (docs/protocol.md, docs/safety.md),
at the seams with its neighbours: what a link on a real port (a reader thread) tells the
protective layer, and what it does with bytes no frame should contain.

Each test pins a bug a user saw, fixed here.
"""

from __future__ import annotations

import dataclasses
import math
import re

import pytest
from session_wire import CODEC, CONFIG, LAYOUT, ROBOT, Wire, reply

import pirate_bt
from pirate_bt.clock import Clock, WallClock
from pirate_bt.errors import FrameError
from pirate_bt.link import opening
from pirate_bt.link.codec import (
    Ack,
    BridgeFlags,
    FrameDecoder,
    Heartbeat,
    Hello,
    MsgType,
    State,
)
from pirate_bt.link.framing import cobs_decode
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.link.testing import MemoryLink, memory_pair
from pirate_bt.link.transport import ByteLink

ZERO = tuple(c.conversion.zero_raw for c in ROBOT.state_channels())


class _LatchedBridge:
    """The far end of an in-memory line, answering as it is written to (no thread of its
    own): a HELLO with the reply of a bridge latched in an earlier session (sessions 2),
    a heartbeat with its ACK; nothing else."""

    def __init__(self) -> None:
        self.host, self._far = memory_pair()
        self._decoder = FrameDecoder(CODEC)
        write = self.host.write

        def write_and_answer(data: bytes) -> None:
            write(data)
            self._answer()

        self.host.write = write_and_answer  # type: ignore[method-assign]

    def _answer(self) -> None:
        for msg in self._decoder.feed(self._far.read_available()):
            if isinstance(msg, FrameError):
                continue
            if isinstance(msg, Hello):
                latched = reply(msg.seq, flags=BridgeFlags.ESTOP, sessions=2)
                self._far.write(CODEC.encode(latched))
            elif isinstance(msg, Heartbeat):
                self._far.write(CODEC.encode(Ack(msg.seq, MsgType.HEARTBEAT)))

    @property
    def link(self) -> MemoryLink:
        return self.host


def test_a_link_with_a_reader_thread_says_why_the_latch_was_kept() -> None:
    """docs/protocol.md (Boot and bridge reset): a latch the link finds at connect and
    keeps is *reported as a latched e-stop that says why*: ``LinkHealth.latch_kept``, which
    the supervisor's cause names (*the bridge reports its e-stop latched: latched in an
    earlier session (reset it)*). A link driven by a reader thread (every real port, and
    socket:// on a wall clock) built its health without it: on the robot the cause was only
    *the bridge reports its e-stop latched*, the reason left out."""
    bridge = _LatchedBridge()
    link = wrap_link(bridge.link, ROBOT, WallClock(), config=CONFIG, threaded=True)
    try:
        assert link.session.threaded
        assert link.latch_kept == "latched in an earlier session (reset it)"
        health = link.health()
        assert health.estopped
        assert health.latch_kept == "latched in an earlier session (reset it)"
    finally:
        link.session.close()


# -- a line that repeats the held STATE ------------------------------------------------------


class _Repeater:
    """A line that, from ``after_s`` of clock time on, delivers none of the bridge's bytes
    but the last STATE frame it passed, again and again, one a state period (a serial
    adapter or relay stuck re-sending its buffer). The host's bytes go through."""

    def __init__(self, inner: ByteLink, _spec: object, clock: Clock, after_s: float = 2.0) -> None:
        self.inner, self.clock = inner, clock
        self._after_s = clock.now() + after_s
        self._pending = b""
        self._state = b""
        self._next_s = math.inf

    @property
    def baud(self) -> int:
        return self.inner.baud

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def read_available(self) -> bytes:
        data, now = self.inner.read_available(), self.clock.now()
        if now < self._after_s:
            *frames, self._pending = (self._pending + data).split(b"\x00")
            for frame in frames:
                if frame and cobs_decode(frame)[1] == MsgType.STATE:
                    self._state = frame + b"\x00"
            return data
        copies = 0
        self._next_s = min(self._next_s, now)
        while self._next_s <= now:
            self._next_s += ROBOT.bridge.state_period
            copies += 1
        return self._state * copies

    def drain_input(self) -> int:
        return self.inner.drain_input()

    def close(self) -> None:
        self.inner.close()


def test_a_line_that_repeats_the_held_state_is_not_taken_for_a_resync() -> None:
    """A `STATE` frame repeated on the line (the very frame the host holds, the same seq)
    is dropped as not newer; after ten in a row over an ack timeout the host "resynchronised"
    on it (*10 STATEs in a row not newer than seq 196: resynchronised on seq 196*), as if
    the held frame were a damaged one from the future, stamped it as just arrived and
    forgot the frames it had refused, again every eleven frames."""
    wire = Wire(hello=reply())
    link = RobotLink(ROBOT, wire.session)
    frame = State(
        5, BridgeFlags.NONE, 0, (1 << LAYOUT.n_channels) - 1, (1,) * LAYOUT.n_boards, ZERO
    )
    wire.answer(frame)
    wire.poll(0.01)
    arrived = wire.session.latest_state()
    assert arrived is not None
    for _ in range(40):  # 0.4 s of the same frame, one a state period
        wire.answer(frame)
        wire.poll(0.01)
    assert wire.session.latest_state() == arrived  # not taken again, nor re-stamped
    assert link.health().states_refused == (("out of sequence", 40),)
    wire.answer(dataclasses.replace(frame, seq=6))  # a new one is taken at once
    wire.poll(0.01)
    assert link.state() is not None and link.health().states_refused == ()


def test_a_run_on_a_line_that_repeats_the_held_state_says_so(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The run then stopped on *link_silent: no state frame from the bridge for 0.150 s
    (the last frame heard, 0.000 s ago, held no state)*: the resync had cleared the count
    of refused frames, and the why said the frames heard held no state, where each held
    the same old one."""
    monkeypatch.setattr(opening, "FaultyLink", _Repeater)  # the line, for faults= below
    result = pirate_bt.simulate_tree(
        "straight", network="straight", params={"distance": "1.5 m"}, faults="delay=1us"
    )
    assert result.status == "failure"
    said = re.match(
        r"link_silent: no state frame taken for 0\.150 s: STATE frames arrived but all (\d+)"
        r" were refused \((\d+) out of sequence\), so its readings are stale: ",
        result.why,
    )
    assert said is not None and said[1] == said[2], result.why
