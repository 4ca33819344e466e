"""Rules that make a robot description workable, beyond its shape.

A description can be well formed and still describe a robot no run can drive: a
bridge that sends state frames less often than the protective layer allows a
reading to age, or a joint sensor that cannot read the angles its joint moves to.
:func:`workable_problems` finds those, each at the key to change, so that
``pirate-bt validate`` says so instead of every run stopping on stale data or
timing out mid-clamp.
"""

from __future__ import annotations

import itertools
import math

from pirate_bt.robot.firmware_fit import (
    BOARD_SILENCE_S,
    board_poll_problems,
    heartbeat_problems,
    position_sensor_problems,
    state_line_problems,
    velocity_loop_problems,
)
from pirate_bt.robot.parts import (
    ControlMode,
    Motor,
    MotorFunction,
    Role,
    SensorKind,
)
from pirate_bt.robot.policy_fit import policy_problems
from pirate_bt.robot.workable import KeyPath, Workable

__all__ = ["BOARD_SILENCE_S", "Workable", "motor_limit_problems", "workable_problems"]


def _fmt_s(seconds: float) -> str:
    return f"{seconds * 1000:g} ms"


def workable_problems(desc: Workable) -> list[tuple[KeyPath, str]]:
    """The rules a run needs of the file, each problem as ``(path, message)``."""
    joints = _joint_sensors(desc)
    return [
        *_freshness(desc),
        *board_poll_problems(desc),
        *heartbeat_problems(desc),
        *state_line_problems(desc),
        *_sensor_ranges(desc),
        *_reach(desc),
        *_drive_feedback(desc),
        *velocity_loop_problems(desc),
        *_cruise(desc),
        *_contradictions(desc),
        *policy_problems(desc),
        *joints,
        *position_sensor_problems(desc, {path[:4] for path, _ in joints}),
    ]


def _contradictions(desc: Workable) -> list[tuple[KeyPath, str]]:
    """Numbers of the clamp and the motion that contradict each other or the motors:
    a wall-contact table whose angle goes back and forth with the diameter, an
    ``unclamped_below`` at or past the first wall contact, a free drive current no
    smaller than a stalled one, and a position-mode hold torque more than a joint with
    a position mode may press with (its torque mode's top and its torque limit: a joint
    held by the wall presses with the hold torque)."""
    out: list[tuple[KeyPath, str]] = []
    clamp, motion = desc.clamp, desc.motion
    pts = clamp.contact_angles
    steps = [b.angle - a.angle for a, b in itertools.pairwise(pts)]
    way = next((d > 0 for d in steps if d != 0), True)  # rising, as the first step goes
    k = next((i + 1 for i, d in enumerate(steps) if d == 0 or (d > 0) != way), None)
    if k is not None:
        out.append(
            (
                ("clamp", "contact_angles", k, "angle"),
                f"the wall-contact angle {_deg(pts[k].angle)} deg of a"
                f" {pts[k].diameter * 1000:g} mm pipe does not go on the way the angles"
                f" before it go ({', '.join(_deg(p.angle) for p in pts[: k + 1])} deg):"
                " the angles must rise (or fall) with the diameter throughout, or a"
                " joint's angle at the wall names two pipes",
            )
        )
    first = min(abs(p.angle) for p in pts)
    if clamp.unclamped_below >= first - 1e-12:
        out.append(
            (
                ("clamp", "unclamped_below"),
                f"unclamped_below {_deg(clamp.unclamped_below)} deg is not below the"
                f" smallest wall-contact angle {_deg(first)} deg (clamp.contact_angles):"
                " a joint at the wall would count as unclamped",
            )
        )
    if motion.drive_free_current >= motion.drive_stall_current:
        out.append(
            (
                ("motion", "drive_free_current"),
                f"drive_free_current {motion.drive_free_current:.3g} A is not less than"
                f" drive_stall_current {motion.drive_stall_current:.3g} A: a free wheel"
                " draws less than a blocked one",
            )
        )
    hold = motion.position_hold_torque
    weakest: tuple[float, str] | None = None
    for board in desc.boards:
        for motor in board.motors:
            if motor.modes.position is None:
                continue
            reach = [motor.modes.torque.si_range[1]] if motor.modes.torque else []
            if motor.limits.torque is not None:
                reach.append(motor.limits.torque.max)
            if reach and (weakest is None or min(reach) < weakest[0]):
                weakest = (min(reach), motor.name)
    if weakest is not None and hold > weakest[0] * (1 + 1e-9):
        out.append(
            (
                ("motion", "position_hold_torque"),
                f"position_hold_torque {hold:g} N*m is more than {weakest[1]!r} may press"
                f" with ({weakest[0]:g} N*m, its torque mode and limit): a position-mode"
                " joint held by the wall presses with the hold torque (the reference PICO"
                " limits its loop's duty to it), past the joint's own limit",
            )
        )
    return out


