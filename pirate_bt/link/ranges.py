"""Readings no valid ``STATE`` carries: a fresh value outside its channel's raw range.

The CRC finds most damage, not all (about one damaged frame in 65 536 passes it), and
not a forged frame. A channel's raw range is the robot description's (``raw`` of the
sensor or feedback conversion): a board reads nothing outside it, so a fresh reading
outside it is damage, never a measurement. :class:`ReadingRanges` refuses such a
reading before it becomes SI: the channel counts as not fresh in that frame (the last
reading taken stays, with its old stamp, so the freshness rules see its age) and the
link counts it (``RobotLink.readings_refused``). Before 2026-11-30 it was converted and
taken: a ``STATE`` saying 32767 for an angle sensor of raw range 0..4095 gave its
joint an angle of 47 rad.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from operator import itemgetter

from pirate_bt.link.messages import State
from pirate_bt.robot.description import RobotDescription

__all__ = ["ReadingRanges"]

_log = logging.getLogger("pirate_bt.link.robot_link")


class ReadingRanges:
    """The raw range of each state channel of ``robot``, in wire order."""

    def __init__(self, robot: RobotDescription) -> None:
        channels = robot.state_channels()
        self._names = tuple(c.name for c in channels)
        self._lows = tuple(c.conversion.raw[0] for c in channels)
        self._highs = tuple(c.conversion.raw[1] for c in channels)
        # The fast check: the channels grouped by range (a few groups), each group's
        # values fetched in one C call and bounded by its min and max; a channel of
        # int16's whole range needs no check (the IMU's is ±π, -31416..31416, since
        # 2026-11-30: a STATE saying 32767 said pitch 188°).
        groups: dict[tuple[int, int], list[int]] = {}
        for i, bounds in enumerate(zip(self._lows, self._highs, strict=True)):
            if bounds != (-32768, 32767):
                groups.setdefault(bounds, []).append(i)
        self._groups = tuple((lo, hi, _getter(ix)) for (lo, hi), ix in groups.items())
        self._said: set[str] = set()  # channels whose refusal was logged, until back in range
        self.refused = 0
        """Fresh readings refused since the link opened."""

    def readings(
        self, frame: State, *, older: bool = False, quiet: bool = False
    ) -> list[int | None]:
        """``frame``'s raw readings, ``None`` where the channel is not fresh or its value
        lies outside the channel's raw range (refused: counted, and logged once until
        the channel reads in range again). ``older``: a frame older than one already
        checked (folded into a snapshot after the newest), whose readings in range say
        nothing of the channel now: they do not end its refusal's silence (before
        2026-11-30 such a frame made the next older one out of range logged again).
        ``quiet``: a frame read again (a snapshot of it built once more): a refusal is
        neither counted nor logged a second time (implies ``older``)."""
        raw = frame.readings()
        values = frame.raw_values
        for lo, hi, get in self._groups:
            group = get(values)
            if min(group) < lo or max(group) > hi:
                break
        else:
            if self._said and not (older or quiet):
                self._said.clear()
            return raw
        for i, value in enumerate(raw):
            name = self._names[i]
            if value is None or self._lows[i] <= value <= self._highs[i]:
                if not (older or quiet):
                    self._said.discard(name)
                continue
            raw[i] = None
            if quiet:
                continue
            self.refused += 1
            if name not in self._said:
                self._said.add(name)
                _log.warning(
                    "STATE seq %d: %s reads %d, outside its raw range %d..%d: not taken"
                    " (a damaged or forged frame that passed the CRC, or a board that"
                    " does not match the robot description)",
                    frame.seq,
                    name,
                    value,
                    self._lows[i],
                    self._highs[i],
                )
        return raw


def _getter(indices: list[int]) -> Callable[[Sequence[int]], Sequence[int]]:
    """The values at ``indices``, as a sequence (one index too)."""
    if len(indices) == 1:
        (i,) = indices
        return lambda values: (values[i],)
    get: Callable[[Sequence[int]], Sequence[int]] = itemgetter(*indices)
    return get
