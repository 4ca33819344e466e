"""The ``explore`` navigator's turns, written in the network's frame, not the IMU's.

A survey finds a turn's way by the IMU (``probe-turn``, ``probe-tee`` try up, down,
left and right as the IMU reads roll: from gravity's up in the cross-section). A
network file's rolls are in the pipe's own frame, carried along without twisting
(docs/networks.md); after a bend left or right on a slope, or a bend at a roll other
than the four, that frame is twisted off gravity's (a bend right on a 20 deg slope
twists it 20 deg). There a turn the IMU found "up" is at roll -20 deg in the frame,
and a survey that wrote it ``direction: up`` wrote another network than the pipe: a
mission planned on it aligned the bend PAB 20 deg off the bend's plane and stopped on a
false map disagreement. :func:`write_in_frame` writes such a turn with its ``roll`` in
the frame, so the planner (which turns a roll back into the IMU's:
:attr:`pirate_bt.pipes.Piece.imu_roll_rad`) gives the PAB the roll the survey found.
"""

from __future__ import annotations

import math
from typing import Any

from pirate_bt.errors import InputError
from pirate_bt.pipes import DIRECTION_ROLL_RAD, Direction

__all__ = [
    "SIDE_TOLERANCE_DEG",
    "TWIST_WRITTEN_DEG",
    "frame_twist_rad",
    "imu_side",
    "write_in_frame",
]

TWIST_WRITTEN_DEG = 5.0
"""A turn found where the surveyed frame is twisted more than this off gravity's up is
written with its ``roll`` in the frame; within it, with the IMU's direction word. The
probes find a turn within ``motion.alignment_tolerance`` (8 deg) of the roll they try,
so a turn written either way is within 8 deg of the pipe's (a pipe drawn ``up`` in a
frame twisted 3 deg, as an as-built variant's slopes twist it, keeps ``up``)."""

SIDE_TOLERANCE_DEG = 8.0
"""A tee's branch written as a ``roll`` leaves on one of the four sides the survey
takes when the IMU reads that roll within this of the side (the 2018 robot's
``motion.alignment_tolerance``; a survey writes the roll it found within 0.05 deg).
Further off (a hand-edited ``roll: -45 deg``) it leaves on none of them."""


def frame_twist_rad(
    segments: list[dict[str, Any]], diameter_m: float | None, segment_id: str
) -> float | None:
    """How far the IMU's roll is ahead of the frame's at ``segment_id``'s start in the
    network surveyed so far (``imu = frame + twist``), or ``None`` when it cannot be
    built or has no such segment."""
    from pirate_bt.pipes import Network
    from pirate_bt.pipes.model import NetworkSpec

    data = {
        "schema_version": 1,
        "name": "surveyed",
        "diameter": f"{(diameter_m or 0.063) * 1000:.1f} mm",
        "segments": segments,
    }
    try:
        network = Network(NetworkSpec.model_validate(data))
    except (ValueError, InputError):  # pydantic's ValidationError is a ValueError
        return None
    for path in network.paths():
        for piece in path.pieces:
            if piece.segment == segment_id:
                return math.remainder(piece.imu_roll_rad - piece.roll_rad, 2 * math.pi)
    return None


def write_in_frame(
    segments: list[dict[str, Any]], diameter_m: float | None, segment_id: str, turn: dict[str, Any]
) -> None:
    """``turn`` (a bend, or a tee's ``branch``) holds the IMU's ``direction``: write its
    ``roll`` in the network's frame instead where the frame is twisted more than
    :data:`TWIST_WRITTEN_DEG` off gravity's at ``segment_id``."""
    twist = frame_twist_rad(segments, diameter_m, segment_id)
    if twist is None or abs(math.degrees(twist)) <= TWIST_WRITTEN_DEG:
        return
    imu = DIRECTION_ROLL_RAD[Direction(turn.pop("direction"))]
    turn["roll"] = f"{math.degrees(math.remainder(imu - twist, 2 * math.pi)):.1f} deg"


def imu_side(segments: list[dict[str, Any]], diameter_m: float | None, tee: dict[str, Any]) -> str:
    """The side a tee's branch leaves on as the IMU reads it: its ``direction``, or, for
    one written with its ``roll`` in a twisted frame, the one of the four within
    :data:`SIDE_TOLERANCE_DEG` of that roll as the IMU reads it (``"None"`` when it
    cannot be told, or is none of the four: it read a roll of -45 deg as ``up``)."""
    branch = tee.get("branch") or {}
    if branch.get("direction") is not None or "roll" not in branch:
        return str(branch.get("direction"))
    from pirate_bt.units import parse_quantity

    twist = frame_twist_rad(segments, diameter_m, str(tee.get("id")))
    try:
        roll = float(parse_quantity(str(branch["roll"]), "angle"))
    except (ValueError, InputError):
        return "None"
    if twist is None:
        return "None"
    imu = roll + twist
    for direction, cardinal in DIRECTION_ROLL_RAD.items():
        if abs(math.remainder(imu - cardinal, 2 * math.pi)) <= math.radians(SIDE_TOLERANCE_DEG):
            return str(direction.value)
    return "None"