def _joint_sensors(desc: Workable) -> list[tuple[KeyPath, str]]:
    """A joint's angle sensor sits on the joint motor's own board and slot: the PICO
    board closes the joint's position loop on it (and the simulator feeds it the
    joint's angle), while the host reads the module's first angle sensor (boards by
    id, then slot) and commands its first joint motor. The two must be one pair, or
    the joint moves unseen and every clamp or rotation times out."""
    out: list[tuple[KeyPath, str]] = []
    joints = {Role.BEND: MotorFunction.BEND, Role.ROTATIONAL: MotorFunction.ROTATE}
    order = sorted(range(len(desc.boards)), key=lambda b: desc.boards[b].id)
    for module in desc.modules:
        function = joints.get(module.role)
        if function is None:
            continue
        motor_at: tuple[int, int] | None = None
        read = None
        for b in order:
            board = desc.boards[b]
            if board.module != module.name:
                continue
            for j in sorted(range(len(board.motors)), key=lambda j: board.motors[j].slot):
                if motor_at is None and board.motors[j].function is function:
                    motor_at = (b, j)
            for sensor in sorted(board.sensors, key=lambda s: s.slot):
                if read is None and sensor.kind is SensorKind.ANGLE:
                    read = sensor
        if motor_at is None or read is None:
            continue  # the description's own check: the module needs both
        b, j = motor_at
        board, motor = desc.boards[b], desc.boards[b].motors[j]
        own = next(
            (s for s in board.sensors if s.slot == motor.slot and s.kind is SensorKind.ANGLE),
            None,
        )
        if own is read:
            continue
        where = (
            f"its board has no angle sensor on slot {motor.slot}"
            if own is None
            else f"the host reads the joint from {read.name!r}, the module's first angle"
            f" sensor, not from {own.name!r} on the joint's slot"
        )
        out.append(
            (
                ("boards", b, "motors", j, "slot"),
                f"{function} joint {motor.name!r} of {module.name!r} (board {board.id},"
                f" slot {motor.slot}): {where}; the board closes the joint's position loop on"
                " the angle sensor of the joint's own slot: put the module's angle sensor"
                " there",
            )
        )
    return out


def _cruise(desc: Workable) -> list[tuple[KeyPath, str]]:
    """Every drive must run at ``motion.nominal_speed``: a mission drives its straights
    at that speed, and a tree asking a drive for more than it may go is refused."""
    slowest: tuple[float, str] | None = None
    for board in desc.boards:
        for motor in board.motors:
            mode = motor.modes.velocity
            if motor.function is not MotorFunction.DRIVE or mode is None:
                continue
            top = mode.si_range[1]
            if motor.limits.velocity is not None:
                top = min(top, motor.limits.velocity.max)
            if slowest is None or top < slowest[0]:
                slowest = (top, motor.name)
    speed = desc.motion.nominal_speed
    coarse = _coarse_drive(desc, speed)
    if coarse:
        return coarse
    if slowest is None or speed <= slowest[0] * (1 + 1e-9):
        return []
    return [
        (
            ("motion", "nominal_speed"),
            f"nominal_speed {_mm_s(speed)} mm/s is faster than drive {slowest[1]!r} may go"
            f" ({_mm_s(slowest[0])} mm/s, its velocity mode and limit): a mission drives at"
            " the nominal speed, and every one would be refused when it loads",
        )
    ]


