"""The ``explore`` navigator's parts: its constants, its parameters' checks, and what
it keeps of the pipe passed (split out of :mod:`pirate_bt.task.explore`, the driving).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pirate_bt.errors import InputError
from pirate_bt.units import parse_quantity

__all__ = [
    "BACK_OUT_REACH_M",
    "OPENING_STOP",
    "Passed",
    "PendingTee",
    "SurveyIncomplete",
    "bend_angle_deg",
    "branch_leavable",
    "check_output",
    "invalid_network",
    "metres",
]

OPENING_STOP = (0.177, 0.55)
"""Where a straight step with ``stop_at_feature`` stops over a tee's opening: the
front tip ``a + b x diameter`` past the tee's start (the bundled robot at its
nominal speed, measured in 51 to 80 mm tees within 3 mm; the first front joint
swings off the wall over the opening's near edge, a little late)."""

BACK_OUT_REACH_M = 0.1075
"""How far behind the front half's trailing end the rear half's first bend module
clamps (the rotational module and half of bend III, the bundled robot): a branch is
left backwards only when half its diameter plus its turn's length is at most this."""


BEND_TOLERANCE_DEG = 3.0
"""A bend whose turn measured is within this of 90 degrees is written as a 90 degree
bend (the network default, no ``angle``)."""


def bend_angle_deg(direction: str, before_rad: float | None, after_rad: float | None) -> float:
    """The turn of a bend up or down, from the IMU's pitch before and after it, rounded
    to 1 degree; 90 for a bend left or right (the observation has no heading), without
    a reading, or within :data:`BEND_TOLERANCE_DEG` of 90.

    The IMU reads a pitch in [-90, 90] degrees: a turn past plumb (90 down from
    -2.8, -92.8) reads folded (-87.2), so both turns are candidates, and one within the
    tolerance of 90 is taken as 90.
    """
    if direction not in ("up", "down") or before_rad is None or after_rad is None:
        return 90.0
    sign = 1.0 if direction == "up" else -1.0
    before, after = math.degrees(before_rad), math.degrees(after_rad)
    turned = sign * (after - before)  # the pitch changed by it
    folded = sign * (sign * 180.0 - after - before)  # the turn went past plumb
    if any(abs(t - 90.0) <= BEND_TOLERANCE_DEG for t in (turned, folded)):
        return 90.0
    if not 0.5 <= turned < 90.0:  # no turn the survey can tell: as it was written
        return 90.0
    return float(round(turned))


def branch_leavable(diameter_m: float, radius_m: float | None = None) -> bool:
    """Can the robot back out of a tee's branch of this size (docs/pabs.md)?

    Raises:
        InputError: a diameter or radius that is not a positive number of metres.
    """
    for name, value in (("diameter_m", diameter_m), ("radius_m", radius_m)):
        if value is None and name == "radius_m":
            continue
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < 1e3:
            raise InputError(f"{name}: give a positive number of metres, not {value!r}"[:200])
    radius = diameter_m if radius_m is None else radius_m
    return diameter_m / 2 + math.pi * radius / 2 <= BACK_OUT_REACH_M + 1e-9


class SurveyIncomplete(RuntimeError):
    """The survey met what it cannot survey; what it surveyed is written."""


def check_output(output: Any) -> Path | None:
    """Where the surveyed network is written: a file name, not a directory.

    Raises:
        InputError: not a file name, or a directory (checked before the robot moves).
    """
    if output is None:
        return None
    if not isinstance(output, str | os.PathLike) or not str(os.fspath(output)).strip():
        raise InputError(f"explore: output: give a .yaml file name, not {output!r}"[:200])
    path = Path(output)
    if path.is_dir():
        raise InputError(f"explore: output: {path} is a directory; name a .yaml file")
    return path


def metres(value: str | float, what: str, dimension: str = "length") -> float:
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise InputError(f"explore: {what}: give a length such as '3 m', not {value!r}"[:200])
    try:
        number = float(value) if not isinstance(value, str) else parse_quantity(value, dimension)
    except (OverflowError, InputError) as exc:
        raise InputError(f"explore: {what}: {exc}"[:200]) from None
    if not math.isfinite(number) or number <= 0 or number > _MAX_LENGTH_M:
        shown = repr(value)[:80]
        raise InputError(
            f"explore: {what} must be positive and at most {_MAX_LENGTH_M:g} m, not {shown}"
        )
    return number


_MAX_LENGTH_M = 1000.0  # a step's longest drive (pirate_bt.task.navigation)


@dataclass
class Passed:
    """A feature passed on the way from the start: backed through on a return."""

    pab: str  # "bend-back" or "t-joint-back"
    way: str  # the bend's direction; a tee: straight or the branch's side
    end_m: float  # the belief where the feature ends (the rear tip goes past it)


@dataclass
class PendingTee:
    """A tee whose branch is not surveyed yet."""

    segment: dict[str, Any]
    start_m: float
    diameter_m: float
    slope_deg: float
    depth: int  # its own entry's index in the trail

    @property
    def side(self) -> str:
        return str(self.segment["branch"]["direction"])

    def __str__(self) -> str:
        return f"{self.segment['id']}'s branch ({self.side}, {self.diameter_m * 1000:.0f} mm)"


def invalid_network(spec: Any) -> str | None:
    """Why a surveyed network does not validate as a network file, or ``None``."""
    import re

    from pirate_bt.pipes.asbuilt import network_yaml
    from pirate_bt.pipes.loader import network_from_data

    try:
        network_from_data(yaml.safe_load(network_yaml(spec)), "surveyed")
    except InputError as exc:
        return re.sub(r"^surveyed(:\d+)*: ", "", str(exc))
    return None
