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

A bend built *less* sharp than drawn (45 degrees where the map draws 90, or 45
degrees up where it draws a riser) was fixed on all the same, once the IMU had swung
by half the drawn angle, and the mission then completed with the pipe heading 45
degrees off the map's and nothing said. :func:`undershot` compares the whole swing
with the map's once the rotational module is :data:`CHECK_AFTER_M` past the turn (and
no other turn of the map is there yet): a difference of :data:`ANGLE_DIFFERENCE_RAD`
(15 degrees) or more either way is a disagreement, less sharp or sharper than drawn.
It was 30 degrees, the threshold of a turn the map lacks, and one way only: a bend
drawn 90 degrees and built 60 (or drawn 60 and built 90, a plumb riser the map has
at 60 degrees) sat on the threshold, and the mission completed. A bend built so much
less sharp that the IMU never swings by half its drawn angle (40 degrees where the top
of a riser draws 90) was never fixed on, and a short leg after it ended before the
localiser's reach did: the mission completed. A swing of 30 degrees or more near the
map's next turn, held within :data:`STEADY_RAD` over :data:`CHECK_AFTER_M` of driving
(the pipe turned, and turns no further), is that turn, less sharp than drawn
(:meth:`TurnWatch.short`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from pirate_bt.pipes.network import Path as PipePath
from pirate_bt.task.fixes import Vec3, angle_between, roll_name
from pirate_bt.task.planner import MapFeature

__all__ = [
    "ANGLE_DIFFERENCE_RAD",
    "CHECK_AFTER_M",
    "STEADY_RAD",
    "TURN_DIFFERENCE_RAD",
    "FixedTurn",
    "TurnWatch",
    "imu_evidence",
    "overturned",
    "undershot",
    "unmapped_turn",
]

CHECK_AFTER_M = 0.3
"""How far past a turn's end on the map the rotational module is when its whole swing
is compared with the map's (past the belief's error after a fix, 0.10 m, and the rest
of a turn built longer than drawn)."""

TURN_DIFFERENCE_RAD = math.radians(30.0)
"""A turn whose whole swing differs from the map's by this much or more is not as
drawn (the localiser's threshold for a turn the map lacks)."""

ANGLE_DIFFERENCE_RAD = math.radians(15.0)
"""A turn fixed on whose whole swing, the rotational module past it, differs from the
map's by this much or more, either way, is not as drawn (:func:`undershot`). Past the
turn the swing is read on straight pipe, to the IMU's noise (0.11 degrees): what else
moves it is the slope of the straights on either side, which an as-built variant
tilts by up to 3 degrees each (:mod:`pirate_bt.pipes.asbuilt`), 6 degrees at most
between them, 12 at twice the bounds."""

STEADY_RAD = math.radians(2.0)
"""A heading held within this over :data:`CHECK_AFTER_M` of driving is steady (a bend's
swing moves it by 2 degrees in 3 mm of a 90 mm radius)."""


@dataclass(slots=True)
class FixedTurn:
    """The last turn the localiser fixed on, and the IMU's heading before it."""

    feature: MapFeature
    before: Vec3
    checked: bool = field(default=False)
    """Its whole swing was compared with the map's (:func:`undershot`)."""


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


def undershot(
    last: FixedTurn | None, tangent: Vec3, imu_m: float, path: PipePath, belief_m: float
) -> tuple[str, str, MapFeature] | None:
    """The mismatch, what was sensed and the turn, when ``last`` turned otherwise than
    drawn: less sharp, or sharper, by :data:`ANGLE_DIFFERENCE_RAD` or more.

    Compared once, the first time the rotational module is :data:`CHECK_AFTER_M` past
    the turn's end on the map with no other turn of the map begun; the map's swing is
    its own tangents' (a slope drawn on the straight after the turn counts).
    """
    if last is None or last.checked:
        return None
    turn = last.feature
    if imu_m < turn.end_m + CHECK_AFTER_M:
        return None
    last.checked = True
    ahead = path.next_turn(turn.end_m + 1e-6)
    if ahead is not None and ahead.start_m <= imu_m:
        return None  # the map turns again there: its next turn is the matcher's
    start = max(0.0, turn.start_m - 1e-6)
    drawn = angle_between(path.tangent_at(imu_m), path.tangent_at(start))
    felt = angle_between(tangent, last.before)
    if abs(drawn - felt) < ANGLE_DIFFERENCE_RAD:
        return None
    mismatch = (
        f"belief and map disagree: the pipe turned by {math.degrees(felt):.0f} deg at"
        f" {turn.segment!r} ({belief_m:.2f} m believed), where the map has it turning"
        f" {roll_name(turn.roll_rad)} by {math.degrees(drawn):.0f} deg: the turn there is"
        f" {'less sharp' if felt < drawn else 'sharper'} than drawn"
    )
    return mismatch, f"a turn of {math.degrees(felt):.0f} deg through {turn.segment!r}", turn


def unmapped_turn(
    swung: float,
    where_m: tuple[float, float],
    reach_m: float,
    ahead: MapFeature | None,
    placed: str = "",
) -> str:
    """The mismatch of a turn felt where the map has none within ``reach_m``.

    ``where_m``: the belief (the front tip) and the rotational module's place, where the
    turn was felt; ``ahead``: the map's next turn, named with how far on it is drawn
    (it was not named: a turn drawn 0.7 m further on, built nearer, read as a turn
    the map does not have at all); ``placed``: where the belief is on the map, after
    *(believed* (:func:`~pirate_bt.task.where_believed.after_fix`).
    """
    belief_m, imu_m = where_m
    text = (
        f"belief and map disagree: the pipe turned by {math.degrees(swung):.0f} deg"
        f" at {belief_m:.2f} m (believed{placed}), where the map has no turn within {reach_m:.2f} m"
    )
    if ahead is not None and ahead.start_m > imu_m:
        text += (
            f"; the map's next turn, {ahead.segment!r}, is drawn {ahead.start_m - imu_m:.2f} m"
            f" further on (at {ahead.start_m:.2f} m): is the pipe before it shorter than drawn,"
            " or is this a turn the map does not have?"
        )
    return text


def imu_evidence(imu_rad: Mapping[str, float], imu_m: float) -> str:
    """The IMU's reading at the rotational module, for a disagreement's evidence."""
    return (
        f"IMU pitch {math.degrees(imu_rad.get('pitch', 0.0)):.1f} deg, yaw"
        f" {math.degrees(imu_rad.get('yaw', 0.0)):.1f} deg at the rotational"
        f" module ({imu_m:.2f} m)"
    )


class TurnWatch:
    """The localiser's check of the turns' angles against the map's, as it goes.

    Args:
        path: The mission's path on the map.
    """

    def __init__(self, path: PipePath) -> None:
        self.path = path
        self.last: FixedTurn | None = None
        """The last turn fixed on (set by the localiser)."""
        self._steady: tuple[Vec3, float] | None = None

    def overturned(
        self, tangent: Vec3, imu_m: float, reach_m: float, belief_m: float
    ) -> tuple[str, str, MapFeature] | None:
        """:func:`overturned` for the last turn fixed on."""
        return overturned(self.last, tangent, imu_m, reach_m, belief_m)

    def short(
        self,
        near: MapFeature | None,
        swung: float,
        tangent: Vec3,
        where_m: tuple[float, float, float],
        drawn_slope: Callable[[], bool],
    ) -> tuple[str, str, MapFeature] | None:
        """A turn less sharp than drawn, fixed on (:func:`undershot`) or not.

        Args:
            near: The map's next turn, when the rotational module is within its reach.
            swung: The IMU's swing since the heading before it.
            tangent: The pipe's direction at the IMU now.
            where_m: The rotational module's place, the belief and the distance driven.
            drawn_slope: Whether the IMU's heading is a slope the map draws there.
        """
        imu_m, belief_m, driven_m = where_m
        found = undershot(self.last, tangent, imu_m, self.path, belief_m)
        if found is not None or near is None:
            self._steady = None
            return found
        if self._steady is None or angle_between(tangent, self._steady[0]) > STEADY_RAD:
            self._steady = (tangent, driven_m)
            return None
        if driven_m - self._steady[1] < CHECK_AFTER_M or swung < TURN_DIFFERENCE_RAD:
            return None
        if swung >= near.angle_rad / 2 or near.angle_rad - swung < TURN_DIFFERENCE_RAD:
            return None  # the localiser's to fix on
        if drawn_slope():
            return None  # a change of slope the map draws, not this turn
        felt, drawn = math.degrees(swung), math.degrees(near.angle_rad)
        mismatch = (
            f"belief and map disagree: the pipe turned by {felt:.0f} deg and no further"
            f" near {near.segment!r} ({belief_m:.2f} m believed), where the map has it"
            f" turning {roll_name(near.roll_rad)} by {drawn:.0f} deg: the turn there is"
            " less sharp than drawn"
        )
        return mismatch, f"a turn of {felt:.0f} deg near {near.segment!r}", near