def _coarse_drive(desc: Workable, speed: float) -> list[tuple[KeyPath, str]]:
    """The first drive whose velocity mode's raw step is so coarse that the nominal
    speed is commanded as raw 0 (``per_raw: 1e306 mm/s``): such a robot validated, and
    every drive stood still until its timeout."""
    for b, board in enumerate(desc.boards):
        for j, motor in enumerate(board.motors):
            mode = motor.modes.velocity
            if motor.function is not MotorFunction.DRIVE or mode is None:
                continue
            if mode.to_raw(speed) == mode.to_raw(0.0):
                return [
                    (
                        ("boards", b, "motors", j, "modes", "velocity", "per_raw"),
                        f"drive {motor.name!r}: one raw step of its velocity mode is"
                        f" {abs(mode.per_raw) * 1000:.4g} mm/s, so nominal_speed"
                        f" {_mm_s(speed)} mm/s is sent as no speed at all: every drive"
                        " would stand still",
                    )
                ]
    return []


def _drive_feedback(desc: Workable) -> list[tuple[KeyPath, str]]:
    """A drive's feedback must read what it is read for: its wheel speed at every
    speed the drive may be commanded, both ways (a drive measures its distance by it,
    so a reading that saturates below the commanded speed under-counts the distance
    and the robot drives on past its goal), and its current up to what a blocked wheel
    draws (``motion.drive_stall_current``; a drive tells a stall by it)."""
    out: list[tuple[KeyPath, str]] = []
    for b, board in enumerate(desc.boards):
        for j, motor in enumerate(board.motors):
            mode = motor.modes.velocity
            if motor.function is not MotorFunction.DRIVE or mode is None:
                continue
            path: KeyPath = ("boards", b, "motors", j, "feedback")
            velocity = motor.feedback.velocity
            if velocity is not None:
                back, fwd = mode.si_range
                if motor.limits.velocity is not None:
                    top = motor.limits.velocity.max
                    back, fwd = max(back, -top), min(fwd, top)
                lo, hi = velocity.si_range
                if not (lo - 1e-9 <= back and fwd <= hi + 1e-9):
                    out.append(
                        (
                            (*path, "velocity", "raw"),
                            f"velocity feedback of {motor.name!r} reads {_mm_s(lo)} .."
                            f" {_mm_s(hi)} mm/s, but the drive may be commanded {_mm_s(back)}"
                            f" .. {_mm_s(fwd)} mm/s (its velocity mode and limit): the"
                            " reading would saturate, under-count the distance driven and"
                            " the robot drive on past its goal",
                        )
                    )
            current = motor.feedback.current
            stall = desc.motion.drive_stall_current
            if current is not None:
                top = current.si_range[1]
                if top < stall * (1 - 1e-9):
                    out.append(
                        (
                            (*path, "current", "raw"),
                            f"current feedback of {motor.name!r} reads at most"
                            f" {top + 0.0:.3g} A, less than motion.drive_stall_current"
                            f" {stall:.3g} A (what a blocked wheel draws): a stalled or"
                            " stuck wheel would go unnoticed",
                        )
                    )
    return out


def _mm_s(value: float) -> str:
    return f"{value * 1000:.4g}"


