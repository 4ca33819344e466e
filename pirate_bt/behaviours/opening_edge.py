"""Where a drive's joint began to swing off the wall: the near edge of a tee's opening.

A drive ends on an opening (``until: front_opening``, ``rear_opening``) once a joint
of the leading half has swung past *every* wall-contact angle of the robot's clamp
table, since the host does not know the pipe's diameter. In a narrow pipe the wall
is far below that angle: in a 51 mm pipe the joint swings from 74° to past 104° at
its 90°/s, 0.35 s, in which the robot drives 28 mm on at 80 mm/s. The drive so
stops that much past the opening's near edge, and a fixed distance driven after it
(the front half across the opening, ``trees/lib/tee-straight.yaml``) takes the
other half's first joint that much nearer the opening: in a 51 mm riser it reached
the opening before the front half clamped, and the robot slid.

:class:`OpeningEdge` reads each joint of the leading half once a tick and keeps the
odometry of the last tick it was *not* swinging outwards (its angle grew by no more
than ``safety.angle_tolerance``, or half the joint's top rate over the tick,
whichever is less). When the drive ends on an opening, :meth:`OpeningEdge.past`
gives how far it has driven since the joint that found it left the wall: how far
past the near edge that joint is (to a tick's travel). A drive writes it with
``overshoot_key``; the next drive takes it off its distance with ``less_key``.
"""

from __future__ import annotations

from collections.abc import Iterable

from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.robot.state import RobotState

__all__ = ["OpeningEdge"]


class OpeningEdge:
    """Per joint of the watched halves: the travel of its last tick not swinging out."""

    def __init__(self, robot: RobotDescription, halves: Iterable[Half]) -> None:
        tolerance = robot.safety.angle_tolerance
        self._joints: list[tuple[str, float, float | None]] = []
        for half in halves:
            for module in robot.bend_modules(half):
                limit = robot.joint_motor(module.name).limits.angular_velocity
                rate = limit.max if limit is not None else None
                self._joints.append((module.name, tolerance, rate))
        self._last: dict[str, float] = {}  # joint -> |angle| at its last reading
        self._steady_at: dict[str, float] = {}  # joint -> travel of its last steady tick

    def update(self, state: RobotState, travelled: float, dt_s: float) -> None:
        """Read the joints once a tick, ``travelled`` metres into the drive."""
        angles = state.joint_angle_rad
        for name, tolerance, rate in self._joints:
            angle = angles.get(name)
            if angle is None:
                continue
            size = abs(angle)
            before = self._last.get(name)
            swing = tolerance if rate is None else min(tolerance, 0.5 * rate * dt_s)
            if before is None or size - before <= swing:
                self._steady_at[name] = travelled
            self._last[name] = size

    def past(self, off: Iterable[str], travelled: float) -> float:
        """How far the drive went since the first of the joints ``off`` (off the wall
        over an opening) began to swing off it; 0 when none was seen at the wall."""
        return max(
            (travelled - self._steady_at[n] for n in off if n in self._steady_at), default=0.0
        )
