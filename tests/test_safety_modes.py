"""Safe state, e-stop latching, operator modes and confirmations."""

from __future__ import annotations

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkLost
from pirate_bt.robot import ControlMode, Half, load_robot
from pirate_bt.safety import (
    Clamp,
    Confirm,
    Confirmation,
    Deny,
    Drive,
    EStop,
    Mode,
    OperatorCommand,
    Reason,
    ResetEStop,
    Resume,
    Rotate,
    SafeStop,
    ScriptedOperator,
    SetMode,
    Source,
    Supervisor,
)
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


@pytest.fixture
def clock() -> SimClock:
    return SimClock(10.0)


@pytest.fixture
def port(clock: SimClock) -> FakePort:
    p = FakePort(ROBOT, clock)
    p.clamp_half(Half.REAR)
    return p


def drives_stopped(port: FakePort) -> bool:
    last = {c.motor: c for c in port.sent}
    return all(
        last[m.name].mode is ControlMode.VELOCITY and last[m.name].value == 0.0
        for m in ROBOT.drive_motors()
    )


def test_safe_state_stops_drives_holds_clamps_and_latches(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    assert sup.command(Drive(0.02)).ok
    port.sent.clear()
    sup.safe_state("runner: behaviour raised")
    assert drives_stopped(port)
    assert not any(c.motor.endswith("_joint") for c in port.sent)  # clamps are left holding
    assert sup.command(Drive(0.02)).reason is Reason.SAFE_STATE
    assert sup.verdicts.last() is not None and sup.verdicts.last().reason is Reason.SAFE_STATE
    sup.resume()
    assert sup.command(Drive(0.02)).ok


def test_stale_data_enters_safe_state_on_tick(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    sup.tick()
    assert not sup.in_safe_state
    port.freeze("imu.pitch")
    clock.advance(0.5)
    sup.tick()
    assert sup.in_safe_state and "imu.pitch" in (sup.safe_state_reason or "")
    assert drives_stopped(port)


def test_link_loss_enters_safe_state_on_tick(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    port.poll_error = LinkLost("nothing heard for 1 s")
    sup.tick()
    assert sup.in_safe_state and "link lost" in (sup.safe_state_reason or "")


def test_repeated_refusals_enter_safe_state(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    port.clamp_half(Half.FRONT)
    for _ in range(ROBOT.safety.max_refusals - 1):
        assert sup.command(Rotate(0.05)).reason is Reason.ROTATE_NEEDS_ONE_CLAMPED
    assert not sup.in_safe_state
    sup.command(Rotate(0.05))
    assert sup.in_safe_state


def test_a_passing_command_resets_the_refusal_count(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    port.clamp_half(Half.FRONT)
    for _ in range(3 * ROBOT.safety.max_refusals):
        sup.command(Rotate(0.05))
        sup.command(Drive(0.0))
    assert not sup.in_safe_state


def test_operator_stop_enters_safe_state(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    sup.apply(SafeStop("operator"))
    assert sup.in_safe_state
    sup.apply(Resume())
    assert not sup.in_safe_state


def test_estop_always_passes_and_latches(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    port.connected = False  # even on a dead link the e-stop is attempted
    sup.apply(EStop("button"))
    assert port.estops == 1 and sup.mode is Mode.ESTOP and sup.tree_paused
    port.connected = True
    assert sup.command(Drive(0.01)).reason is Reason.ESTOP_LATCHED
    assert sup.command(Drive(0.01), source=Source.OPERATOR).reason is Reason.ESTOP_LATCHED
    sup.apply(SetMode(Mode.AUTONOMOUS))  # cannot hand back past a latched e-stop
    assert sup.mode is Mode.ESTOP
    assert sup.request_confirmation("clamp") is Confirmation.DENIED
    sup.apply(ResetEStop())
    assert sup.mode is Mode.MANUAL and not port.estopped
    sup.apply(SetMode(Mode.AUTONOMOUS))
    assert sup.command(Drive(0.01)).ok


def test_bridge_estop_latches_on_tick(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    port.estopped = True
    sup.tick()
    assert sup.mode is Mode.ESTOP


def test_takeover_and_hand_back_take_effect_within_one_tick(
    port: FakePort, clock: SimClock
) -> None:
    script = ScriptedOperator(
        at_tick=[
            (3, SetMode(Mode.MANUAL)),
            (4, OperatorCommand(Drive(0.02))),
            (5, SetMode(Mode.AUTONOMOUS)),
        ]
    )
    sup = Supervisor(port, clock, inputs=[script])
    for tick in range(1, 7):
        sup.tick()
        tree = sup.command(Drive(0.01))
        if tick in (3, 4):
            assert sup.tree_paused and tree.reason is Reason.TREE_PAUSED, tick
        else:
            assert not sup.tree_paused and tree.ok, tick
        clock.advance(0.1)
    by_operator = [v for v in sup.verdicts if v.source is Source.OPERATOR]
    assert len(by_operator) == 1 and by_operator[0].ok and by_operator[0].tick == 4
    assert script.exhausted


def test_takeover_stops_the_drives(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    sup.command(Drive(0.02))
    sup.set_mode(Mode.MANUAL)
    assert drives_stopped(port)


def test_operator_commands_need_manual_mode(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    v = sup.apply(OperatorCommand(Drive(0.02)))
    assert v is not None and v.reason is Reason.OPERATOR_NOT_IN_CONTROL
    sup.set_mode(Mode.MANUAL)
    v = sup.apply(OperatorCommand(Rotate(0.05)))
    assert v is not None and v.ok  # rear clamped, front free
    v = sup.apply(OperatorCommand(Clamp(Half.REAR, 2.0)))
    assert v is not None and v.reason is Reason.TORQUE_LIMIT  # same checks as the tree


def test_supervised_mode_waits_for_confirmation(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock, mode=Mode.SUPERVISED)
    assert sup.request_confirmation("drive 1") is Confirmation.PENDING
    assert sup.command(Drive(0.01)).reason is Reason.NOT_CONFIRMED
    assert sup.pending_confirmations() == ["drive 1"]
    sup.apply(Confirm())
    assert sup.request_confirmation("drive 1") is Confirmation.GRANTED
    assert sup.command(Drive(0.01)).ok
    sup.end_step("drive 1")
    assert sup.command(Drive(0.01)).reason is Reason.NOT_CONFIRMED
    assert sup.request_confirmation("drive 2") is Confirmation.PENDING
    sup.apply(Deny("drive 2"))
    assert sup.request_confirmation("drive 2") is Confirmation.DENIED


def test_autonomous_mode_grants_at_once(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    assert sup.request_confirmation("clamp front") is Confirmation.GRANTED
    sup.set_mode(Mode.MANUAL)
    sup.end_step("clamp front")
    assert sup.request_confirmation("clamp front") is Confirmation.PENDING


def test_hand_back_leaves_safe_state(port: FakePort, clock: SimClock) -> None:
    sup = Supervisor(port, clock)
    sup.safe_state("x")
    sup.set_mode(Mode.MANUAL)
    assert sup.in_safe_state
    sup.set_mode(Mode.SUPERVISED)
    assert not sup.in_safe_state


def test_scripted_operator_by_time(port: FakePort, clock: SimClock) -> None:
    script = ScriptedOperator(at_time=[(clock.now() + 0.25, SetMode(Mode.MANUAL))])
    sup = Supervisor(port, clock, inputs=[script])
    sup.tick()
    clock.advance(0.2)
    sup.tick()
    assert sup.mode is Mode.AUTONOMOUS
    clock.advance(0.1)
    sup.tick()
    assert sup.mode is Mode.MANUAL
