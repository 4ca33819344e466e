"""The watch on joints that do not follow their position setpoints: a stalled motor.

A joint motor in position mode whose joint cannot move (its motor or gear blocked: the
simulator's ``motor_stall``) drives its loop to saturation: it applies its stall
torque, over its torque limit, and a motor held over its limit longer than
``motion.over_torque_time`` is damaged. Until 2026-11-30 nothing on the host noticed: a
bend joint stalled for two seconds while a bend or T-joint PAB steered its half
(``scenarios/bend-right.route`` with ``motor_stall:bend_3_joint@32s+2s``) over-torqued,
and the mission *completed*, with the simulator's one damage event in its message.

The host reads no joint current, but it reads the angle. A joint whose board holds a
position setpoint more than ``safety.angle_tolerance`` away from its reading for
:data:`JOINT_STALL_S` while that reading stayed still (within a quarter of that
tolerance), pressing nothing (its spring, where it has one, under the released force:
a joint stopped by the wall presses the wall), is stalled: the supervisor enters its
safe state naming it and lets that joint go (torque 0: its loop no longer pushes), a
verdict of its own. A moving joint covers its tolerance in a few hundredths of a second
(90°/s on the bundled robot); a setpoint is rate-limited to one tick's step, so a joint
that follows reaches it by the next tick. The rotation and the front module's tilt
and camera joints are watched so too (from 2026-12-01; before, a jammed rotate joint
pushed on until the rotate step's ten-second timeout, a jammed front tilt for five),
each read from its angle sensor, with no spring to press.

The wait starts only once the board is known to have the setpoint: a
``BULK_SETPOINTS`` is acknowledged by a later ``STATE``'s ``ack_seq``, and the link
tells which setpoint each board holds by it (``setpoint_applied``, an optional port
method). Until 2026-12-01 the wait started from the supervisor's own setpoint and
again only on a retry the link counted; on a lossy link a setpoint lost or late (a
superseded bulk is never retried) was taken for a stalled motor: ``riser.route`` with
``drop=0.1,corrupt=0.05,delay=20ms`` stopped on *bend_2_joint ... at 0.0°, asked
18.0°*. A port without ``setpoint_applied`` (a test's fake) is judged as before: its
last setpoint, the wait started again on a retry.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from pirate_bt.errors import LinkError
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    MotorFunction,
    RobotDescription,
    Role,
    SensorKind,
)
from pirate_bt.robot.policy_fit import JOINT_STALL_S
from pirate_bt.robot.port import RobotPort
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.checks import released_force_n, stale_channels
from pirate_bt.safety.commands import Raw
from pirate_bt.safety.operator import Mode
from pirate_bt.safety.verdict import Outcome, Reason, Source, Verdict

__all__ = ["JOINT_STALL_S", "StallMixin"]

_Joint = tuple[str, str, tuple[str, ...], str]
"""A watched joint: its motor, its module, the channels that must be fresh to judge it,
and the ``RobotState`` field it is read from (``joint_angle_rad``: by its module)."""

_FRONT_JOINTS = {
    MotorFunction.TILT: "front_tilt_rad",
    MotorFunction.CAMERA_TILT: "camera_tilt_rad",
    MotorFunction.CAMERA_PAN: "camera_pan_rad",
}
"""The front module's position-mode joints and the state field each is read from."""

log = logging.getLogger("pirate_bt.safety")


