"""The stalled-joint watch on a lossy link (session 22): a joint waits for its setpoint
only once its board is known to have it (a STATE's ack_seq), so a setpoint lost or
late is not taken for a stalled motor; a real stall is still let go."""

from __future__ import annotations

import math
from typing import Any

import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.link.codec import BulkSetpoints
from pirate_bt.link.snapshots import AppliedSetpoints
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import CommandCodec, MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.safety import Supervisor
from pirate_bt.safety.commands import Bend
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


def test_a_bend_pab_on_a_link_that_drops_a_fifth_of_its_frames_is_not_stopped() -> None:
    # was: 'joint_stalled: bend_3_joint does not move toward its setpoint: at 33.6°,
    # asked 20.1°, for 0.10 s (a stalled joint motor?) ...': a bulk lost, the next one
    # late, and no retry counted (a superseded bulk is never retried)
    result = pirate_bt.simulate_tree(
        "bend", network="bend-right", params={"roll": "90 deg"}, faults="drop=0.2", seed=0
    )
    assert result.status == "success", result.why
    assert result.counters.damage == 0


class _SlowBoardPort(FakePort):
    """A fake port that tells which setpoint each board holds (as RobotLink does from
    the STATEs' ack_seq): only what the test has delivered."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.held: dict[str, MotorCommand] = {}

    def deliver(self) -> None:
        for motor, (mode, value) in self.setpoints.items():
            self.held[motor] = MotorCommand(motor, mode, value)

    def setpoint_applied(self, motor: str) -> MotorCommand | None:
        return self.held.get(motor)


def test_a_joint_waits_for_its_setpoint_only_once_its_board_has_it() -> None:
    clock = SimClock(10.0)
    port = _SlowBoardPort(ROBOT, clock)
    port.clamp_half(Half.FRONT, 0.7)
    port.free_half(Half.REAR, 0.0)
    sup = Supervisor(port, clock)
    sup.tick()
    port.deliver()  # the rear's joints hold 0°, where they are
    assert sup.command(Bend("bend_3", math.radians(4))).ok
    # the bulk carrying 4° is lost or late: the board still holds 0°, the joint still
    for _ in range(8):
        clock.advance(0.05)
        sup.tick()
    assert not sup.in_safe_state, sup.safe_state_reason  # was: joint_stalled after 0.1 s
    port.deliver()  # a STATE acknowledges it; the joint does not move
    for _ in range(2):
        clock.advance(0.05)
        sup.tick()
        assert not sup.in_safe_state, sup.safe_state_reason  # still for less than 0.1 s
    clock.advance(0.05)
    sup.tick()
    assert sup.safe_state_reason == (
        "joint_stalled: bend_3_joint does not move toward its setpoint: at 0.0°, asked 4.0°,"
        " for 0.10 s (a stalled joint motor?): the supervisor lets it go"
    )
    assert port.setpoints["bend_3_joint"] == (ControlMode.TORQUE, 0.0)


def test_a_joint_stalled_on_a_lossy_link_is_still_let_go() -> None:
    # the board has the setpoint (acknowledged) and the joint does not follow it: a
    # stall, whatever the link lost meanwhile
    clock = SimClock(10.0)
    port = _SlowBoardPort(ROBOT, clock)
    port.clamp_half(Half.FRONT, 0.7)
    port.free_half(Half.REAR, 0.0)
    sup = Supervisor(port, clock)
    sup.tick()
    assert sup.command(Bend("bend_3", math.radians(4))).ok
    port.deliver()
    for _ in range(3):
        clock.advance(0.05)
        sup.tick()
    assert (sup.safe_state_reason or "").startswith("joint_stalled: bend_3_joint")


class _Session:
    """The one thing AppliedSetpoints reads of a session: its newest STATE."""

    def __init__(self) -> None:
        self.ack_seq = 0

    def latest_state(self) -> Any:
        return (type("State", (), {"ack_seq": self.ack_seq})(), 0.0)


def _bulk(seq: int, **angles_deg: float | None) -> BulkSetpoints:
    codec = CommandCodec(ROBOT)
    slots = ROBOT.setpoint_slots()
    modes: list[ControlMode | None] = [None] * len(slots)
    raws = [0] * len(slots)
    index = {(s.board, s.slot): i for i, s in enumerate(slots)}
    for motor, deg in angles_deg.items():
        if deg is None:
            continue
        raw = codec.to_raw(MotorCommand(motor, ControlMode.POSITION, math.radians(deg)))
        i = index[(raw.board, raw.slot)]
        modes[i], raws[i] = raw.mode, raw.raw_value
    return BulkSetpoints(seq, tuple(modes), tuple(raws))


def test_the_link_tells_the_setpoint_a_board_holds_by_the_states_ack_seq() -> None:
    applied = AppliedSetpoints(ROBOT)
    session: Any = _Session()
    applied.sent(_bulk(5, bend_3_joint=10.0))
    applied.sent(_bulk(6, bend_3_joint=20.0))
    assert applied.applied(session, "bend_3_joint") is None  # nothing applied yet
    # the bridge applied 5 before 6 superseded it on the host: 5 is what it holds
    session.ack_seq = 5
    held = applied.applied(session, "bend_3_joint")
    assert held is not None and held.mode is ControlMode.POSITION
    assert math.degrees(held.value) == pytest.approx(10.0, abs=0.2)
    session.ack_seq = 6
    held = applied.applied(session, "bend_3_joint")
    assert held is not None and math.degrees(held.value) == pytest.approx(20.0, abs=0.2)
    applied.sent(_bulk(7, bend_3_joint=None, bend_1_joint=5.0))  # bend_3 kept
    session.ack_seq = 7
    held = applied.applied(session, "bend_3_joint")
    assert held is not None and math.degrees(held.value) == pytest.approx(20.0, abs=0.2)
    session.ack_seq = 0  # a new session: the bridge holds its stop
    assert applied.applied(session, "bend_3_joint") is None
