"""The protective layer in its modes, probed from docs/safety.md and docs/protocol.md.

Each test pins a bug a user saw, fixed here.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator

import pytest
from session_wire import ROBOT, Peer
from test_probe18_link import _mismatch

import pirate_bt
from pirate_bt.api import Connection
from pirate_bt.errors import InputError, ProtocolMismatch
from pirate_bt.link.codec import Ack, AckStatus, EStop, Message, MsgType
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.robot import ControlMode, Half, MotorCommand
from pirate_bt.safety import Clamp, Drive, Outcome, Raw, Reason, Source, Tilt, operator
from pirate_bt.safety.checks import stale_channels
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.operator import Mode
from pirate_bt.safety.supervisor import Supervisor

# -- a protocol mismatch in the middle of a session ------------------------------------------


def _estop_acked(msg: Message) -> list[Message]:
    if isinstance(msg, EStop):
        return [Ack(msg.seq, MsgType.ESTOP, AckStatus.APPLIED)]
    return []


def test_a_protocol_mismatch_is_named_so_and_its_safe_state_sends_the_estop(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """After three STATE frames of another layout the supervisor's safe state said
    *link lost: the bridge sent 3 STATE frames ...* for a bridge that still hears the
    host, and its stop could not go out (*could not send the stop of ...*): nothing
    stopped the drives until the connection closed, or the bridge's watchdog. The
    cause is now a protocol mismatch (still a link error, exit 3), and the stop falls
    back to the e-stop, which the bridge takes whatever the layout (docs/protocol.md)."""
    peer = Peer(_estop_acked)
    link = RobotLink(ROBOT, peer.session())
    sup = Supervisor(link, peer.clock)
    _mismatch(peer)
    with caplog.at_level(logging.INFO, logger="pirate_bt.safety"):
        sup.tick()
    peer.clock.sleep(0.05)  # the bridge reads what the host wrote
    why = sup.safe_state_reason or ""
    assert why.startswith("protocol mismatch: the bridge sent 3 STATE frames"), why
    assert "link lost" not in why
    assert isinstance(sup.safe_state_error, ProtocolMismatch)
    assert any(isinstance(m, EStop) for m in peer.seen), peer.seen  # before any close
    said = [
        r.getMessage()
        for r in caplog.records
        if r.name == "pirate_bt.safety" and r.levelno >= logging.ERROR
    ]
    assert len(said) == 1 and said[0].endswith("; e-stop sent"), said
    sup.close()
    assert link.close_error is None


# -- a value beyond what a motor's mode can carry ---------------------------------------------


@pytest.fixture
def sim_robot() -> Iterator[Connection]:
    with pirate_bt.connect("sim:straight") as connection:
        connection.supervisor.tick()
        yield connection


@pytest.mark.parametrize(("value", "reaches"), [(1e308, 1.0), (150.0, 1.0), (-1.0, 0.0)])
def test_a_raw_pwm_beyond_its_raw_range_is_clipped_and_says_so(
    sim_robot: Connection, value: float, reaches: float
) -> None:
    """`supervisor.command(Raw(MotorCommand("front_leds", PWM, 1e308)))` raised
    *OverflowError: cannot convert float infinity to integer* out of the link's
    conversion, and 150 (15 000 %) or -1 *passed*, the verdict's `sent` showing the
    value while the link saturated it to the raw range unsaid. Such a value is now
    clipped to what the raw range carries, `raw_range`, the verdict saying so."""
    sup = sim_robot.supervisor
    verdict = sup.command(Raw(MotorCommand("front_leds", ControlMode.PWM, value)))
    assert verdict.outcome is Outcome.CLIP and verdict.reason is Reason.RAW_RANGE, verdict
    assert "front_leds: pwm" in verdict.detail and "its raw range" in verdict.detail
    (sent,) = verdict.sent
    assert sent.value == pytest.approx(reaches)


def test_a_raw_pwm_at_the_end_of_its_range_passes(sim_robot: Connection) -> None:
    """Full duty (1.0, which the raw range's 255 steps of 0.392 % round to) is in range."""
    verdict = sim_robot.supervisor.command(Raw(MotorCommand("front_leds", ControlMode.PWM, 1.0)))
    assert verdict.outcome is Outcome.PASS, verdict


# -- an e-stop reset the bridge refuses -------------------------------------------------------


def test_a_refused_estop_reset_says_which_board_keeps_it_latched() -> None:
    """With board 26 rebooting, `reset_estop()` returned false and said only *e-stop
    reset nacked NOT_READY*; the operator had to guess why. It now names what the host
    sees: the board whose every reading is stale, and before they go stale what the
    bridge's NOT_READY means."""
    with pirate_bt.connect("sim:straight", faults="board_reset:26@0.5s") as robot:
        sup, clock = robot.supervisor, robot.supervisor.clock
        sup.apply(operator.EStop())
        said = []
        for _ in range(8):
            clock.sleep(0.1)
            sup.tick()
            if clock.now() > 0.55:
                assert not sup.reset_estop() and sup.mode is Mode.ESTOP
                said.append(sup.estop_reset_refusal or "")
    assert said[0].startswith("e-stop reset nacked NOT_READY: the bridge cannot confirm")
    assert (
        said[-1] == "e-stop reset nacked NOT_READY: board 26 is not answering (every reading stale)"
    )


# -- a stop that could not reach a board away -------------------------------------------------


def test_a_drive_whose_board_was_away_at_the_stop_is_stopped_when_it_answers_again() -> None:
    """A drive at 30 mm/s, then board 26 reboots: the safe state (stale data) stops the
    other drives, bend_3_drive's stop is refused (its board away for good). When the
    board answered again 1.5 s later, the bridge handed it the setpoints it kept,
    0.03 m/s: bend_3_drive turned on, fresh readings and all, in the safe state, for as
    long as the connection stayed open. The supervisor now sends that stop again once
    the board answers."""
    sup = open_supervisor(network="straight", sim_faults=["board_reset:26@0.5s"])
    try:
        sup.tick()
        assert sup.command(Drive(0.03)).ok
        for _ in range(30):
            sup.clock.sleep(0.1)
            sup.tick()
        state = sup.state()
        assert state is not None and sup.in_safe_state
        assert not stale_channels(sup.robot, state, ["bend_3_drive.velocity"], sup.clock.now())
        assert state.drive_velocity_mps["bend_3_drive"] == pytest.approx(0.0, abs=1e-3)
    finally:
        sup.close()


# -- confirmations across an e-stop and a hand-over -------------------------------------------


class _Operator:
    """Confirms every step waiting, but for a while (from 4 s to 6 s) when it e-stops
    the robot, resets the e-stop and hands the robot back (supervised)."""

    releases = True

    def __init__(self, sup: Supervisor) -> None:
        self.sup = sup

    def poll(self, tick: int, now: float) -> list[operator.OperatorAction]:
        out: list[operator.OperatorAction] = []
        if not 4.0 <= now < 6.0:
            out += [operator.Confirm(step) for step in self.sup.pending_confirmations()]
        for at, action in (
            (4.0, operator.EStop()),
            (4.5, operator.ResetEStop()),
            (5.0, operator.SetMode(Mode.SUPERVISED)),
        ):
            if at <= now < at + 0.05:
                out.append(action)
        return out


def test_a_step_confirmed_before_an_estop_waits_again_after_its_reset() -> None:
    """Supervised, a drive confirmed and under way, an e-stop, its reset and the
    hand-back to supervised: the e-stop forgot the grant but kept its answer, so the
    drive's commands were refused `not_confirmed` while nothing waited for the operator
    to confirm: the run sat still to its time limit, its why blaming the e-stop. The
    steps confirmed before an e-stop now wait again, and the run goes on once the
    operator confirms."""
    with pirate_bt.connect("sim:straight", mode="supervised") as robot:
        robot.supervisor.add_input(_Operator(robot.supervisor))
        result = robot.run("straight", params={"distance": "0.5 m"}, max_time="30 s")
    assert result.status == "success", result.why


def test_confirmations_follow_the_estop_and_the_mode() -> None:
    sup = open_supervisor(network="straight", mode="supervised")
    try:
        sup.tick()
        assert sup.request_confirmation("drive").value == "pending"
        sup.confirm("drive")
        assert sup.check(Drive(0.03)).ok
        sup.apply(operator.EStop())
        assert sup.reset_estop()
        sup.set_mode(Mode.SUPERVISED)
        # the step waits again: the operator sees it, and its commands wait for him
        assert sup.pending_confirmations() == ["drive"]
        assert sup.request_confirmation("drive").value == "pending"
        assert sup.check(Drive(0.03)).reason is Reason.NOT_CONFIRMED
        assert sup.confirm() == "drive" and sup.check(Drive(0.03)).ok
        # a step waiting when the operator hands over to autonomous waits no more
        assert sup.request_confirmation("bend").value == "pending"
        sup.set_mode(Mode.AUTONOMOUS)
        assert sup.pending_confirmations() == []
        assert sup.request_confirmation("bend").value == "granted"
    finally:
        sup.close()


# -- the rate limits after an e-stop ----------------------------------------------------------


def test_the_first_drive_after_an_estop_reset_is_held_to_its_acceleration_limit() -> None:
    """Driving at 80 mm/s, an e-stop (the wheels stop), its reset: the operator's
    `Drive(0.1)` *passed* whole, the acceleration limit reckoned from the 0.08 m/s set
    before the e-stop, which the wheels no longer turned at (0.4 m/s² lets 0.04 m/s
    from standstill in 0.1 s). The e-stop's stop is now the drives' last setpoint."""
    sup = open_supervisor(network="straight")
    try:
        sup.tick()
        assert sup.command(Clamp(Half.REAR, 0.7)).ok
        for _ in range(15):
            sup.clock.sleep(0.1)
            sup.tick()
        for _ in range(5):
            sup.command(Drive(0.08))
            sup.clock.sleep(0.1)
            sup.tick()
        sup.apply(operator.EStop())
        for _ in range(5):
            sup.clock.sleep(0.1)
            sup.tick()
        assert sup.reset_estop() and sup.mode is Mode.MANUAL
        sup.clock.sleep(0.1)
        sup.tick()
        verdict = sup.command(Drive(0.1), source=Source.OPERATOR)
        assert verdict.reason is Reason.ACCELERATION_LIMIT, verdict
        assert "velocity change from 0 in 0.1 s" in verdict.detail
        assert all(mc.value == pytest.approx(0.04) for mc in verdict.sent)
    finally:
        sup.close()


# -- a confirmation of no step ----------------------------------------------------------------


def test_a_confirmation_of_no_step_is_bad_input(caplog: pytest.LogCaptureFixture) -> None:
    """`Deny([1])` from an operator input raised `TypeError: unhashable type: 'list'`
    out of the supervisor's tick (the run ended on it), and `Confirm(5)` granted a step
    no node can ask for. Both are refused as input, one line, nothing changed; the tick
    logs the input's error and goes on (docs/safety.md, *Operator authority*)."""
    scripted = operator.ScriptedOperator(at_tick=[(2, operator.Deny([1]))])  # type: ignore[arg-type]
    sup = open_supervisor(network="straight", mode="supervised", inputs=[scripted])
    try:
        with caplog.at_level(logging.ERROR, logger="pirate_bt.safety"):
            sup.tick()
            sup.tick()
        assert any("not a step: [1]" in r.getMessage() for r in caplog.records)
        with pytest.raises(InputError, match=r"^not a step: 5 \(a step's text"):
            sup.apply(operator.Confirm(5))  # type: ignore[arg-type]
        assert sup.request_confirmation("5").value == "pending"
    finally:
        sup.close()


# -- a stop with no reason --------------------------------------------------------------------


@pytest.mark.parametrize("reason", [None, ""])
def test_a_safe_stop_with_no_reason_is_a_safe_state(reason: str | None) -> None:
    """`SafeStop(None)` (or `safe_state(None)` from planner code) stopped the drives but
    kept no cause, and no cause is how the supervisor tells it is not in its safe state:
    the tree's next drive passed. `EStop(None)` latched with no reason, which a
    primitive took for no e-stop. Both now keep a cause saying none was given."""
    sup = open_supervisor(network="straight")
    try:
        sup.tick()
        sup.apply(operator.SafeStop(reason))  # type: ignore[arg-type]
        assert sup.in_safe_state and sup.safe_state_reason == "safe state (no reason given)"
        assert sup.command(Drive(0.02)).reason is Reason.SAFE_STATE
        sup.apply(operator.EStop(reason))  # type: ignore[arg-type]
        assert sup.estop_reason == "e-stop (no reason given)"
    finally:
        sup.close()


# -- a deny of a step under way ---------------------------------------------------------------


class _Denier:
    """Confirms every step waiting until 4 s, then denies the drive under way."""

    releases = True

    def __init__(self, sup: Supervisor) -> None:
        self.sup = sup

    def poll(self, tick: int, now: float) -> list[operator.OperatorAction]:
        if now < 4.0:
            return [operator.Confirm(step) for step in self.sup.pending_confirmations()]
        if now < 4.05:
            return [operator.Deny("drive along the straight")]
        return []


def test_a_deny_of_the_step_under_way_stops_it() -> None:
    """Supervised, the straight PAB's drive confirmed and at speed, the operator denies
    it: nothing changed, the drive (which asks once, and sends nothing more at speed)
    went on and the run *succeeded*, 1 m driven under the operator's deny. A deny of a
    step under way now stops the robot: its safe state, the run failing on the deny."""
    with pirate_bt.connect("sim:straight", mode="supervised") as robot:
        robot.supervisor.add_input(_Denier(robot.supervisor))
        result = robot.run("straight", params={"distance": "1 m"}, max_time="40 s")
    assert result.status == "failure"
    assert result.why == "the operator denied 'drive along the straight' while it ran"


def test_a_deny_of_a_step_the_estop_interrupted_stops_it_too() -> None:
    sup = open_supervisor(network="straight", mode="supervised")
    try:
        sup.tick()
        sup.request_confirmation("drive")
        sup.confirm("drive")
        sup.apply(operator.EStop())
        assert sup.reset_estop()
        sup.set_mode(Mode.SUPERVISED)
        assert sup.deny() == "drive"
        assert sup.safe_state_reason == "the operator denied 'drive' while it ran"
        # a step that only waited is denied without a stop
        sup.resume()
        sup.request_confirmation("bend")
        assert sup.deny() == "bend" and not sup.in_safe_state
    finally:
        sup.close()


def test_a_command_after_an_estop_reset_does_not_restart_the_drives() -> None:
    """Driving at 80 mm/s, an e-stop, its reset: the link kept the setpoints from before
    the e-stop and sends its whole table with any command, so the operator's first
    command after the reset, a front tilt, set the robot driving at 80 mm/s again. The
    reset now puts the setpoints in the stop the bridge applied (docs/protocol.md: a
    reset never restarts motion by itself)."""
    sup = open_supervisor(network="straight")
    try:
        sup.tick()
        assert sup.command(Clamp(Half.REAR, 0.7)).ok
        for _ in range(15):
            sup.clock.sleep(0.1)
            sup.tick()
        for _ in range(5):
            sup.command(Drive(0.08))
            sup.clock.sleep(0.1)
            sup.tick()
        sup.apply(operator.EStop())
        sup.clock.sleep(0.3)
        sup.tick()
        assert sup.reset_estop()
        assert sup.command(Tilt(0.1), source=Source.OPERATOR).ok
        for _ in range(5):
            sup.clock.sleep(0.1)
            sup.tick()
        state = sup.state()
        assert state is not None
        assert all(abs(v) < 1e-3 for v in state.drive_velocity_mps.values()), state
    finally:
        sup.close()
