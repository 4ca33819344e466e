"""Findings of an independent wire-protocol probe (docs/protocol.md), each fixed in the link.

1. A ``COUNTERS_REQUEST`` that fails (a reply for another number of boards, or lost on
   every try) is that request's own outcome. It made the next ``RobotLink.send`` raise
   (*1 earlier request(s) failed; last: CountersRequest ...*) before the setpoints went
   out, so a diagnostic read failed the next tree command, and ``close()`` sent no stop
   bulk but latched the bridge's e-stop instead.
2. docs/simulator.md called the simulated bridge a protocol 1.1 bridge; it answers a 1.2
   ``HELLO`` with a 1.2 ``HELLO_REPLY`` (and a 1.1 one with 1.1), as protocol.md says a
   1.2 bridge does, and has the hardware e-stop input 1.2 reports.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from session_wire import CODEC, LAYOUT, ROBOT, Peer

from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BoardCounters,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    MsgType,
)
from pirate_bt.link.requests import Outcome
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.robot import ControlMode, MotorCommand
from pirate_bt.sim import Simulator


def bridge_with_counters_of(n_boards: int) -> Callable[[Message], list[Message]]:
    """Acknowledges heartbeats, bulks and e-stops; answers COUNTERS for ``n_boards``."""

    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, Heartbeat):
            return [Ack(msg.seq, MsgType.HEARTBEAT, AckStatus.APPLIED)]
        if isinstance(msg, BulkSetpoints):
            return [Ack(msg.seq, MsgType.BULK_SETPOINTS, AckStatus.APPLIED)]
        if isinstance(msg, EStop):
            return [Ack(msg.seq, MsgType.ESTOP, AckStatus.APPLIED)]
        if isinstance(msg, CountersRequest):
            boards = tuple(BoardCounters(20 + i) for i in range(n_boards))
            return [Counters(msg.seq, 1, boards=boards)]
        return []

    return answer


def drive_stop() -> list[MotorCommand]:
    return [MotorCommand(m.name, ControlMode.VELOCITY, 0.0) for m in ROBOT.drive_motors()]


def test_a_failed_counters_request_does_not_fail_the_next_setpoints() -> None:
    peer = Peer(bridge_with_counters_of(2))  # a COUNTERS for 2 boards: a bad frame
    link = RobotLink(ROBOT, peer.session())
    ask = link.session.wait(link.session.request_counters())
    assert ask.outcome is Outcome.FAILED and ask.reply is None  # its own outcome
    link.send_and_wait(drive_stop())  # raised "... last: CountersRequest ..." before
    assert isinstance(peer.seen[-1], BulkSetpoints)  # and the setpoints went out
    link.close()


def test_a_close_after_a_failed_counters_request_stops_without_an_estop() -> None:
    peer = Peer(bridge_with_counters_of(2))
    link = RobotLink(ROBOT, peer.session())
    link.session.wait(link.session.request_counters())
    link.close()
    sent = [type(m) for m in peer.seen if not isinstance(m, Heartbeat | CountersRequest)]
    assert sent == [BulkSetpoints]  # the drives' stop, acknowledged; no e-stop latched
    assert not link.session.stats().estopped


def test_counters_of_the_layout_are_still_taken() -> None:
    peer = Peer(bridge_with_counters_of(LAYOUT.n_boards))
    link = RobotLink(ROBOT, peer.session())
    ask = link.session.wait(link.session.request_counters())
    assert ask.outcome is Outcome.ACKED and ask.reply is not None
    link.close()


SIMULATOR_MD = Path(__file__).resolve().parents[1] / "docs" / "simulator.md"


def test_simulator_md_names_the_protocol_the_simulated_bridge_speaks() -> None:
    spoken = []
    with Simulator("lab", ROBOT) as sim:
        for seq, minor in ((1, 2), (2, 1)):
            sim.bridge.receive(CODEC.encode(Hello(seq, LAYOUT.digest, minor)))
            answers = FrameDecoder(CODEC).feed(sim.bridge.read())
            spoken += [m.minor for m in answers if isinstance(m, HelloReply)]
    assert spoken == [2, 1]  # a 1.2 bridge, which speaks 1.1 to a host that asks for it
    text = " ".join(SIMULATOR_MD.read_text().split())
    said = re.search(r"reference bridge of `docs/protocol.md` \(protocol ([0-9.]+)", text)
    assert said is not None and said.group(1) == "1.2"  # it said 1.1
    assert "set_estop_input" in text


def test_a_link_lost_right_after_an_ack_is_still_a_silent_link() -> None:
    """3. A bridge that falls silent ends as ``link_silent``, exit 3 (safety.md), whatever
    its last frame was: when an ACK came after the last STATE, the supervisor compared
    the readings' age with the time since *any* frame and called the same silence
    *stale data*, exit 1 (4 of 11 loss times over 28 ms)."""
    import contextlib
    import io

    from pirate_bt.cli import main

    tree = str(Path(__file__).resolve().parent.parent / "trees" / "straight.yaml")
    outcomes = []
    for ms in range(5000, 5030, 3):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(
                ["run", tree, "--param", "distance=0.5 m", "--sim", "straight", "--quiet",
                 "--faults", f"link_loss@{ms / 1000:.3f}s"]
            )  # fmt: skip
        outcomes.append((ms, code, err.getvalue().strip().splitlines()[-1]))
    assert all(code == 3 for _, code, _ in outcomes), outcomes
    assert all("FAILURE - link_silent: " in line for _, _, line in outcomes), outcomes
    assert any("no state frame from the bridge" in line for _, _, line in outcomes)
