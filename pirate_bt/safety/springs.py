"""What a refusal says on a robot with no spring sensor on a half's bend modules.

Without springs the supervisor classifies a half by its joint angles alone
(:func:`~pirate_bt.safety.checks.classify_half`): a joint between
``clamp.unclamped_below`` and the smallest wall-contact angle is *transitioning*,
since a clamp closing passes there and nothing reads whether it presses. A half
steered into a turn (the bend PAB's 40 deg) is such a half, so every drive after it
is refused ``half_transitioning``; the refusal alone read as a fault of the run, not
as what the robot lacks. :func:`check_transitioning_explained` is
:func:`~pirate_bt.safety.checks.check_transitioning` with the missing sensors named.
"""

from __future__ import annotations

import math

from pirate_bt.robot.description import Half, RobotDescription, SensorKind
from pirate_bt.safety.checks import (
    INVARIANTS,
    Check,
    CheckContext,
    ClampState,
    Intent,
    Problem,
    check_transitioning,
)

__all__ = ["check_transitioning_explained", "default_checks", "unsprung_modules"]


def unsprung_modules(robot: RobotDescription, half: Half) -> list[str]:
    """The bend modules of ``half`` that have no spring sensor in the robot description."""
    missing: list[str] = []
    for module in robot.bend_modules(half):
        try:
            robot.sensor_of(module.name, SensorKind.SPRING)
        except KeyError:
            missing.append(module.name)
    return missing


def check_transitioning_explained(ctx: CheckContext, intent: Intent) -> Problem | None:
    """:func:`~pirate_bt.safety.checks.check_transitioning`, naming the missing spring
    sensors when a half without them is what it refuses the drive for."""
    problem = check_transitioning(ctx, intent)
    if problem is None:
        return None
    for half, state in sorted(ctx.halves.items()):
        missing = unsprung_modules(ctx.robot, half)
        if state is not ClampState.TRANSITIONING or not missing:
            continue
        clamp = ctx.robot.clamp
        angles = [ctx.state.joint_angle_rad.get(m.name) for m in ctx.robot.bend_modules(half)]
        shown = ", ".join(f"{math.degrees(a):.1f}°" for a in angles if a is not None)
        wall = min(c.angle for c in clamp.contact_angles)
        return Problem(
            problem.reason,
            f"{problem.detail}: the robot has no spring sensor on {', '.join(missing)} to"
            f" confirm a clamp, so the {half} half's joints at {shown} (neither below"
            f" clamp.unclamped_below {math.degrees(clamp.unclamped_below):.1f}° nor at the"
            f" wall, {math.degrees(wall):.1f}°) cannot be told from a clamp closing",
        )
    return problem


def default_checks() -> list[Check]:
    """The invariants a supervisor starts with: :data:`~pirate_bt.safety.checks.INVARIANTS`
    with the transition check that names missing spring sensors."""
    return [check_transitioning_explained if c is check_transitioning else c for c in INVARIANTS]
