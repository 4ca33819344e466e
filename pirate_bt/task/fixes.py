"""What the localiser reports, and the IMU geometry it reads.

:class:`Fix` (one correction of the belief at a recognised feature) and
:class:`Disagreement` (where belief and map parted) are what a mission's result
and report carry; :func:`imu_tangent` and the small vector helpers turn the IMU's
pitch and yaw into the pipe's direction and name a turn's way. The matching
itself is :class:`pirate_bt.task.localise.Localiser`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "Disagreement",
    "Fix",
    "ShortLeg",
    "Vec3",
    "angle_between",
    "cross",
    "imu_tangent",
    "roll_name",
    "wrap_angle",
]

Vec3 = tuple[float, float, float]


def imu_tangent(imu_rad: dict[str, float] | None) -> Vec3 | None:
    """The pipe's direction at the IMU, from its pitch and yaw (``None`` without an IMU)."""
    if not imu_rad or "pitch" not in imu_rad or "yaw" not in imu_rad:
        return None
    pitch, yaw = imu_rad["pitch"], imu_rad["yaw"]
    return (math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch))


def cross(a: Vec3, b: Vec3) -> Vec3:
    """The cross product ``a x b``."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def wrap_angle(angle: float) -> float:
    """``angle`` in ``[-pi, pi)``."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


_ROLL_NAMES = ((0.0, "up"), (math.pi / 2, "right"), (math.pi, "down"), (-math.pi / 2, "left"))


def roll_name(roll_rad: float) -> str:
    """The nearest of up, right, down and left for a turn's roll."""
    return min(_ROLL_NAMES, key=lambda named: abs(wrap_angle(roll_rad - named[0])))[1]


def angle_between(a: Vec3, b: Vec3) -> float:
    """The angle between two unit vectors (radians)."""
    dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    return math.acos(max(-1.0, min(1.0, dot)))


@dataclass(frozen=True, slots=True)
class Fix:
    """One correction of the belief at a recognised feature.

    Attributes:
        time_s: Clock time of the fix.
        feature: Segment id of the feature.
        how: ``imu`` (a turn) or ``joints`` (a T-joint's opening).
        before_m: Belief just before the fix.
        after_m: Belief after it.
        truth_m: Simulator truth at the fix, when known.
        since_fix_m: Distance driven since the previous fix (or the start).
        confidence: How well the place fits the map: ``exp(-z**2 / 2)``, ``z`` the
            correction over half the stated tolerance (1 where the map has it, 0.14 at
            the tolerance's edge, lower out in the matcher's reach).
    """

    time_s: float
    feature: str
    how: str
    before_m: float
    after_m: float
    truth_m: float | None = None
    since_fix_m: float = 0.0
    confidence: float = 1.0

    @property
    def error_after_m(self) -> float | None:
        """Belief minus truth after the fix."""
        return None if self.truth_m is None else self.after_m - self.truth_m

    @property
    def correction_m(self) -> float:
        return self.after_m - self.before_m

    @property
    def drift_per_m(self) -> float:
        """The correction per metre driven since the previous fix (map error plus odometry)."""
        return self.correction_m / self.since_fix_m if self.since_fix_m > 0 else 0.0


@dataclass(frozen=True, slots=True)
class ShortLeg:
    """A forward straight leg that stopped blocked short of the distance it was to drive.

    Attributes:
        leg: The PAB's node name (``03 inspect 2 m (line 3)``).
        asked_m: The distance it was given when it started.
        travelled_m: How far its drive had travelled when it was blocked.
        takes: The turn the route takes next (segment id; ``None`` when the next PAB
            past the straights is no turn): a block there is that turn, met early.
        to_end: The leg goes to the end of the line (a block near the map's end is
            taken for it).
    """

    leg: str
    asked_m: float
    travelled_m: float
    takes: str | None
    to_end: bool


@dataclass(frozen=True, slots=True)
class Disagreement:
    """Where belief and map parted.

    Attributes:
        time_s: Clock time it was found.
        belief_m: The belief then (on the map's path).
        expected: The feature the map has there (``"bend 'bend-a' at 4.00-4.14 m"``),
            or ``None`` when the map has none.
        sensed: What the sensors found (``"a turn of 88 deg"``, ``"an opening"``), or
            ``None`` when they found nothing.
        evidence: The sensor readings behind it, for people.
        window_m: The tolerance it was searched within.
        feature: The map feature's segment id, if any.
        sensed_at_m: Where on the map the sensed feature is (an opening: where the
            module that felt it is), if anything was sensed there.
        sensed_by: The module whose sensor felt it.
    """

    time_s: float
    belief_m: float
    expected: str | None
    sensed: str | None
    evidence: str
    window_m: float
    feature: str | None = None
    sensed_at_m: float | None = None
    sensed_by: str | None = None

    def describe(self) -> str:
        """One line: ``belief and map disagree at 4.62 m: ...``."""
        # the feature expected may be far beyond the window (the map's next tee, 10 m
        # on): 'the map has it within 0.89 m' said it was there
        map_has = (
            f"the map expected {self.expected} (searched within {self.window_m:.2f} m)"
            if self.expected is not None
            else f"the map has no feature within {self.window_m:.2f} m"
        )
        sensed = self.sensed or "nothing"
        return (
            f"belief and map disagree at {self.belief_m:.2f} m (believed): {map_has}, the"
            f" robot sensed {sensed} ({self.evidence})"
        )