class StallMixin:
    """The stalled-joint watch of :class:`~pirate_bt.safety.supervisor.Supervisor`."""

    robot: RobotDescription
    _port: RobotPort
    _mode: Mode
    _last_setpoint: dict[str, tuple[ControlMode, float, float]]
    _half_channels: dict[Half, tuple[str, ...]]

    if TYPE_CHECKING:

        def safe_state(self, reason: str, *, error: BaseException | None = None) -> None: ...

        def _record(self, verdict: Verdict) -> Verdict: ...

    def _stall_joints(self) -> list[_Joint]:
        """Every joint watched (:data:`_Joint`): each bend joint (its half's angle and
        spring channels), the rotation and the front module's tilt and camera joints
        (each its angle channel)."""
        joints: list[_Joint] | None = getattr(self, "_stall_list", None)
        if joints is None:
            joints = [
                (
                    self.robot.joint_motor(m.name).name,
                    m.name,
                    self._half_channels[half],
                    "joint_angle_rad",
                )
                for half in Half
                for m in self.robot.bend_modules(half)
            ]
            joints.extend(_rotation_joint(self.robot))
            joints.extend(_front_joints(self.robot))
            self._stall_list = joints
            self._stall_since: dict[str, tuple[float, float, int]] = {}
            self._stall_let_go: set[str] = set()
        return joints

    def _watch_stalls(self, state: RobotState, now_s: float) -> None:
        """Let a joint that stays still short of its position setpoint go (see the
        module), once per joint until it is commanded again."""
        joints = self._stall_joints()
        if self._mode is Mode.ESTOP:
            return
        tol = self.robot.safety.angle_tolerance
        still = tol / 4
        released = released_force_n(self.robot)
        since = self._stall_since
        applied: Callable[[str], MotorCommand | None] | None = getattr(
            self._port, "setpoint_applied", None
        )
        for motor, module, channels, field in joints:
            setpoint = self._last_setpoint.get(motor)
            if setpoint is None or setpoint[0] is not ControlMode.POSITION:
                since.pop(motor, None)
                self._stall_let_go.discard(motor)
                continue
            if motor in self._stall_let_go:
                continue
            target = setpoint[1]
            if applied is not None:
                held = applied(motor)  # what the board holds, by the STATEs' ack_seq
                if held is None or held.mode is not ControlMode.POSITION:
                    since.pop(motor, None)  # not yet known on the board: no wait
                    continue
                target = held.value
            if field != "joint_angle_rad":
                angle, force = getattr(state, field), None
            else:
                angle, force = state.joint_angle_rad.get(module), state.clamp_force_n.get(module)
            if (
                angle is None
                or abs(angle - target) <= tol
                or (force is not None and abs(force) >= released)
                or stale_channels(self.robot, state, channels, now_s)
            ):
                since.pop(motor, None)
                continue
            # timed by the readings' own stamps (no new state is no evidence); on a port
            # that cannot tell what the board holds, started again when the link
            # retried a request meanwhile (the setpoint may have reached it late)
            resent = 0
            if applied is None:
                health = self._port.health()
                resent = health.retries + health.failed
            first = since.get(motor)
            if first is None or abs(angle - first[1]) > still or resent != first[2]:
                since[motor] = (state.stamp_s, angle, resent)
                continue
            if state.stamp_s - first[0] < JOINT_STALL_S - 1e-9:
                continue
            self._let_joint_go(motor, angle, setpoint[1], state.stamp_s - first[0], now_s)

    def _let_joint_go(
        self, motor: str, angle: float, target: float, for_s: float, now_s: float
    ) -> None:
        """Enter the safe state naming the stalled ``motor`` and let it go: torque 0, or
        PWM 0 where it has no torque mode (the safe state brakes the rotation so)."""
        cause = (
            f"{Reason.JOINT_STALLED}: {motor} does not move toward its setpoint: at"
            f" {math.degrees(angle):.1f}°, asked {math.degrees(target):.1f}°, for"
            f" {for_s:.2f} s (a stalled joint motor?): the supervisor lets it go"
        )
        self.safe_state(cause)
        modes = self.robot.motor(motor).modes
        mode = ControlMode.TORQUE if modes.get(ControlMode.TORQUE) is not None else ControlMode.PWM
        cmd = MotorCommand(motor, mode, 0.0)
        try:
            self._port.send((cmd,))
        except LinkError as exc:  # its board away: its motor is off anyway
            log.error("could not let %s go: %s", motor, exc)
            return
        self._stall_let_go.add(motor)
        self._stall_since.pop(motor, None)
        self._last_setpoint[motor] = (mode, 0.0, now_s)
        log.warning("stalled joint let go: %s", cause)
        self._record(
            Verdict(
                Outcome.PASS,
                Raw(cmd),
                Source.SUPERVISOR,
                sent=(cmd,),
                reason=Reason.JOINT_STALLED,
                detail=f"protective release: {cause}",
            )
        )


def _rotation_joint(robot: RobotDescription) -> list[_Joint]:
    """The rotation as a watched joint, where the robot has a rotate motor and a
    rotation angle sensor: ``[(motor, module, (angle channel,), "rotation_rad")]``."""
    try:
        module = robot.rotational_module().name
        motor = robot.rotate_motor().name
        channel = robot.sensor_of(module, SensorKind.ANGLE).name
    except (KeyError, StopIteration):
        return []
    return [(motor, module, (channel,), "rotation_rad")]


def _front_joints(robot: RobotDescription) -> list[_Joint]:
    """The front module's tilt and camera joints with a position mode, each read by the
    angle sensor on its own board and slot (as ``RobotState`` reads them)."""
    out: list[_Joint] = []
    for board, motor in robot.motors():
        field = _FRONT_JOINTS.get(motor.function)
        if field is None or motor.modes.get(ControlMode.POSITION) is None:
            continue
        if robot.module(board.module).role is not Role.FRONT:
            continue
        for sensor in board.sensors:
            if sensor.slot == motor.slot and sensor.kind is SensorKind.ANGLE:
                out.append((motor.name, board.module, (sensor.name,), field))
                break
    return out
