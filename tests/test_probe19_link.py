"""The link under faults, probed from the user docs (docs/protocol.md, docs/safety.md),
at the seams with its neighbours: what a link on a real port (a reader thread) tells the
protective layer, and what it does with bytes no frame should contain.

Each test pins a bug a user saw, fixed here.
"""

from __future__ import annotations

from session_wire import CODEC, CONFIG, ROBOT, reply

from pirate_bt.clock import WallClock
from pirate_bt.errors import FrameError
from pirate_bt.link.codec import Ack, BridgeFlags, FrameDecoder, Heartbeat, Hello, MsgType
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.testing import MemoryLink, memory_pair


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
