"""A drive's watch on the grip it drives with: no half holds, because a joint stopped.

A drive moves the robot only while a clamped half presses its wheels on the wall.
When the one half that holds lets go (its bend joint's motor stalls, say), the
wheels spin on: the robot stays where it is (or slides) and the odometry counts
distance not travelled. What failed later then looks like something else: a map
that has the bend too near, a search that met no feature.

The host reads the cause in the springs and the joint angles: a joint that pressed
the wall now reads no force (below ``safety.release_force_fraction`` of the
holding force) and has not moved (within ``safety.angle_tolerance`` of where it
last pressed), while no half is clamped by its readings. A joint over a tee's
opening, or at a wider pipe, swings on and is not taken for this; a half released
on purpose moves its joints away from the wall. Without spring readings nothing
can be seen. :class:`GripWatch` says so once it has lasted :data:`GRIP_LOST_S`.
"""

from __future__ import annotations

import math

from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.robot.state import RobotState
from pirate_bt.safety import ClampState
from pirate_bt.safety.checks import classify_half, released_force_n

__all__ = ["GRIP_LOST_S", "GripWatch"]

GRIP_LOST_S = 0.25
"""How long no half may hold, with a joint stopped where it pressed, before a drive
fails (five ticks at 20 Hz: one reading is not believed)."""

_HALVES = tuple(Half)  # iterating the enum itself costs a generator on every tick


class GripWatch:
    """Watches the halves a drive holds with, one state at a time (see the module)."""

    def __init__(self, robot: RobotDescription) -> None:
        self.robot = robot
        self._held: set[Half] = set()
        self._pressed_at: dict[str, float] = {}  # joint -> angle where it last pressed
        self._since: float | None = None

    def update(self, state: RobotState, now_s: float) -> str | None:
        """Read one state; the lost grip, for people, once it has lasted, else ``None``."""
        robot = self.robot
        clamp = robot.clamp
        holding = False
        for half in _HALVES:
            if classify_half(robot, state, half) is ClampState.CLAMPED:
                holding = True
                self._held.add(half)
            for module in robot.bend_modules(half):
                angle = state.joint_angle_rad.get(module.name)
                force = state.clamp_force_n.get(module.name)
                if angle is not None and force is not None and clamp.holds_force(force):
                    self._pressed_at[module.name] = angle
        stopped = [] if holding else self._stopped(state)
        if not stopped:
            self._since = None
            return None
        if self._since is None:
            self._since = now_s
        if now_s - self._since < GRIP_LOST_S - 1e-9:
            return None
        half, name, angle, force = stopped[0]
        return (
            f"grip lost: no half holds the robot: {name} presses {force:.1f} N at"
            f" {math.degrees(angle):.1f}°, stopped where it pressed the wall (the {half}"
            f" half's joint does not press: a stalled joint motor?); the wheels would slip"
        )

    def _stopped(self, state: RobotState) -> list[tuple[Half, str, float, float]]:
        """Joints of a half that held, now pressing nothing where they pressed."""
        robot = self.robot
        released_n = released_force_n(robot)
        tol = robot.safety.angle_tolerance
        out: list[tuple[Half, str, float, float]] = []
        for half in sorted(self._held):
            for module in robot.bend_modules(half):
                angle = state.joint_angle_rad.get(module.name)
                force = state.clamp_force_n.get(module.name)
                pressed = self._pressed_at.get(module.name)
                if angle is None or force is None or pressed is None:
                    continue
                if abs(force) < released_n and abs(angle - pressed) <= tol:
                    out.append((half, module.name, angle, force))
        return out
