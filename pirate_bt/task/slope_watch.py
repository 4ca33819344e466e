"""Slopes the pipe has and the map does not: the IMU's pitch against the map's straights.

The localiser (:mod:`pirate_bt.task.localise`) compares the IMU with the map at turns
of 30 degrees or more; a straight that climbs 20 degrees where the map draws it level
changes nothing it matches on (the path's length is the same), and the mission goes
on. That is right for the mission, but the map is wrong, and a user should hear of
it. :class:`SlopeWatch` reads the IMU's pitch where the belief puts the IMU (the
rotational module) on a straight of the map, away from its ends, and notes a straight
whose pitch differs from the map's slope by more than :data:`SLOPE_NOTE_RAD` over at
least :data:`SLOPE_SPAN_M` of driving, once per straight. A note never stops a
mission: it is said in :attr:`~pirate_bt.task.mission_result.MissionResult.map_notes`
and the report's *Map and pipe* section.

Only a steady pitch counts (within :data:`SLOPE_STEADY_RAD` over the span): the IMU
swinging through a turn the belief has not reached yet is the localiser's to match.
"""

from __future__ import annotations

import math

from pirate_bt.pipes.network import Path as PipePath
from pirate_bt.pipes.network import Piece
from pirate_bt.robot.state import RobotState

__all__ = ["SLOPE_NOTE_RAD", "SLOPE_SPAN_M", "SLOPE_STEADY_RAD", "SlopeWatch"]

SLOPE_NOTE_RAD = math.radians(10.0)
"""A straight whose pitch differs from the map's slope by more is noted (an as-built
straight may differ by 3 degrees, :class:`pirate_bt.pipes.asbuilt.AsBuiltBounds`)."""

SLOPE_SPAN_M = 0.3
"""How far (belief, metres driven) the difference must hold to be noted."""

SLOPE_STEADY_RAD = math.radians(3.0)
"""How much the pitch may vary over that span and still be one slope."""

_END_MARGIN_M = 0.35
"""Distance kept from a straight's ends (the belief's tolerance after a fix, and the
IMU's module half-length)."""

_SAMPLE_M = 0.01


class SlopeWatch:
    """Notes straights of the map whose felt slope differs from the drawn one.

    Args:
        path: The mission's path on the map.
        imu_offset_m: How far the IMU sits behind the front tip.
    """

    def __init__(self, path: PipePath, imu_offset_m: float) -> None:
        self._imu_offset_m = imu_offset_m
        self._straights: list[tuple[float, float, float, Piece]] = []
        for piece in path.pieces:
            if piece.is_turn or piece.end_m - piece.start_m < 2 * _END_MARGIN_M + SLOPE_SPAN_M:
                continue
            slope = path.slope_at((piece.start_m + piece.end_m) / 2)
            self._straights.append(
                (piece.start_m + _END_MARGIN_M, piece.end_m - _END_MARGIN_M, slope, piece)
            )
        self.notes: list[str] = []
        """One line per straight noted, in the order found."""
        self._noted: set[str] = set()
        self._run: list[tuple[float, float]] = []  # (IMU belief, pitch) differing so far
        self._last: tuple[float, float, float, Piece] | None = None  # the straight now

    def update(self, state: RobotState | None, belief_m: float) -> None:
        """Read one state at the belief ``belief_m`` (the front tip's)."""
        if state is None or not self._straights:
            return
        pitch = state.imu_rad.get("pitch")
        s = belief_m - self._imu_offset_m
        found = self._last  # runs every tick: the straight of the tick before, first
        if found is None or not found[0] <= s <= found[1]:
            found = next((x for x in self._straights if x[0] <= s <= x[1]), None)
            if found is not self._last:
                self._run.clear()  # another straight (or none): a run starts afresh
            self._last = found
        if pitch is None or found is None or found[3].segment in self._noted:
            self._run.clear()
            return
        _, _, slope, piece = found
        if abs(pitch - slope) <= SLOPE_NOTE_RAD:
            self._run.clear()
            return
        if self._run and abs(s - self._run[-1][0]) < _SAMPLE_M:
            return  # one sample per centimetre driven: a robot standing adds nothing
        self._run.append((s, pitch))
        pitches = [p for _, p in self._run]
        if max(pitches) - min(pitches) > SLOPE_STEADY_RAD:
            self._run = [(s, pitch)]  # not one slope yet: start again from here
            return
        span = abs(self._run[-1][0] - self._run[0][0])
        if span < SLOPE_SPAN_M:
            return
        felt = sum(pitches) / len(pitches)
        start, end = sorted((self._run[0][0], self._run[-1][0]))
        self._noted.add(piece.segment)
        self.notes.append(
            f"straight {piece.segment!r}: the pipe slopes {_degrees(felt)} where the map"
            f" draws {_degrees(slope)} (felt from {start:.2f} to {end:.2f} m along the"
            " map, believed)"
        )
        self._run.clear()


def _degrees(rad: float) -> str:
    value = math.degrees(rad)
    if abs(value) < 0.5:
        return "0°"
    return f"{abs(value):.0f}° {'up' if value > 0 else 'down'}"
