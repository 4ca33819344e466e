"""Static limits: angle range, torque, speed and rate of change per motor.

Each limit of a motor in the robot description is clipped or refused by that
limit's policy; :func:`limit` applies them all to one motor command.
"""

from __future__ import annotations

import math

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    LimitPolicy,
    Motor,
    MotorFunction,
    RobotDescription,
)
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.checks import Problem
from pirate_bt.safety.verdict import Reason

__all__ = ["drive_reach", "limit", "measured"]


def measured(robot: RobotDescription, motor: Motor, state: RobotState | None) -> float | None:
    if state is None:
        return None
    fn = motor.function
    if fn is MotorFunction.BEND:
        return state.joint_angle_rad.get(robot.module_of(motor.name).name)
    if fn is MotorFunction.ROTATE:
        return state.rotation_rad
    if fn is MotorFunction.TILT:
        return state.front_tilt_rad
    if fn is MotorFunction.CAMERA_TILT:
        return state.camera_tilt_rad
    if fn is MotorFunction.CAMERA_PAN:
        return state.camera_pan_rad
    if fn is MotorFunction.DRIVE:
        return state.drive_velocity_mps.get(motor.name)
    return None


def limit(
    robot: RobotDescription,
    last_setpoint: dict[str, tuple[ControlMode, float, float]],
    mc: MotorCommand,
    state: RobotState | None,
    now: float,
) -> tuple[float, list[tuple[Reason, str]]] | Problem:
    """Apply every static limit of ``mc``'s motor: ``(value, clips)`` or a refusal."""
    motor = robot.motor(mc.motor)
    lim = motor.limits
    value = mc.value
    notes: list[tuple[Reason, str]] = []

    def bound(
        reason: Reason, policy: LimitPolicy, lo: float, hi: float, what: str
    ) -> Problem | None:
        nonlocal value
        if lo <= value <= hi:
            return None
        text = f"{motor.name}: {what} {value:g} outside [{lo:g}, {hi:g}]"
        if policy is LimitPolicy.REFUSE:
            return Problem(reason, text)
        value = min(max(value, lo), hi)
        notes.append((reason, f"{text}, clipped to {value:g}"))
        return None

    window = robot.safety.rate_window
    last = last_setpoint.get(mc.motor)
    if last is not None and last[0] is mc.mode:
        reference: float | None = last[1]
        dt = min(max(now - last[2], 0.0), window)
    else:
        reference = measured(robot, motor, state)
        dt = window
    problem: Problem | None = None
    if mc.mode is ControlMode.POSITION:
        if lim.angle is not None:
            problem = bound(
                Reason.ANGLE_LIMIT, lim.angle.policy, lim.angle.min, lim.angle.max, "angle"
            )
        if problem is None and lim.angular_velocity is not None and reference is not None:
            step = lim.angular_velocity.max * dt
            # back toward where the joint is, from a setpoint it has not reached: it
            # slows down and stops there, it cannot jerk (a node halted holds its joint)
            at = measured(robot, motor, state) if last is not None else None
            if at is None or not min(reference, at) <= value <= max(reference, at):
                problem = bound(
                    Reason.ANGULAR_RATE_LIMIT,
                    lim.angular_velocity.policy,
                    reference - step,
                    reference + step,
                    f"angle step from {reference:g} in {dt:g} s: target",
                )
    elif mc.mode is ControlMode.TORQUE:
        if lim.torque is not None:
            problem = bound(
                Reason.TORQUE_LIMIT,
                lim.torque.policy,
                -lim.torque.max,
                lim.torque.max,
                "torque",
            )
    elif mc.mode is ControlMode.VELOCITY:
        if lim.velocity is not None:
            problem = bound(
                Reason.VELOCITY_LIMIT,
                lim.velocity.policy,
                -lim.velocity.max,
                lim.velocity.max,
                "velocity",
            )
        ref = reference or 0.0
        # Slowing down is never limited: stopping must always be possible. A reversal
        # (the wheels told to turn the other way) stops at once and speeds up the other
        # way by at most one step from the old speed, as drive_reach reckons it: until
        # the twenty-second session it was clipped to ref - step, so the wheels went on
        # forward (at 60 mm/s from 80) where a stop would have stopped them.
        faster = abs(value) > abs(ref)  # pragma: no mutate (>=: an equal speed is inside any bound)
        speeding = faster or (value * ref < 0)
        if problem is None and lim.acceleration is not None and speeding:
            step = lim.acceleration.max * dt
            lo, hi = ref - step, ref + step
            if value * ref < 0:  # a reversal: the stop on its way is free
                lo, hi = min(lo, 0.0), max(hi, 0.0)
            problem = bound(
                Reason.ACCELERATION_LIMIT,
                lim.acceleration.policy,
                lo,
                hi,
                f"velocity change from {ref:g} in {dt:g} s: target",
            )
    if problem is not None:
        return problem
    conversion = motor.modes.get(mc.mode)
    if conversion is not None:
        # what the mode's raw range can carry, in SI (the description's own range): the
        # link would saturate a value beyond it unsaid. As the link rounds, a value
        # within half a raw step of the range is in it.
        lo, hi = conversion.si_range
        half_step = abs(conversion.per_raw) / 2
        if not lo - half_step <= value <= hi + half_step:
            text = f"{motor.name}: {mc.mode} {value:g} outside [{lo:g}, {hi:g}], its raw range"
            value = lo if value < lo else hi
            notes.append((Reason.RAW_RANGE, f"{text}, clipped to {value:g}"))
    return value, notes


def drive_reach(
    robot: RobotDescription,
    last_setpoint: dict[str, tuple[ControlMode, float, float]],
    velocity: float,
    state: RobotState | None,
    now: float,
) -> float:
    """The drive speed nearest ``velocity`` that every drive motor's acceleration limit
    lets a ``Drive`` reach now, as :func:`limit` judges it (from the same reference, over
    the same time): ``velocity`` itself where no limit stands in the way.

    A primitive steps its setpoint by this where a limit's policy refuses a larger step
    (with ``clip`` the supervisor clips it the same way).
    """
    lo, hi = -math.inf, math.inf
    window = robot.safety.rate_window
    for motor in robot.drive_motors():
        acc = motor.limits.acceleration
        if acc is None:
            continue
        last = last_setpoint.get(motor.name)
        if last is not None and last[0] is ControlMode.VELOCITY:
            ref = last[1]
            dt = min(max(now - last[2], 0.0), window)
        else:
            ref = measured(robot, motor, state) or 0.0
            dt = window
        step = acc.max * dt
        # slowing down (toward 0, not past it) is never limited; a reversal is a speed-up
        if ref >= 0.0:
            lo, hi = max(lo, min(0.0, ref - step)), min(hi, ref + step)
        else:
            lo, hi = max(lo, ref - step), min(hi, max(0.0, ref + step))
    return min(max(velocity, lo), hi)
