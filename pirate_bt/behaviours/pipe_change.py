"""A drive's watch on the pipe changing under it (``stop_at_change``).

A survey's straight ends where the pipe changes: the IMU's pitch moves off its mean
at the start (a slope change at the rotational module), or a joint of the leading
half, at the wall, reads another diameter than it did at the start (a reducer).
:class:`PipeChangeWatch` reads one state a tick and says which, once it has lasted;
a slope change is placed where it began (:attr:`PipeChangeWatch.sensed_back_m`).
"""

from __future__ import annotations

import math
from collections import deque
from itertools import islice

from pirate_bt.behaviours.primitive import _SETTLE_TICKS
from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.robot.state import RobotState

__all__ = [
    "DIAMETER_CHANGE_M",
    "DIAMETER_SETTLE_M",
    "SLOPE_CHANGE_RAD",
    "SLOPE_WINDOW_TICKS",
    "PipeChangeWatch",
]

SLOPE_CHANGE_RAD = math.radians(0.25)
"""``stop_at_change``: the IMU's mean pitch this far off its mean at the start is a
slope change ..."""

SLOPE_WINDOW_TICKS = 16
"""... each mean over this many readings (one a tick: 0.8 s at 20 Hz, 64 mm at
80 mm/s): IMU noise of 0.11° (``SensorNoise.typical``) moves the difference of two
such means by 0.04°, a sixth of the threshold, so noise does not end a drive; a step
of the threshold is felt once the whole window is past it, and placed where it began
(:attr:`PipeChangeWatch.sensed_back_m`)."""

DIAMETER_CHANGE_M = 0.002
"""``stop_at_change``: a leading joint's diameter reading off by this much is a reducer ..."""

DIAMETER_SETTLE_M = 0.04
"""... when it stays off, the joint at the wall, over this much travel."""


class PipeChangeWatch:
    """Slope and diameter changes since a drive started, one state a tick (see the module)."""

    def __init__(self, robot: RobotDescription) -> None:
        self.robot = robot
        self._pitch0: float | None = None  # the mean of the first readings
        # (pitch, travelled) of the last readings: a window's mean and the history
        # the change is placed in once it is felt
        self._pitches: deque[tuple[float, float]] = deque(maxlen=2 * SLOPE_WINDOW_TICKS)
        self.sensed_back_m = 0.0
        """How far back (metres of travel) a sensed slope change began: 0 otherwise."""
        self._diameter0: dict[str, float] = {}
        self._change_ticks = 0
        self._diameter_from: float | None = None  # odometry where a diameter change began

    def changed(self, state: RobotState, velocity: float, travelled: float) -> str | None:
        """``slope`` once the mean pitch has changed (:data:`SLOPE_CHANGE_RAD`, means
        over :data:`SLOPE_WINDOW_TICKS` readings) for ``_SETTLE_TICKS`` ticks running,
        ``diameter`` once a leading joint's reading has stayed changed, at the wall, for
        :data:`DIAMETER_SETTLE_M` of travel (``stop_at_change``), else ``None``. The
        first readings are the reference. A joint swinging off the wall into a tee's
        opening passes through other readings on its way: it is off the wall (an
        opening stop) before that distance, where a cone keeps the change."""
        found: str | None = None
        pitch = state.imu_rad.get("pitch")
        if pitch is not None:
            self._pitches.append((pitch, travelled))
            kept = len(self._pitches)
            if kept >= SLOPE_WINDOW_TICKS:
                window = islice(self._pitches, kept - SLOPE_WINDOW_TICKS, None)
                mean = sum(p for p, _ in window) / SLOPE_WINDOW_TICKS
                if self._pitch0 is None:
                    self._pitch0 = mean
                elif abs(mean - self._pitch0) >= SLOPE_CHANGE_RAD:
                    found = "slope"
        clamp = self.robot.clamp
        tol = self.robot.safety.angle_tolerance
        wall_min = min(c.angle for c in clamp.contact_angles) - tol
        wall_max = max(c.angle for c in clamp.contact_angles) + tol
        leading = Half.FRONT if velocity > 0 else Half.REAR
        narrowed = False
        for module in self.robot.bend_modules(leading):
            angle = state.joint_angle_rad.get(module.name)
            if angle is None or not wall_min <= abs(angle) <= wall_max:
                continue
            diameter = clamp.diameter_for(angle)
            before = self._diameter0.setdefault(module.name, diameter)
            narrowed = narrowed or abs(diameter - before) >= DIAMETER_CHANGE_M
        if not narrowed:
            self._diameter_from = None
        elif self._diameter_from is None:
            self._diameter_from = travelled
        elif found is None and travelled - self._diameter_from >= DIAMETER_SETTLE_M:
            return "diameter"
        self._change_ticks = self._change_ticks + 1 if found else 0
        if found is None or self._change_ticks < _SETTLE_TICKS:
            return None
        self.sensed_back_m = travelled - self._slope_began()
        return found

    def _slope_began(self) -> float:
        """Where (travel) the pitch left its reference: the split of the readings kept
        into the reference before and one level after that fits them best (a mean's
        crossing comes up to a window late, more so for a small change)."""
        assert self._pitch0 is not None
        readings = list(self._pitches)
        pitches = [p for p, _ in readings]
        best, began = math.inf, readings[-1][1]
        before = 0.0  # squared error of the readings before the split, about the reference
        for k in range(len(readings)):
            after = pitches[k:]
            mean = sum(after) / len(after)
            error = before + sum((p - mean) ** 2 for p in after)
            if error < best:
                best, began = error, readings[k][1]
            before += (pitches[k] - self._pitch0) ** 2
        return began
