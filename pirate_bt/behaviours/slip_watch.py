"""A drive's watch on wheel slip: the wheels turn while no half holds the robot.

PIRATE moves only on a half whose wheels the clamp presses on the wall. When no half
holds - the one half that held has a joint swung off the wall over a tee's opening
while the other half is released, say - the wheels turn in place: the robot stays
where it is (or slides down a slope) while the odometry counts distance it does not
travel. A drive that waits for a feature (a turn, a block) would spin its whole
search out, 3 m of odometry at 80 mm/s, and then fail as if the pipe had no
feature, its odometry far ahead of the robot.

The host reads it from the halves' clamp states (the supervisor's own reading of
the joint angles and springs, :func:`~pirate_bt.safety.checks.classify_half`): no
half clamped, with the drive commanding the wheels, for :data:`SLIP_S`.
:class:`GripWatch <pirate_bt.behaviours.grip.GripWatch>` names a joint that stopped
where it pressed (a stalled joint motor) sooner; this watch names the rest: a joint
off the wall (over an opening, or a pipe wider than the clamp reaches), a half
released or letting go.

In a steep pipe (an IMU pitch beyond ``motion.max_unclamped_slope``) there is no
window: a robot no half holds there slides down at once, so the first state that says
so ends the drive (a riser's tee whose branch was built off the drawing: the rear
half, the only one holding, reaches the opening and the robot slides on every step
it drives over it).
"""

from __future__ import annotations

import math

from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.robot.state import RobotState
from pirate_bt.safety import ClampState
from pirate_bt.safety.checks import classify_half
from pirate_bt.safety.supervisor_hold import why_half_holds_nothing

__all__ = ["SLIP_S", "SlipWatch"]

SLIP_S = 0.5
"""How long no half may hold the robot while the wheels are driven before the drive
fails (ten ticks at 20 Hz; longer than a stalled joint's
:data:`~pirate_bt.behaviours.grip.GRIP_LOST_S`, which names its own cause first)."""

_HOLDING = frozenset({ClampState.CLAMPED, ClampState.UNKNOWN})
"""A half that holds the robot, or whose readings cannot tell (counted as holding)."""


class SlipWatch:
    """Watches that some half holds the robot while a drive turns its wheels."""

    def __init__(self, robot: RobotDescription) -> None:
        self.robot = robot
        self._since: float | None = None
        self._from_m = 0.0  # odometry where no half held any more

    def update(self, state: RobotState, now_s: float, travelled_m: float) -> str | None:
        """Read one state ``travelled_m`` into the drive; the slip, for people, once it
        has lasted, else ``None``. A half whose clamp state cannot be read (a reading
        missing) counts as holding: a slip is called only on readings that say so."""
        robot = self.robot
        front = classify_half(robot, state, Half.FRONT)
        if front in _HOLDING:  # every drive tick: no dict, no generator (a drive's cost)
            self._since = None
            return None
        rear = classify_half(robot, state, Half.REAR)
        if rear in _HOLDING:
            self._since = None
            return None
        kinds = {Half.FRONT: front, Half.REAR: rear}
        if self._since is None:
            self._since = now_s
            self._from_m = travelled_m
        pitch = state.imu_rad.get("pitch")
        steep = pitch is not None and abs(pitch) > robot.motion.max_unclamped_slope
        if not steep and now_s - self._since < SLIP_S - 1e-9:
            return None
        halves = "; ".join(why_half_holds_nothing(robot, state, h, k) for h, k in kinds.items())
        if steep and pitch is not None:
            return (
                f"no half holds the robot after {self._from_m:.3f} m ({halves}): it slides"
                f" down the steep pipe (pitch {math.degrees(pitch):.0f}°)"
            )
        return (
            f"no half holds the robot after {self._from_m:.3f} m ({halves}): the wheels"
            " turn in place"
        )


def no_turn_felt(
    heading0: tuple[float, float, float] | None,
    heading: tuple[float, float, float] | None,
    turn_angle_rad: float,
) -> str:
    """What a slip means in a drive into a tee's branch (``stop_when_turned``) that felt
    no turn: the front half, steered one way, slid on over the opening, and the rear
    half reached it - the branch may leave on another side (the other side, or up or
    down). ``heading0`` and ``heading`` are the IMU's unit vectors along the pipe at the
    start and now."""
    turned = ""
    if heading0 is not None and heading is not None:
        dot = sum(a * b for a, b in zip(heading0, heading, strict=True))
        angle = math.degrees(math.acos(max(-1.0, min(1.0, dot))))
        turned = f" (the IMU turned {angle:.1f}° of the {math.degrees(turn_angle_rad):g}°)"
    return f"; no turn felt{turned}: the tee's branch may leave on another side than steered into"
