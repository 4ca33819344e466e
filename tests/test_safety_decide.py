"""Every road through the supervisor's decision, as the verdict shows it.

Written with the mutation run (docs/testing.md): each refusal keeps the command and its
source and says why in the words an operator reads; a stop goes out only when sent and
resets what the rate limits count from; the node that asked is named, except for an
operator; a passing command resets the count of refusals in a row; custom checks see
the clock and only commands that move.
"""

from __future__ import annotations

import logging
from typing import Any

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkError
from pirate_bt.robot import ControlMode, Half, MotorCommand, load_robot
from pirate_bt.safety import (
    Clamp,
    Drive,
    Mode,
    Outcome,
    Raw,
    Reason,
    Rotate,
    Source,
    Stop,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.checks import CheckContext, Intent, Problem
from pirate_bt.safety.commands import Command
from pirate_bt.safety.testing import FakePort
from pirate_bt.safety.verdict import Verdict, issuing

ROBOT = load_robot()


@pytest.fixture
def clock() -> SimClock:
    return SimClock(50.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    p = FakePort(ROBOT, clock)
    p.clamp_half(Half.REAR)
    return p


@pytest.fixture
def sup(port: FakePort, clock: SimClock) -> Supervisor:
    return Supervisor(port, clock)


def refused(v: Verdict, command: Command, source: Source, reason: Reason, detail: str) -> None:
    assert (v.outcome, v.command, v.source, v.reason, v.detail, v.sent) == (
        Outcome.REFUSE,
        command,
        source,
        reason,
        detail,
        (),
    )


class Node:
    """A duck-typed tree node (name, parent, children) for :func:`issuing`."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.parent: Any = None
        self.children: list[Any] = []


# -- authority -----------------------------------------------------------------------------


def test_authority_refusals_keep_the_command_and_say_who_may_act(
    sup: Supervisor, port: FakePort
) -> None:
    drive = Drive(0.02)
    refused(
        sup.command(drive, source=Source.OPERATOR),
        drive,
        Source.OPERATOR,
        Reason.OPERATOR_NOT_IN_CONTROL,
        "take over (mode manual) before driving by hand; mode is autonomous",
    )
    sup.set_mode(Mode.SUPERVISED)
    refused(
        sup.command(drive),
        drive,
        Source.TREE,
        Reason.NOT_CONFIRMED,
        "supervised mode: no step has been confirmed by the operator",
    )
    sup.set_mode(Mode.MANUAL)
    refused(
        sup.command(drive),
        drive,
        Source.TREE,
        Reason.TREE_PAUSED,
        "the operator has taken over (manual)",
    )
    sup.set_mode(Mode.AUTONOMOUS)
    sup.safe_state("a test asked")
    refused(
        sup.command(drive), drive, Source.TREE, Reason.SAFE_STATE, "in safe state: a test asked"
    )
    sup.estop("red button")
    refused(
        sup.command(drive, source=Source.OPERATOR),
        drive,
        Source.OPERATOR,
        Reason.ESTOP_LATCHED,
        "e-stop latched (red button)",
    )


def test_link_expansion_and_state_refusals_keep_the_command(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    rotate = Rotate(0.05)
    port.connected = False
    refused(
        sup.command(rotate),
        rotate,
        Source.TREE,
        Reason.LINK_DOWN,
        "the link to the robot is not connected",
    )
    port.connected = True
    bend = Raw(MotorCommand("bend_1_joint", ControlMode.PWM, 0.1))
    refused(
        sup.command(bend),
        bend,
        Source.TREE,
        Reason.MODE_NOT_ALLOWED,
        "bend motor 'bend_1_joint' accepts only torque, position through the supervisor",
    )
    port.freeze("bend_2_spring", "imu.pitch")
    clock.advance(2.0)
    refused(
        sup.command(rotate),
        rotate,
        Source.TREE,
        Reason.STALE_STATE,
        "readings too old: bend_2_spring (2.000 s), imu.pitch (2.000 s)",
    )


def test_a_channel_never_read_is_named_as_never_read(clock: SimClock) -> None:
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    del port.values["bend_3_spring"]
    sup = Supervisor(port, clock)
    refused(
        sup.command(Drive(0.02)),
        Drive(0.02),
        Source.TREE,
        Reason.STALE_STATE,
        "readings too old: bend_3_spring (never)",
    )


def test_with_no_state_a_command_is_refused_and_says_so(clock: SimClock) -> None:
    class Silent(FakePort):
        def state(self) -> None:  # type: ignore[override]
            return None

    sup = Supervisor(Silent(ROBOT, clock), clock)
    sup.set_mode(Mode.MANUAL)
    drive = Drive(0.02)
    refused(
        sup.command(drive, source=Source.OPERATOR),
        drive,
        Source.OPERATOR,
        Reason.NO_STATE,
        "no state received yet",
    )


def test_invariant_and_limit_refusals_keep_the_command(sup: Supervisor, port: FakePort) -> None:
    sup.set_mode(Mode.MANUAL)
    unclamp = Unclamp(Half.REAR)
    refused(
        sup.command(unclamp, source=Source.OPERATOR),
        unclamp,
        Source.OPERATOR,
        Reason.OTHER_HALF_NOT_CLAMPED,
        "the rear half may unclamp or bend only while the front half is clamped (it is unclamped)",
    )
    far = Rotate(3.1)
    refused(
        sup.command(far, source=Source.OPERATOR),
        far,
        Source.OPERATOR,
        Reason.ANGLE_LIMIT,
        "rotate: angle 3.1 outside [-3.05433, 3.05433]",
    )


def test_a_send_that_fails_is_refused_with_the_link_s_words(
    sup: Supervisor, port: FakePort
) -> None:
    port.fail_send = True
    drive = Drive(0.02)
    refused(sup.command(drive), drive, Source.TREE, Reason.LINK_ERROR, "fake send failure")


# -- what passes -------------------------------------------------------------------------------


def test_passes_and_clips_keep_the_command_and_its_source(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    sup.set_mode(Mode.MANUAL)  # a takeover stops the drives: let time pass
    clock.advance(1.0)
    drive = Drive(0.02)
    v = sup.command(drive, source=Source.OPERATOR)
    assert (v.outcome, v.command, v.source) == (Outcome.PASS, drive, Source.OPERATOR)
    tilt = Tilt(2.0)
    v = sup.command(tilt, source=Source.OPERATOR)
    assert (v.outcome, v.command, v.source) == (Outcome.CLIP, tilt, Source.OPERATOR)
    assert v.detail.startswith(
        "front_tilt: angle 2 outside [-1.74533, 1.74533], clipped to 1.74533; "
    )
    assert v.sent == (MotorCommand("front_tilt", ControlMode.POSITION, v.sent[0].value),)
    stop = Stop()
    v = sup.command(stop, source=Source.OPERATOR)
    assert (v.outcome, v.command, v.source) == (Outcome.PASS, stop, Source.OPERATOR)


def test_a_stop_goes_out_only_when_sent(sup: Supervisor, port: FakePort) -> None:
    dry = sup.check(Stop())
    assert dry.outcome is Outcome.PASS and dry.sent == () and port.sent == []
    sent = sup.command(Stop())
    zeros = tuple(MotorCommand(m.name, ControlMode.VELOCITY, 0.0) for m in ROBOT.drive_motors())
    assert sent.sent == zeros and tuple(port.sent) == zeros


def test_after_a_stop_a_speed_up_starts_from_rest(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    for v in (0.04, 0.08):
        assert sup.command(Drive(v)).ok
        clock.advance(1.0)
    assert sup.command(Stop()).ok
    v = sup.command(Drive(0.04))  # the same instant as the stop: no time to speed up
    assert v.outcome is Outcome.CLIP and {c.value for c in v.sent} == {0.0}
    clock.advance(1.0)
    assert sup.command(Drive(0.04)).outcome is Outcome.PASS


def test_a_stop_that_cannot_be_sent_is_logged(
    sup: Supervisor, port: FakePort, caplog: pytest.LogCaptureFixture
) -> None:
    port.fail_send = True
    caplog.set_level(logging.ERROR, logger="pirate_bt.safety")
    v = sup.command(Stop())
    assert v.outcome is Outcome.PASS and v.sent == ()
    drives = ", ".join(m.name for m in ROBOT.drive_motors())
    said = [r.getMessage() for r in caplog.records]
    assert said == [f"could not send the stop of {drives}: fake send failure"]
    # said once while the link stays down (a closed line gave 27 lines: one per drive,
    # at every stop sent into it)
    assert sup.command(Stop()).sent == ()
    assert [r.getMessage() for r in caplog.records] == said
    # a stop that goes out ends the episode: the next failure is said again
    port.fail_send = False
    assert sup.command(Stop()).sent != ()
    port.fail_send = True
    sup.command(Stop())
    assert [r.getMessage() for r in caplog.records] == said * 2


class _Refusing(FakePort):
    """A fake link that refuses the next ``fails`` sends, or any holding ``motor``."""

    def __init__(self, clock: SimClock, fails: int = 0, motor: str | None = None) -> None:
        super().__init__(ROBOT, clock)
        self.fails, self.motor = fails, motor

    def send(self, commands: Any) -> None:
        if self.fails > 0 or any(c.motor == self.motor for c in commands):
            self.fails -= 1
            raise LinkError("refused")
        super().send(commands)


def test_a_stop_refused_for_an_earlier_failure_goes_out_at_the_second_try(
    clock: SimClock, caplog: pytest.LogCaptureFixture
) -> None:
    port = _Refusing(clock, fails=1)
    caplog.set_level(logging.INFO, logger="pirate_bt.safety")
    v = Supervisor(port, clock).command(Stop())
    zeros = tuple(MotorCommand(m.name, ControlMode.VELOCITY, 0.0) for m in ROBOT.drive_motors())
    assert v.sent == zeros and tuple(port.sent) == zeros
    said = {r.getMessage(): r.levelname for r in caplog.records}
    assert said.get("the stop went out at the second try (the first: refused)") == "WARNING"
    assert "ERROR" not in said.values(), said


def test_a_board_that_refuses_its_stop_keeps_only_its_own_drives_from_stopping(
    clock: SimClock, caplog: pytest.LogCaptureFixture
) -> None:
    drives = [m.name for m in ROBOT.drive_motors()]
    board = ROBOT.board_of(drives[0]).id
    mine = [d for d in drives if ROBOT.board_of(d).id == board]
    others = [d for d in drives if d not in mine]
    assert others, "the bundled robot has drives on more than one board"
    port = _Refusing(clock, motor=drives[0])
    caplog.set_level(logging.ERROR, logger="pirate_bt.safety")
    v = Supervisor(port, clock).command(Stop())
    assert [c.motor for c in v.sent] == others and [c.motor for c in port.sent] == others
    assert [r.getMessage() for r in caplog.records] == [
        f"could not send the stop of {', '.join(mine)}: refused"
    ]


def test_a_stop_into_a_latched_e_stop_is_not_an_error(
    sup: Supervisor, port: FakePort, caplog: pytest.LogCaptureFixture
) -> None:
    port.fail_send = True
    port.estopped = True
    caplog.set_level(logging.INFO, logger="pirate_bt.safety")
    sup.command(Stop())
    levels = {r.getMessage(): r.levelname for r in caplog.records}
    assert "stop not sent (the e-stop is latched): fake send failure" in levels
    assert "ERROR" not in levels.values(), levels


# -- recording -------------------------------------------------------------------------------------


def test_a_verdict_names_the_node_that_asked_but_never_for_an_operator(
    sup: Supervisor, clock: SimClock
) -> None:
    node = Node("drive on")
    with issuing(node):
        tree = sup.command(Drive(0.02))
        sup.set_mode(Mode.MANUAL)
        operator = sup.command(Drive(0.02), source=Source.OPERATOR)
    assert (tree.node, tree.node_name, tree.stamp_s) == ("0", "drive on", clock.now())
    assert (operator.node, operator.node_name) == (None, None)
    plain = sup.command(Stop())
    assert (plain.node, plain.node_name, plain.stamp_s) == (None, None, clock.now())


def test_a_pass_resets_the_count_of_refusals_in_a_row(sup: Supervisor) -> None:
    limit = ROBOT.safety.max_refusals
    bad = Unclamp(Half.REAR)  # the front half is free: refused
    for _ in range(limit - 1):
        assert sup.command(bad).refused
    assert sup.command(Drive(0.0)).ok
    for _ in range(limit - 1):
        assert sup.command(bad).refused
    assert not sup.in_safe_state
    assert sup.command(bad).refused
    assert sup.in_safe_state


# -- what custom checks see -------------------------------------------------------------------


def test_custom_checks_see_the_clock_and_only_commands_that_move(
    sup: Supervisor, clock: SimClock
) -> None:
    seen: list[tuple[Command, float]] = []

    def veto(ctx: CheckContext, intent: Intent) -> Problem | None:
        seen.append((intent.command, ctx.now_s))
        return Problem(Reason.OTHER_HALF_NOT_CLAMPED, "veto")

    sup.add_check(veto)
    assert sup.command(Drive(0.0)).ok  # moves nothing: no invariant is asked
    sup.set_mode(Mode.MANUAL)
    camera = Raw(MotorCommand("camera_pan", ControlMode.POSITION, 0.1))
    assert sup.command(camera, source=Source.OPERATOR).ok
    sup.set_mode(Mode.AUTONOMOUS)
    assert sup.command(Drive(0.02)).detail == "veto"
    assert seen == [(Drive(0.02), clock.now())]


def test_a_zero_drive_still_needs_fresh_readings(
    sup: Supervisor, port: FakePort, clock: SimClock
) -> None:
    """Only ``Stop`` always passes; a drive at zero is judged on the readings it relies on."""
    port.freeze("bend_1_angle")
    clock.advance(1.0)
    assert sup.command(Drive(0.0)).reason is Reason.STALE_STATE
    assert sup.command(Stop()).ok


def test_a_clamp_target_survives_a_reversal(sup: Supervisor, port: FakePort) -> None:
    """A clamp that swings its joints across is a release on the way, but its target is a clamp."""
    port.clamp_half(Half.FRONT)
    port.set(bend_3_angle=-1.0, bend_4_angle=-1.0, bend_3_spring=0.0, bend_4_spring=0.0)
    assert sup.command(Clamp(Half.REAR, 0.5)).ok
    port.free_half(Half.REAR)
    from pirate_bt.safety import ClampState

    assert sup.half_states()[Half.REAR] is ClampState.TRANSITIONING  # asked to clamp
