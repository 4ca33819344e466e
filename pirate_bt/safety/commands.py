"""High-level commands in SI units: what behaviours and operators ask the supervisor for.

A behaviour never names a motor. It asks for an effect - clamp the front half at
0.5 N·m, drive at 60 mm/s, rotate the halves to 30° - and the
:class:`~pirate_bt.safety.supervisor.Supervisor` checks the request, then expands
it into :class:`~pirate_bt.robot.commands.MotorCommand` objects for the motors
that play that role in the robot description. Teleop and tools that need one
particular motor use :class:`Raw`, which goes through the same checks.

Every command is a frozen dataclass, so it can be logged, compared and stored in
a trace as it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import TypeVar

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import Half

_E = TypeVar("_E", bound=Enum)

__all__ = [
    "Bend",
    "Clamp",
    "Command",
    "Drive",
    "MoveFrontClear",
    "Raw",
    "Rotate",
    "Stop",
    "Tilt",
    "Unclamp",
    "describe",
]


@dataclass(frozen=True, slots=True)
class Clamp:
    """Press a half's wheels against the wall: torque mode on the half's bend joints.

    Attributes:
        half: Which half clamps.
        torque_nm: Joint torque; at least the description's ``clamp.min_torque``.
    """

    half: Half
    torque_nm: float


@dataclass(frozen=True, slots=True)
class Unclamp:
    """Release a half: move its bend joints back to straight (position mode, rate limited).

    Attributes:
        half: Which half releases.
        angle_rad: Joint angle to move to (0 = straight).
    """

    half: Half
    angle_rad: float = 0.0


@dataclass(frozen=True, slots=True)
class Drive:
    """Drive every wheel at one speed; negative drives backwards."""

    velocity_mps: float


@dataclass(frozen=True, slots=True)
class Bend:
    """Set the joint angle of one bend module (position mode, rate limited)."""

    module: str
    angle_rad: float


@dataclass(frozen=True, slots=True)
class Rotate:
    """Set the angle between the two halves (position mode, rate limited)."""

    angle_rad: float


@dataclass(frozen=True, slots=True)
class Tilt:
    """Set the front module's tilt angle (position mode, rate limited)."""

    angle_rad: float


@dataclass(frozen=True, slots=True)
class MoveFrontClear:
    """Tilt the front module clear: ``clamp.front_clear_angle`` plus ``safety.angle_tolerance``.

    The margin makes a position loop that settles within its tolerance of the target
    still end at least at the clear angle.

    Attributes:
        sign: +1 or -1: to which side the front module swings out of the way.
    """

    sign: int = 1


@dataclass(frozen=True, slots=True)
class Stop:
    """Stop every drive motor; clamps and joints hold. Always passes."""


@dataclass(frozen=True, slots=True)
class Raw:
    """One motor command by motor name (teleop, tools); checked like everything else."""

    command: MotorCommand


Command = Clamp | Unclamp | Drive | Bend | Rotate | Tilt | MoveFrontClear | Stop | Raw
"""Every command type the supervisor accepts."""


def describe(command: Command) -> str:
    """A short human form of a command, e.g. ``clamp(front, 0.5 N·m)``.

    A malformed one (``Drive("fast")``, which the supervisor refuses) or something that
    is no command at all is shown as its ``repr``: the verdict that refuses it is
    logged and traced like any other."""
    try:
        return _describe(command)
    except (TypeError, ValueError, AttributeError, OverflowError):  # 10**400 is no float
        try:
            return repr(command)[:200]
        except ValueError:  # an integer of more digits than Python turns into text
            return f"{type(command).__name__}(a number too long to show)"


def _describe(command: Command) -> str:
    match command:
        case Clamp(half, torque):
            return f"clamp({half}, {torque:g} N·m)"
        case Unclamp(half, angle):
            return f"unclamp({half})" if angle == 0 else f"unclamp({half}, {angle:g} rad)"
        case Drive(v):
            return f"drive({v * 1000:g} mm/s)"
        case Bend(module, angle):
            return f"bend({module}, {angle:g} rad)"
        case Rotate(angle):
            return f"rotate({angle:g} rad)"
        case Tilt(angle):
            return f"tilt({angle:g} rad)"
        case MoveFrontClear(sign):
            return f"move_front_clear({'+' if sign >= 0 else '-'})"
        case Stop():
            return "stop()"
        case Raw(mc):
            return f"raw({mc.motor}, {mc.mode}, {mc.value:g})"
    raise TypeError(f"not a command: {command!r}")


def member_of(kind: type[_E], value: object) -> _E | None:
    """``value`` as a member of ``kind`` (the member, or its value as text:
    ``"front"`` for ``Half.FRONT``), or ``None`` when it is neither.

    What a command holds may come from a user's Python, YAML or a console: every
    enumerated field of a command (a half, a control mode, a source, a mode) is read
    through here, so that text is taken for what it names and anything else is refused
    by the caller, never compared by identity as it stands.
    """
    if isinstance(value, kind):
        return value
    try:
        return kind(value)
    except (ValueError, TypeError):
        return None