def _reach(desc: Workable) -> list[tuple[KeyPath, str]]:
    """The joints must reach the angles a clamp needs: each wall-contact angle (a half's
    joints press until their wheels touch the wall there), the steer angle plus its
    tolerance (where a joint counts as steered into a turn), and the front tilt the front
    clear angle plus its tolerance (where a front clamp first tilts the front module)."""
    out: list[tuple[KeyPath, str]] = []
    bends = {m.name for m in desc.modules if m.role is Role.BEND}
    joints = [
        m
        for b in desc.boards
        if b.module in bends
        for m in b.motors
        if m.function is MotorFunction.BEND
    ]
    need = desc.clamp.min_torque
    for b, board in enumerate(desc.boards):
        for j, motor in enumerate(board.motors):
            if board.module not in bends or motor.function is not MotorFunction.BEND:
                continue
            path: KeyPath = ("boards", b, "motors", j)
            torque = motor.modes.torque
            if torque is None:
                out.append(
                    (
                        (*path, "modes"),
                        f"bend joint {motor.name!r} has no torque mode: a clamp presses the"
                        " wheels on the wall with joint torque",
                    )
                )
                continue
            reach = min(
                torque.si_range[1],
                *([motor.limits.torque.max] if motor.limits.torque is not None else []),
            )
            if reach < need * (1 - 1e-9):
                out.append(
                    (
                        (*path, "limits", "torque") if motor.limits.torque else (*path, "modes"),
                        f"bend joint {motor.name!r} presses with at most {reach:g} N*m (its"
                        f" torque limit and mode), less than clamp.min_torque {need:g} N*m:"
                        " no clamp could hold",
                    )
                )
    for k, point in enumerate(desc.clamp.contact_angles):
        for motor in joints:
            limit = motor.limits.angle
            if limit is not None and point.angle > limit.max + 1e-9:
                out.append(
                    (
                        ("clamp", "contact_angles", k, "angle"),
                        f"bend joint {motor.name!r} stops at {_deg(limit.max)} deg"
                        f" (limits.angle), short of the wall-contact angle"
                        f" {_deg(point.angle)} deg of a {point.diameter * 1000:g} mm pipe:"
                        " no half could clamp in it",
                    )
                )
                break
    steer = desc.motion.steer_angle + desc.safety.angle_tolerance
    for motor in joints:
        limit = motor.limits.angle
        if limit is not None and steer > limit.max + 1e-9:
            out.append(
                (
                    ("motion", "steer_angle"),
                    f"bend joint {motor.name!r} stops at {_deg(limit.max)} deg (limits.angle),"
                    f" short of {_deg(steer)} deg (motion.steer_angle +"
                    " safety.angle_tolerance), where a joint counts as steered into a turn:"
                    " no tree could steer a half into a bend or a T-joint",
                )
            )
            break
    front = desc.modules[0].name if desc.modules else None
    clear = desc.clamp.front_clear_angle + desc.safety.angle_tolerance
    for b, board in enumerate(desc.boards):
        for j, motor in enumerate(board.motors):
            limit = motor.limits.angle
            if board.module != front or motor.function is not MotorFunction.TILT:
                continue
            if limit is not None and clear > limit.max + 1e-9:
                out.append(
                    (
                        ("boards", b, "motors", j, "limits", "angle"),
                        f"front tilt {motor.name!r} stops at {_deg(limit.max)} deg, short of"
                        f" {_deg(clear)} deg (clamp.front_clear_angle +"
                        " safety.angle_tolerance), where a front clamp first tilts the"
                        " front module clear: no front clamp could start",
                    )
                )
    return out


def _freshness(desc: Workable) -> list[tuple[KeyPath, str]]:
    """No reading can be fresher than the last STATE frame: each reading's freshness
    limit (``safety.stale_after_periods`` × its period) and the link's silence limit
    must outlast a state period, or every run stops between two frames."""
    out: list[tuple[KeyPath, str]] = []
    period = desc.bridge.state_period
    factor = desc.safety.stale_after_periods
    tightest: tuple[float, str] | None = None
    for board in desc.boards:
        for sensor in board.sensors:
            limit = factor * sensor.period
            if limit <= period and (tightest is None or limit < tightest[0]):
                tightest = (limit, sensor.name)
    if tightest is not None:
        limit, name = tightest
        out.append(
            (
                ("bridge", "state_period"),
                f"a state frame every {_fmt_s(period)} is too slow for sensor {name!r}: its"
                f" readings count as stale after {_fmt_s(limit)} (safety.stale_after_periods"
                f" {factor:g} x its period), before the next frame brings a fresh one, so"
                " every run would stop on stale data; lengthen the sensor's period or"
                " shorten the state period",
            )
        )
    silence = desc.safety.max_link_silence
    if silence <= period:
        out.append(
            (
                ("safety", "max_link_silence"),
                f"max_link_silence {_fmt_s(silence)} is not longer than the state period"
                f" {_fmt_s(period)}: the link would count as lost between two state frames",
            )
        )
    watchdog = desc.bridge.watchdog
    if watchdog > silence * (1 + 1e-9):
        out.append(
            (
                ("bridge", "watchdog"),
                f"watchdog {_fmt_s(watchdog)} is longer than safety.max_link_silence"
                f" {_fmt_s(silence)}: on a lost link the host gives up after"
                f" {_fmt_s(silence)}, and the bridge alone can stop the wheels, after"
                f" {_fmt_s(watchdog)}; the robot would drive on blind meanwhile (make the"
                " watchdog no longer than the silence limit)",
            )
        )
    return out


