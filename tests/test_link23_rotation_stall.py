"""The stalled-joint watch covers the rotation (session 23): a rotation commanded in
position mode whose joint does not move (a jammed rotate joint) is let go after
JOINT_STALL_S, as a stalled bend joint is, and the run ends naming it; a rotation
whose setpoint its board does not hold yet is not judged."""

from __future__ import annotations

import math
from typing import Any

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.safety import Supervisor
from pirate_bt.safety.commands import Rotate
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


def test_a_bend_pab_whose_rotate_joint_is_jammed_stops_naming_it() -> None:
    # was: 'timeout: not done after 10 s (rotating to 90.0°: at 0.0°)', the rotate
    # motor's position loop pushing a jammed joint for ten seconds
    result = pirate_bt.simulate_tree(
        "bend",
        network="bend-right",
        params={"roll": "90 deg"},
        faults="motor_stall:rotate@0s+100s",
        seed=0,
    )
    assert result.status == "failure"
    assert result.why.startswith("joint_stalled: rotate does not move toward its setpoint")
    assert result.counters.damage == 0


class _HeldPort(FakePort):
    """A fake port that tells which setpoint each board holds: only what the test has
    delivered (as RobotLink does from the STATEs' ack_seq). Its rotation never moves."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.held: dict[str, MotorCommand] = {}

    def deliver(self) -> None:
        for motor, (mode, value) in self.setpoints.items():
            self.held[motor] = MotorCommand(motor, mode, value)

    def setpoint_applied(self, motor: str) -> MotorCommand | None:
        return self.held.get(motor)


def _supervisor() -> tuple[SimClock, _HeldPort, Supervisor]:
    clock = SimClock(10.0)
    port = _HeldPort(ROBOT, clock)
    port.clamp_half(Half.REAR, 0.7)
    port.free_half(Half.FRONT, 0.0)
    port.values[port.rotation_channel] = 0.0
    sup = Supervisor(port, clock)
    sup.tick()
    return clock, port, sup


def test_a_jammed_rotation_is_let_go_once_its_board_holds_the_setpoint() -> None:
    clock, port, sup = _supervisor()
    assert sup.command(Rotate(math.radians(2))).ok
    for _ in range(6):  # the bulk lost or late: the board does not hold it yet
        clock.advance(0.05)
        sup.tick()
    assert not sup.in_safe_state, sup.safe_state_reason
    port.deliver()  # acknowledged; the joint stays at 0°
    for _ in range(3):
        clock.advance(0.05)
        sup.tick()
    reason = sup.safe_state_reason or ""
    assert reason.startswith(
        "joint_stalled: rotate does not move toward its setpoint: at 0.0°, asked 2.0°"
    ), reason
    assert port.setpoints["rotate"] == (ControlMode.TORQUE, 0.0)  # its loop let go


def test_a_rotation_that_follows_its_setpoint_is_not_stopped() -> None:
    clock, port, sup = _supervisor()
    assert sup.command(Rotate(math.radians(2))).ok
    port.deliver()
    for _ in range(6):
        clock.advance(0.05)
        port.values[port.rotation_channel] = port.setpoints["rotate"][1]  # it follows
        sup.tick()
    assert not sup.in_safe_state, sup.safe_state_reason


def test_a_jammed_front_tilt_stops_naming_it() -> None:
    # was: 'timeout: not done after 5 s (front tilt 0.0°)', the tilt motor's position
    # loop pushing a jammed joint for five seconds (the front module's joints were not
    # watched either)
    result = pirate_bt.simulate_tree(
        "straight",
        network="straight",
        params={"distance": "0.5 m"},
        faults="motor_stall:front_tilt@0s+100s",
        seed=0,
    )
    assert result.status == "failure"
    assert result.why.startswith("joint_stalled: front_tilt does not move toward its setpoint")
