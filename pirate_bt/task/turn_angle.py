"""A turn the map has, felt sharper than drawn: named as that turn, not as a new one.

The localiser (:mod:`pirate_bt.task.localise`) fixes on a turn when the IMU has swung
by half its drawn angle, and takes the heading after it as the reference once the
rotational module is past the turn's end on the map. A bend built at 90 degrees where
the map draws 45 goes on turning after that: the IMU swings 30 degrees more just past
the mapped turn, and the localiser stopped the mission on *the pipe turned by 30 deg
at 1.90 m (believed), where the map has no turn within 0.34 m*, though the map's bend
was right behind the robot and the pipe is not as drawn *there*. :func:`overturned`
names it: the whole swing from the heading before the turn, against the turn's drawn
angle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pirate_bt.task.fixes import Vec3, angle_between, roll_name
from pirate_bt.task.planner import MapFeature

__all__ = ["FixedTurn", "overturned"]


@dataclass(frozen=True, slots=True)
class FixedTurn:
    """The last turn the localiser fixed on, and the IMU's heading before it."""

    feature: MapFeature
    before: Vec3


def overturned(
    last: FixedTurn | None, tangent: Vec3, imu_m: float, reach_m: float, belief_m: float
) -> tuple[str, str, MapFeature] | None:
    """The mismatch and what was sensed, when a swing just past ``last`` is that turn's.

    Args:
        last: The last turn fixed on (``None``: none yet).
        tangent: The pipe's direction at the IMU now.
        imu_m: Where the belief puts the rotational module.
        reach_m: The localiser's reach now.
        belief_m: The belief (the front tip).

    Returns:
        ``(mismatch, sensed, the turn)``, or ``None`` when the swing is not just past ``last``
        (the rotational module more than ``reach_m`` beyond its end on the map).
    """
    if last is None or imu_m - last.feature.end_m > reach_m:
        return None
    turn = last.feature
    total = math.degrees(angle_between(tangent, last.before))
    drawn = math.degrees(turn.angle_rad)
    mismatch = (
        f"belief and map disagree: the pipe turned by {total:.0f} deg at {belief_m:.2f} m"
        f" (believed) through what the map has as {turn.segment!r}, drawn turning"
        f" {roll_name(turn.roll_rad)} by {drawn:.0f} deg: the turn there is sharper than"
        " drawn (or a turn the map does not have follows it)"
    )
    return mismatch, f"a turn of {total:.0f} deg through {turn.segment!r}", turn
