"""An ESTOP the bridge refuses is no e-stop (session 22, brief C item 3).

docs/protocol.md, Checks: the bridge checks a frame's length before its type's action,
so an ``ESTOP`` carrying a stray byte (damaged past its CRC, or sent by a host of
another make) is answered ``NACK BAD_LENGTH`` and does not latch: a frame that fails
its checks is not a command (firmware/piratebay/protocol.c does the same). The host
took the ``NACK`` as the e-stop's outcome and did nothing more: the supervisor believed
the robot latched while the bridge drove on. A refused ``ESTOP`` is now sent again at
once (the same frame, as a lost copy is); one refused or unanswered on every try, with
no latch in the bridge's STATEs, ends the run in the safe state (the drives stopped by
a setpoint), its cause naming the refusal.
"""

from __future__ import annotations

from session_wire import LAYOUT, ROBOT, Wire, reply

from pirate_bt.link.closing import EStopNotTaken
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BulkSetpoints,
    EStop,
    MsgType,
    Nack,
    NackCode,
    State,
)
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.link.session import Outcome
from pirate_bt.robot import ControlMode
from pirate_bt.safety.operator import Mode
from pirate_bt.safety.supervisor import Supervisor


def _state(seq: int, flags: BridgeFlags = BridgeFlags.NONE) -> State:
    every = (1 << LAYOUT.n_channels) - 1
    return State(seq, flags, 0, every, (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels)


def test_an_estop_the_bridge_refuses_once_is_sent_again_and_latches() -> None:
    wire = Wire(hello=reply(sessions=1))
    wire.answer(_state(1))
    wire.poll(0.01)
    req = wire.session.estop()
    sent = [m for m in wire.sent() if isinstance(m, EStop)]
    assert [m.seq for m in sent] == [req.seq]
    wire.answer(Nack(req.seq, int(MsgType.ESTOP), NackCode.BAD_LENGTH))
    wire.poll(0.001)
    # was: no second copy; the request ended NACKED and the bridge never latched
    again = [m for m in wire.sent() if isinstance(m, EStop)]
    assert [m.seq for m in again] == [req.seq]  # the same frame, at once
    assert not req.done
    wire.answer(Ack(req.seq, int(MsgType.ESTOP), AckStatus.APPLIED))
    wire.poll(0.001)
    assert req.outcome is Outcome.ACKED
    assert wire.session.stats().estopped
    assert wire.session.take_estop_not_taken() is None


def test_an_estop_refused_on_every_try_stops_the_drives_and_says_so() -> None:
    wire = Wire(hello=reply(sessions=1))
    link = RobotLink(ROBOT, wire.session)
    wire.answer(_state(1))
    wire.poll(0.01)
    sup = Supervisor(link, wire.clock)
    sup.tick()
    wire.sent()
    sup.estop("operator stop")
    seq = 2
    refused = 0
    bulks: list[BulkSetpoints] = []
    for i in range(200):
        for msg in wire.sent():
            if isinstance(msg, EStop):  # a bridge that takes none of them
                refused += 1
                wire.answer(Nack(msg.seq, int(MsgType.ESTOP), NackCode.BAD_LENGTH))
            elif isinstance(msg, BulkSetpoints):
                bulks.append(msg)
        wire.answer(_state(seq))  # no ESTOP flag: the bridge did not latch
        seq += 1
        wire.clock.advance(0.01)
        if i % 5 == 4:
            sup.tick()
        if sup.in_safe_state and bulks:
            break
    # was: one ESTOP, NACKed; no safe state, no stop: the drives went on
    assert refused == wire.session.config.max_retries + 1
    why = sup.safe_state_reason
    assert why is not None and "\n" not in why
    assert why.startswith("e-stop not latched: the bridge did not latch the e-stop"), why
    assert "NACK BAD_LENGTH" in why and "no command" in why, why
    assert isinstance(sup.safe_state_error, EStopNotTaken)  # a link error: exit 3
    assert sup.mode is Mode.ESTOP  # still refusing every command
    drives = {
        i
        for i, slot in enumerate(ROBOT.setpoint_slots())
        if slot.motor.name in {m.name for m in ROBOT.drive_motors()}
    }
    stop = bulks[-1]
    assert all(stop.modes[i] is ControlMode.VELOCITY and stop.raw_values[i] == 0 for i in drives)


def test_an_estop_whose_answers_are_lost_but_latched_is_not_said_not_taken() -> None:
    wire = Wire(hello=reply(sessions=1))
    link = RobotLink(ROBOT, wire.session)
    wire.answer(_state(1))
    wire.poll(0.01)
    sup = Supervisor(link, wire.clock)
    sup.tick()
    sup.estop("operator stop")
    for seq in range(2, 60):  # no ACK ever comes, but the STATEs show the latch
        wire.answer(_state(seq, BridgeFlags.ESTOP))
        wire.clock.advance(0.01)
        if seq % 5 == 0:
            sup.tick()
    assert not sup.in_safe_state, sup.safe_state_reason
    assert sup.mode is Mode.ESTOP


def test_an_estop_answered_stale_with_no_latch_stops_the_drives_and_says_so() -> None:
    """docs/protocol.md: an ESTOP latches whatever its seq, and is answered ACK APPLIED.
    A bridge that answered it STALE (not applied) and showed no latch was taken as
    latched too (found probing: the same hole as a NACK)."""
    wire = Wire(hello=reply(sessions=1))
    link = RobotLink(ROBOT, wire.session)
    wire.answer(_state(1))
    wire.poll(0.01)
    sup = Supervisor(link, wire.clock)
    sup.tick()
    wire.sent()
    sup.estop("operator stop")
    for seq in range(2, 40):
        for msg in wire.sent():
            if isinstance(msg, EStop):
                wire.answer(Ack(msg.seq, int(MsgType.ESTOP), AckStatus.STALE))
        wire.answer(_state(seq))
        wire.clock.advance(0.01)
        if seq % 5 == 0:
            sup.tick()
        if sup.in_safe_state:
            break
    why = sup.safe_state_reason
    assert why is not None
    assert why.startswith("e-stop not latched: the bridge did not latch the e-stop"), why
    assert "answered it STALE, not applied" in why, why
    assert sup.mode is Mode.ESTOP


def _after_an_acked_estop(shown: list[bool]) -> Supervisor:
    """A supervisor whose bridge acknowledges the e-stop and then sends STATEs with the
    ``ESTOP`` flag as ``shown`` says, one every 10 ms, the supervisor ticking every 50."""
    wire = Wire(hello=reply(sessions=1))
    link = RobotLink(ROBOT, wire.session)
    wire.answer(_state(1))
    wire.poll(0.01)
    sup = Supervisor(link, wire.clock)
    sup.tick()
    wire.sent()
    sup.estop("operator stop")
    for seq, latched in enumerate(shown, start=2):
        for msg in wire.sent():
            if isinstance(msg, EStop):
                wire.answer(Ack(msg.seq, int(MsgType.ESTOP), AckStatus.APPLIED))
        wire.answer(_state(seq, BridgeFlags.ESTOP if latched else BridgeFlags.NONE))
        wire.clock.advance(0.01)
        if seq % 5 == 0:
            sup.tick()
        if sup.in_safe_state:
            break
    return sup


def test_an_estop_acknowledged_but_never_shown_latched_stops_the_drives() -> None:
    """A bridge that answers ACK APPLIED to the e-stop and drives on (docs/protocol.md:
    an ESTOP latches at once, and every STATE after shows it). Found probing."""
    sup = _after_an_acked_estop([False] * 30)
    why = sup.safe_state_reason
    assert why is not None
    assert why.startswith("e-stop not latched: the bridge did not latch the e-stop"), why
    assert "acknowledged it (ACK APPLIED), but the STATEs it sent since show no latch" in why
    assert sup.mode is Mode.ESTOP


def test_an_estop_shown_latched_a_state_late_is_taken() -> None:
    # one STATE sent before the bridge read the ESTOP, delivered after its ACK
    sup = _after_an_acked_estop([False, True] + [True] * 28)
    assert not sup.in_safe_state, sup.safe_state_reason
    assert sup.mode is Mode.ESTOP