def _sensor_ranges(desc: Workable) -> list[tuple[KeyPath, str]]:
    """The sensors the protective layer and the PABs read on a module (its first angle
    sensor, its first spring sensor: boards by id, then slot) must reach the values
    they are read for: a joint's angle limits, and the wall force of a holding clamp."""
    out: list[tuple[KeyPath, str]] = []
    first: dict[tuple[str, SensorKind], tuple[KeyPath, float, float]] = {}
    order = sorted(range(len(desc.boards)), key=lambda b: desc.boards[b].id)
    for b in order:
        board = desc.boards[b]
        for j in sorted(range(len(board.sensors)), key=lambda j: board.sensors[j].slot):
            sensor = board.sensors[j]
            lo, hi = sensor.conversion().si_range
            first.setdefault((board.module, sensor.kind), (("boards", b, "sensors", j), lo, hi))
    joints = {Role.BEND: MotorFunction.BEND, Role.ROTATIONAL: MotorFunction.ROTATE}
    force = desc.clamp.holding_force_n
    for module in desc.modules:
        function = joints.get(module.role)
        angle = first.get((module.name, SensorKind.ANGLE))
        if function is not None and angle is not None:
            path, lo, hi = angle
            for board in desc.boards:
                for motor in board.motors:
                    limit = motor.limits.angle
                    if board.module != module.name or motor.function is not function:
                        continue
                    if limit is not None and not lo - 1e-9 <= limit.min < limit.max <= hi + 1e-9:
                        out.append(
                            (
                                (*path, "raw"),
                                f"angle sensor of {module.name!r} reads {_deg(lo)} .. {_deg(hi)}"
                                f" deg, but its joint {motor.name!r} moves {_deg(limit.min)} .."
                                f" {_deg(limit.max)} deg (limits.angle): the host would misread"
                                " the joint where the sensor saturates",
                            )
                        )
        spring = first.get((module.name, SensorKind.SPRING))
        if module.role is Role.BEND and spring is not None:
            path, lo, hi = spring
            # a pressing wheel's force is positive (a reversed sensor has a negative
            # per_raw and reads it positive): a range that only reaches it as a
            # negative number saturates at its top, however large its magnitude
            if hi < force * (1 - 1e-9):
                out.append(
                    (
                        (*path, "raw"),
                        f"spring sensor of {module.name!r} reads at most"
                        f" {hi + 0.0:.3g} N, less than the wall force of a"
                        f" holding clamp, {force:.3g} N (clamp.min_torque / clamp.lever_arm):"
                        " no clamp of this half could ever be confirmed",
                    )
                )
    return out


def _deg(rad: float) -> str:
    return f"{math.degrees(rad):.4g}"


def motor_limit_problems(motor: Motor, path: KeyPath) -> list[tuple[KeyPath, str]]:
    """A motor's limits against its modes' raw ranges, and the modes and limits its
    function needs, each at its key under ``path``."""
    out: list[tuple[KeyPath, str]] = []
    lim = motor.limits

    def inside(limit_value: float, mode: ControlMode, what: str, key: str) -> None:
        conv = motor.modes.get(mode)
        if conv is None:
            return
        lo, hi = conv.si_range
        if not lo - 1e-12 <= limit_value <= hi + 1e-12:
            out.append(
                (
                    (*path, "limits", key),
                    f"motor {motor.name!r}: {what} limit {limit_value:g} lies outside the"
                    f" {mode} mode's raw range ({lo:g} .. {hi:g} in SI)",
                )
            )

    if lim.angle is not None:
        inside(lim.angle.min, ControlMode.POSITION, "angle", "angle")
        inside(lim.angle.max, ControlMode.POSITION, "angle", "angle")
    if lim.torque is not None:
        inside(lim.torque.max, ControlMode.TORQUE, "torque", "torque")
    if lim.velocity is not None:
        inside(lim.velocity.max, ControlMode.VELOCITY, "velocity", "velocity")
    if motor.function is MotorFunction.DRIVE and motor.modes.velocity is None:
        out.append(((*path, "modes"), f"drive motor {motor.name!r} needs a velocity mode"))
    if motor.function in (MotorFunction.BEND, MotorFunction.ROTATE):
        if motor.modes.position is None:
            out.append(((*path, "modes"), f"joint motor {motor.name!r} needs a position mode"))
        if lim.angle is None:
            out.append(((*path, "limits"), f"joint motor {motor.name!r} needs an angle limit"))
    return out
