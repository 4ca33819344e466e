"""The state invariants, as small pure functions over one snapshot.

The supervisor first turns a command into an :class:`Intent` - which halves it
clamps or releases, whether it rotates, drives or tilts the front module, and
which sensor channels a decision about it relies on. Each invariant is then a
function ``(CheckContext, Intent) -> Problem | None``; the first problem refuses
the command. They read the robot description for every number, so a robot with
other clamp angles or another slope threshold needs a new file, not new code.

A half's clamp state comes from its sensors (joint angles; spring forces where
the description has spring sensors) combined with what the supervisor last asked
of that half, see :func:`half_states`.

To add a check, write a function with the :data:`Check` signature and pass it to
:meth:`~pirate_bt.safety.supervisor.Supervisor.add_check` (or append it to
:data:`INVARIANTS` for every supervisor); see docs/safety.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import (
    ControlMode,
    Half,
    MotorFunction,
    RobotDescription,
    SensorKind,
)
from pirate_bt.robot.state import RobotState
from pirate_bt.safety.commands import Command
from pirate_bt.safety.verdict import Reason

__all__ = [
    "INVARIANTS",
    "Check",
    "CheckContext",
    "ClampState",
    "HalfTarget",
    "Intent",
    "Problem",
    "check_front_clear",
    "check_other_half_clamped",
    "check_rotate_one_clamped",
    "check_steep_pipe",
    "check_transitioning",
    "classify_half",
    "front_tilt_channel",
    "half_states",
    "is_steep",
    "off_wall_rad",
    "pressing_over_opening",
    "released_force_n",
    "sensed_half",
    "stale_channels",
]


class ClampState(StrEnum):
    """What a half is doing with the wall."""

    CLAMPED = "clamped"
    UNCLAMPED = "unclamped"
    TRANSITIONING = "transitioning"
    """Between unclamped and clamped, or on its way from one to the other."""
    UNKNOWN = "unknown"
    """A reading the classification needs is missing."""


class HalfTarget(StrEnum):
    """What the supervisor last asked a half to do."""

    CLAMP = "clamp"
    RELEASE = "release"


@dataclass(frozen=True, slots=True)
class Problem:
    """Why an invariant refuses a command."""

    reason: Reason
    detail: str


@dataclass(frozen=True)
class Intent:
    """What a command would do to the robot, in terms the invariants reason about.

    Attributes:
        command: The command asked for.
        motor_commands: Its expansion into motor commands (before limits).
        clamps: Halves it clamps.
        releases: Halves whose clamp it loosens (unclamp, bend, a low torque).
        presses: Halves whose wheels it may push against the wall: any torque on
            a bend joint (a joint in torque mode swings until the wall stops it) or
            a position target at or beyond the smallest wall-contact angle.
        rotates: It moves the rotational joint.
        drive_mps: Requested wheel speed if it drives (``None`` otherwise).
        front_tilt_rad: Requested front tilt if it tilts the front module.
        stop: It only stops drives.
        channels: Sensor channels the decision relies on (checked for freshness).
    """

    command: Command
    motor_commands: tuple[MotorCommand, ...]
    clamps: frozenset[Half] = frozenset()
    releases: frozenset[Half] = frozenset()
    presses: frozenset[Half] = frozenset()
    rotates: bool = False
    drive_mps: float | None = None
    front_tilt_rad: float | None = None
    stop: bool = False
    channels: tuple[str, ...] = ()

    @property
    def moves(self) -> bool:
        """True when the command can move a joint or the wheels."""
        return bool(
            self.clamps
            or self.releases
            or self.rotates
            or (self.drive_mps is not None and self.drive_mps != 0.0)
            or self.front_tilt_rad is not None
        )


@dataclass(frozen=True)
class CheckContext:
    """Everything an invariant may look at.

    Attributes:
        robot: The robot description.
        state: The current snapshot.
        now_s: Clock time of the decision.
        halves: Clamp state of each half.
        targets: What the supervisor last asked each half to do (none yet: absent).
        setpoints: The last setpoint sent to each motor, ``(mode, value, time)``: where
            a motor is still going after its reading (none sent yet: absent).
    """

    robot: RobotDescription
    state: RobotState
    now_s: float
    halves: Mapping[Half, ClampState] = field(default_factory=dict)
    targets: Mapping[Half, HalfTarget] = field(default_factory=dict)
    setpoints: Mapping[str, tuple[ControlMode, float, float]] = field(default_factory=dict)


Check = Callable[[CheckContext, Intent], Problem | None]
"""An invariant: ``None`` when the command may go, else the :class:`Problem`."""


def off_wall_rad(robot: RobotDescription) -> float:
    """The joint angle past which a bend joint is off the wall, over an opening (a tee's
    branch): past every wall-contact angle of the clamp table, with two angle tolerances
    to spare (the host does not know the pipe's diameter)."""
    return max(c.angle for c in robot.clamp.contact_angles) + 2 * robot.safety.angle_tolerance


def released_force_n(robot: RobotDescription) -> float:
    """The wall normal force below which a joint presses nothing:
    ``safety.release_force_fraction`` of the holding force (a half all below it is
    unclamped, :func:`classify_half`)."""
    return robot.safety.release_force_fraction * robot.clamp.holding_force_n


_LAST_STATE: tuple[RobotState | None, RobotDescription | None, dict[Half, ClampState]]
_LAST_STATE = (None, None, {})
"""The halves classified on the last state read: the supervisor's checks and hold, and a
drive's grip and slip watches, each classify the same state in a tick. Kept with the
state and the robot themselves (both immutable), so an entry is never served for
another; one tuple, read and replaced whole, so two runs in two threads do not mix."""


def classify_half(robot: RobotDescription, state: RobotState, half: Half) -> ClampState:
    """A half's clamp state from its sensors alone (:func:`sensed_half`), worked out
    once per state."""
    global _LAST_STATE
    last = _LAST_STATE
    if last[0] is state and last[1] is robot:
        known = last[2].get(half)
        if known is not None:
            return known
        found = last[2][half] = sensed_half(robot, state, half)
        return found
    found = sensed_half(robot, state, half)
    _LAST_STATE = (state, robot, {half: found})
    return found


def sensed_half(robot: RobotDescription, state: RobotState, half: Half) -> ClampState:
    """A half's clamp state from its sensors alone.

    With spring sensors on every bend module of the half, the normal force decides:
    at least the holding force (``min_torque / lever_arm``: the simulator's own
    threshold, see :meth:`~pirate_bt.robot.description.ClampConfig.holds_force`)
    on every wheel with every joint at or beyond the smallest wall-contact angle
    is clamped; below ``release_force_fraction`` of it
    everywhere is unclamped. Without springs the joint angles decide: all beyond
    the smallest contact angle is clamped, all below ``unclamped_below`` is
    unclamped. Anything else is transitioning.
    """
    clamp = robot.clamp
    modules, contact_min, released = _half_table(robot, half)
    signed: list[float] = []
    joint_angles = state.joint_angle_rad
    for name in modules:
        angle = joint_angles.get(name)
        if angle is None:
            return ClampState.UNKNOWN
        signed.append(angle)
    # The wheels of a pair press opposite walls only when its joints bend the same way;
    # joints at the wall on opposite sides do not hold the half.
    at_wall = all(a >= contact_min for a in signed) or all(a <= -contact_min for a in signed)
    forces = [state.clamp_force_n.get(name) for name in modules]
    if all(f is not None for f in forces) and forces:
        values = [abs(f) for f in forces if f is not None]
        if at_wall and all(clamp.holds_force(f) for f in values):
            return ClampState.CLAMPED
        if all(f < released for f in values):
            return ClampState.UNCLAMPED
        return ClampState.TRANSITIONING
    if at_wall:
        return ClampState.CLAMPED
    if all(abs(a) < clamp.unclamped_below for a in signed):
        return ClampState.UNCLAMPED
    return ClampState.TRANSITIONING


_HALF_TABLES: dict[tuple[int, Half], tuple[RobotDescription, tuple[tuple[str, ...], float, float]]]
_HALF_TABLES = {}


def _half_table(robot: RobotDescription, half: Half) -> tuple[tuple[str, ...], float, float]:
    """What :func:`classify_half` reads of the robot for ``half``, worked out once per
    robot (it runs on every tick): the bend modules' names, the smallest wall-contact
    angle less the angle tolerance, and :func:`released_force_n`. The robot is kept
    with its entry, so a later robot at the same address is never served its table."""
    key = (id(robot), half)
    entry = _HALF_TABLES.get(key)
    if entry is not None and entry[0] is robot:  # pragma: no mutate (a cache)
        return entry[1]
    tol = robot.safety.angle_tolerance
    table = (
        tuple(m.name for m in robot.bend_modules(half)),
        min(p.angle for p in robot.clamp.contact_angles) - tol,
        released_force_n(robot),
    )
    if len(_HALF_TABLES) >= 64:  # pragma: no mutate (a bound on memory, not a rule)
        _HALF_TABLES.clear()
    _HALF_TABLES[key] = (robot, table)  # pragma: no mutate (a cache)
    return table


def pressing_over_opening(robot: RobotDescription, state: RobotState, half: Half) -> bool:
    """Whether ``half`` holds the wall with some joints while the others press on
    nothing beyond it: the half crossing a tee's opening.

    Read with springs only (without them a joint pressing on nothing cannot be told
    from one at the wall). Every joint of the half is read and bends the same way;
    each either *holds* (at least the smallest wall-contact angle, less
    ``angle_tolerance``, and its spring at the holding force) or *presses on
    nothing* (its spring below the holding force while it is bent at least as far as
    the holding joints, less ``angle_tolerance``: it swings out over an opening, or
    back onto the wall behind it, not away from the wall); at least one does each.
    Its classification is *transitioning*, though no joint of it was asked to move.
    """
    clamp = robot.clamp
    tol = robot.safety.angle_tolerance
    wall_min = min(p.angle for p in clamp.contact_angles) - tol
    joints: list[tuple[float, float]] = []
    for module in robot.bend_modules(half):
        angle = state.joint_angle_rad.get(module.name)
        force = state.clamp_force_n.get(module.name)
        if angle is None or force is None:
            return False
        joints.append((angle, force))
    # Angles on the side the joints bend together: a joint bent the other way is
    # neither holding nor past the wall, so it ends the question below.
    side = math.copysign(1.0, sum(a for a, _ in joints))
    holding = [side * a for a, f in joints if side * a >= wall_min and clamp.holds_force(f)]
    if not holding or len(holding) == len(joints):
        return False
    wall = min(holding)
    return all(
        side * a >= wall - tol and not clamp.holds_force(f)
        for a, f in joints
        if not (side * a >= wall_min and clamp.holds_force(f))
    )


def half_states(
    robot: RobotDescription, state: RobotState, targets: Mapping[Half, HalfTarget]
) -> dict[Half, ClampState]:
    """Each half's clamp state: its sensors, corrected by what it was last asked to do.

    A half asked to clamp that is not yet clamped, or asked to release that still
    holds, is transitioning even if its sensors alone would say otherwise.
    """
    out: dict[Half, ClampState] = {}
    for half in Half:
        sensed = classify_half(robot, state, half)
        target = targets.get(half)
        if (target is HalfTarget.CLAMP and sensed is ClampState.UNCLAMPED) or (
            target is HalfTarget.RELEASE and sensed is ClampState.CLAMPED
        ):
            sensed = ClampState.TRANSITIONING
        out[half] = sensed
    return out


def front_tilt_channel(robot: RobotDescription) -> str | None:
    """The state channel that reads the front tilt (``None`` if the robot has no tilt motor)."""
    front = robot.modules[0].name
    try:
        motor = robot.motor_of(front, MotorFunction.TILT)
    except KeyError:
        return None
    board = robot.board_of(motor.name)
    for sensor in board.sensors:
        if sensor.slot == motor.slot and sensor.kind is SensorKind.ANGLE:
            return sensor.name
    try:
        return robot.sensor_of(front, SensorKind.ANGLE).name
    except KeyError:
        return None


def is_steep(robot: RobotDescription, state: RobotState) -> bool:
    """True when the pipe is steeper than ``motion.max_unclamped_slope``.

    Without an IMU pitch reading the pipe is taken as steep: the check then
    errs on the side of keeping a half clamped.
    """
    pitch = state.imu_rad.get("pitch")
    return pitch is None or abs(pitch) > robot.motion.max_unclamped_slope


def stale_channels(
    robot: RobotDescription, state: RobotState, names: tuple[str, ...], now_s: float
) -> list[tuple[str, float]]:
    """``(channel, age_s)`` for each of ``names`` older than its freshness limit.

    A channel is stale when its last fresh reading is older than
    ``safety.stale_after_periods`` times its sensor period.
    """
    periods = robot.channel_periods_s()
    default = robot.bridge.state_period  # a name that is no channel: the frame's period
    factor = robot.safety.stale_after_periods
    out: list[tuple[str, float]] = []
    for name in names:
        period = periods.get(name, default)
        age = state.age_s(name, now_s)
        if not math.isfinite(age) or age > factor * period:
            out.append((name, age))
    return out


# -- the invariants ----------------------------------------------------------


def loosened(ctx: CheckContext, intent: Intent) -> frozenset[Half]:
    """The halves whose hold ``intent`` loosens.

    A clamp that swings a half's joints across to the other side lets go on the way
    (:attr:`Intent.releases`), but a half known to be unclamped has nothing to let go
    of: clamping it is no release. Without that, the clamp that would stop a robot
    sliding in a steep pipe with no half clamped was refused as a release.
    """
    return frozenset(
        h
        for h in intent.releases
        if not (h in intent.clamps and ctx.halves.get(h) is ClampState.UNCLAMPED)
    )


def check_steep_pipe(ctx: CheckContext, intent: Intent) -> Problem | None:
    """Never both halves unclamped in a pipe steeper than ``motion.max_unclamped_slope``."""
    if not intent.moves or not is_steep(ctx.robot, ctx.state):
        return None
    clamped = {h for h, s in ctx.halves.items() if s is ClampState.CLAMPED}
    pitch = ctx.state.imu_rad.get("pitch")
    where = "no pitch reading" if pitch is None else f"pitch {math.degrees(pitch):.1f}°"
    limit = math.degrees(ctx.robot.motion.max_unclamped_slope)
    releases = loosened(ctx, intent)
    if releases and not (clamped - releases):
        return Problem(
            Reason.STEEP_PIPE_UNCLAMPED,
            f"releasing the {'/'.join(sorted(releases))} half would leave no half"
            f" clamped in a steep pipe ({where} > {limit:.1f}°)",
        )
    if not clamped and not intent.clamps:
        return Problem(
            Reason.STEEP_PIPE_UNCLAMPED,
            f"no half is clamped in a steep pipe ({where} > {limit:.1f}°): clamp first",
        )
    return None


def check_other_half_clamped(ctx: CheckContext, intent: Intent) -> Problem | None:
    """A half may unclamp or bend only while the other half is clamped."""
    for half in sorted(loosened(ctx, intent)):
        other = ctx.halves.get(half.other, ClampState.UNKNOWN)
        if other is not ClampState.CLAMPED:
            return Problem(
                Reason.OTHER_HALF_NOT_CLAMPED,
                f"the {half} half may unclamp or bend only while the {half.other} half is"
                f" clamped (it is {other})",
            )
    return None


def check_rotate_one_clamped(ctx: CheckContext, intent: Intent) -> Problem | None:
    """Rotation only with exactly one half clamped and the other free."""
    if not intent.rotates:
        return None
    states = dict(ctx.halves)
    clamped = [h for h, s in states.items() if s is ClampState.CLAMPED]
    if len(clamped) != 1:
        return Problem(
            Reason.ROTATE_NEEDS_ONE_CLAMPED,
            f"rotation needs exactly one half clamped ({len(clamped)} are:"
            f" front {states.get(Half.FRONT)}, rear {states.get(Half.REAR)})",
        )
    free = clamped[0].other
    if states.get(free) is not ClampState.UNCLAMPED:
        return Problem(
            Reason.HALF_TRANSITIONING,
            f"rotation needs the {free} half free, but it is {states.get(free)}",
        )
    return None


def check_transitioning(ctx: CheckContext, intent: Intent) -> Problem | None:
    """No drive while a half is between unclamped and clamped.

    But for one case, which is no transition: a half asked to clamp that presses the
    wall wherever there is wall while a joint of it swings free over a tee's opening
    (:func:`pressing_over_opening`) may drive while the other half is clamped; the
    clamped half holds the robot, and the pressing half senses the opening passed.
    """
    if intent.drive_mps is None or intent.drive_mps == 0.0:
        return None
    for half, state in sorted(ctx.halves.items()):
        if state is ClampState.UNKNOWN or (
            state is ClampState.TRANSITIONING and not _crossing_opening(ctx, half)
        ):
            return Problem(
                Reason.HALF_TRANSITIONING,
                f"no drive while the {half} half is {state} (between unclamped and clamped)"
                + (_unsprung(ctx, half) if state is ClampState.TRANSITIONING else ""),
            )
    return None


def _unsprung(ctx: CheckContext, half: Half) -> str:
    """Why a half is transitioning on a robot with no spring sensor on some of its bend
    modules (``""`` when every one has one): its joints between ``unclamped_below`` and
    the wall cannot be told from a clamp closing (the bend PAB's 40 deg turn, a drive
    after it refused with nothing to say it was the robot, before 2026-11-30)."""
    robot = ctx.robot
    missing: list[str] = []
    for module in robot.bend_modules(half):
        try:
            robot.sensor_of(module.name, SensorKind.SPRING)
        except KeyError:
            missing.append(module.name)
    if not missing:
        return ""
    angles = [ctx.state.joint_angle_rad.get(m.name) for m in robot.bend_modules(half)]
    shown = ", ".join(f"{math.degrees(a):.1f}°" for a in angles if a is not None)
    clamp = robot.clamp
    wall = min(c.angle for c in clamp.contact_angles)
    return (
        f": the robot has no spring sensor on {', '.join(missing)} to confirm a clamp, so"
        f" the {half} half's joints at {shown} (neither below clamp.unclamped_below"
        f" {math.degrees(clamp.unclamped_below):.1f}° nor at the wall,"
        f" {math.degrees(wall):.1f}°) cannot be told from a clamp closing"
    )


def _crossing_opening(ctx: CheckContext, half: Half) -> bool:
    return (
        ctx.halves.get(half.other) is ClampState.CLAMPED
        and ctx.targets.get(half) is HalfTarget.CLAMP
        and pressing_over_opening(ctx.robot, ctx.state, half)
    )


def check_front_clear(ctx: CheckContext, intent: Intent) -> Problem | None:
    """The front module must be clear before the front half presses the wall, and stay clear.

    Pressing includes more than a clamp: any torque on a front bend joint, and a
    position target at the wall, push the front wheels on the wall too.
    """
    if front_tilt_channel(ctx.robot) is None:
        return None
    clear = ctx.robot.clamp.front_clear_angle - ctx.robot.safety.angle_tolerance
    if Half.FRONT in intent.clamps or Half.FRONT in intent.presses:
        tilt = ctx.state.front_tilt_rad
        # where its last setpoint still takes it counts as where it is: a tilt back from
        # clear, sent a moment before, swings the module into the wheels' way after a
        # clamp checked on the reading alone (front_pressed damage, before 2026-11-30)
        going = _tilt_setpoint(ctx)
        if tilt is None or not _clear_path(tilt, going, clear):
            shown = "unknown" if tilt is None else f"{math.degrees(tilt):.1f}°"
            if tilt is not None and going is not None and going != tilt:
                shown += f", on its way to {math.degrees(going):.1f}°"
            return Problem(
                Reason.FRONT_NOT_CLEAR,
                f"move the front module clear (|tilt| >= "
                f"{math.degrees(ctx.robot.clamp.front_clear_angle):.1f}°, it is {shown})"
                " before the front half clamps or presses the wall",
            )
    target = intent.front_tilt_rad
    if target is not None:
        front = ctx.halves.get(Half.FRONT, ClampState.UNKNOWN)
        now = ctx.state.front_tilt_rad
        # The module moves from where it is to the target (rate-limited on the way), so
        # the whole path must stay clear: same side, both ends beyond the clear angle.
        path_clear = (
            now is not None
            and abs(target) >= clear
            and abs(now) >= clear
            and math.copysign(1.0, target) == math.copysign(1.0, now)
        )
        if front is not ClampState.UNCLAMPED and not path_clear:
            return Problem(
                Reason.FRONT_NOT_CLEAR,
                f"the front module may leave its clear position only while the front half is"
                f" unclamped (it is {front})",
            )
    return None


def _tilt_setpoint(ctx: CheckContext) -> float | None:
    """The front tilt's last position setpoint (``None``: none, or not a position)."""
    try:
        motor = ctx.robot.motor_of(ctx.robot.modules[0].name, MotorFunction.TILT)
    except KeyError:
        return None
    last = ctx.setpoints.get(motor.name)
    return last[1] if last is not None and last[0] is ControlMode.POSITION else None


def _clear_path(tilt: float, going: float | None, clear: float) -> bool:
    """The module is clear where it reads and, when a setpoint moves it, all the way
    there: both beyond the clear angle, on the same side."""
    if abs(tilt) < clear:
        return False
    return going is None or (
        abs(going) >= clear and math.copysign(1.0, going) == math.copysign(1.0, tilt)
    )


INVARIANTS: list[Check] = [
    check_steep_pipe,
    check_other_half_clamped,
    check_rotate_one_clamped,
    check_transitioning,
    check_front_clear,
]
"""The invariants every supervisor starts with, in the order they are checked."""
