"""The robot's names a guard refers to, checked against the robot description at load.

A comparison's ``state:`` may name a bend module, a drive motor or a motor
(``joint_angle.bend_1``, ``drive_velocity.bend_3_drive``, ``motor_current.rotate``), and
``state_fresh`` names state channels. A name the robot does not have used to load and
check clean, and fail only when the guard was ticked, with a message that blamed the
readings (*joint_angle.bend_9 has no reading*, *stale: nosuch*): the tree is now refused
at load, naming the file, line and column and the names the robot has.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pirate_bt.errors import shown
from pirate_bt.robot.description import Half, RobotDescription, SensorKind

__all__ = ["channel_problems", "state_problems"]

_WHAT = {
    "joint_angle": "bend modules with an angle sensor",
    "clamp_force": "bend modules with a spring sensor",
    "drive_velocity": "drive motors",
    "motor_current": "motors that report a current",
}


def _names(robot: RobotDescription, prefix: str) -> list[str] | None:
    """The names ``prefix.<name>`` may take on ``robot``; ``None`` for a fixed value."""
    if prefix in ("joint_angle", "clamp_force"):
        kind = SensorKind.ANGLE if prefix == "joint_angle" else SensorKind.SPRING
        out = []
        for module in (m for half in Half for m in robot.bend_modules(half)):
            try:
                robot.sensor_of(module.name, kind)
            except KeyError:
                continue
            out.append(module.name)
        return out
    if prefix == "drive_velocity":
        return [m.name for m in robot.drive_motors()]
    if prefix == "motor_current":
        channels = {c.name for c in robot.state_channels()}
        return [m.name for _, m in robot.motors() if f"{m.name}.current" in channels]
    return None


def state_problems(comparisons: Sequence[Any], robot: RobotDescription) -> list[str]:
    """``"condition: ..."`` for every comparison whose ``state:`` names what the robot
    has not (a module, a drive, a motor)."""
    problems: list[str] = []
    for comparison in comparisons:
        path = getattr(comparison, "state", None)
        if not path:
            continue
        prefix, _, rest = path.partition(".")
        names = _names(robot, prefix) if rest else None
        if names is not None and rest not in names:
            problems.append(
                f"condition: {shown(path)}: {shown(rest)} is none of the robot's"
                f" {_WHAT[prefix]} ({', '.join(names) or 'it has none'})"
            )
    return problems


def channel_problems(channels: Sequence[str], robot: RobotDescription) -> list[str]:
    """``"channels: ..."`` for every name that is none of the robot's state channels."""
    known = [c.name for c in robot.state_channels()]
    unknown = [c for c in channels if c not in known]
    if not unknown:
        return []
    import difflib

    hints = []
    for name in unknown:
        close = difflib.get_close_matches(name, known, n=1)
        hints.append(f"{shown(name)}" + (f" (did you mean {close[0]!r}?)" if close else ""))
    return [f"channels: the robot has no state channel {', '.join(hints)}"]
