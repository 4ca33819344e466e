"""The ``explore`` navigator's parts: its constants, its parameters' checks, what
it keeps of the pipe passed, and the network file it writes (split out of
:mod:`pirate_bt.task.explore`, the driving), and the notes of what a stop leaves
unsurveyed.
"""

from __future__ import annotations

import contextlib
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pirate_bt.errors import InputError
from pirate_bt.task.explore_extend import NOT_SURVEYED
from pirate_bt.units import parse_quantity

__all__ = [
    "APPROACH_M",
    "BACK_OUT_REACH_M",
    "CONE_M",
    "CONE_PASS_M",
    "ENDS_UNSURE",
    "MARGIN_M",
    "OPENING_STOP",
    "PROBE_BEFORE_M",
    "PROBE_OVER_M",
    "PROBE_WIDEST_M",
    "SETTLED_M",
    "Passed",
    "PendingTee",
    "SurveyIncomplete",
    "bend_angle_deg",
    "branch_leavable",
    "check_output",
    "ends_note",
    "invalid_network",
    "left_by_a_stop",
    "metres",
    "rear_over_opening",
    "slipped_over",
    "tee_start",
    "unprobed_opening",
    "write_survey",
]

APPROACH_M = 0.25
"""Where a turn into a branch starts: the front tip this far before the middle of
the opening (the planner's ``approach_m``)."""

MARGIN_M = 0.25
"""How far short of a feature a return's straight drive stops: the backward PAB
searches the rest (up to 3 m) with its own sensing."""

SETTLED_M = 0.05
"""A change felt this close after the feature before is the robot leaving that feature."""

CONE_M = 0.05
"""A reducer's cone length, written (the network default; the robot does not measure it)."""

CONE_PASS_M = 0.25
"""How far the robot drives through a reducer before the front half reads its diameter."""

OPENING_STOP = (0.177, 0.55)
"""Where a straight step with ``stop_at_feature`` stops over a tee's opening: the
front tip ``a + b x diameter`` past the tee's start (the bundled robot at its
nominal speed, measured in 51 to 80 mm tees within 3 mm; the first front joint
swings off the wall over the opening's near edge, a little late)."""

PROBE_BEFORE_M = 0.062
"""Where ``probe-tee`` holds the robot to probe: the front tip up to this far before the
middle of the opening (52 to 62 mm in 51 to 63 mm tees; 77 mm on a link with delay),
the rear half alone holding."""

PROBE_OVER_M = 0.01
"""A probe is not tried where, by the survey's lengths (good to about this), the rear
half's last joint would be this far or more onto the opening of the tee before: two
51 mm tees 0.3 m apart, 26 mm onto it (the probe was refused); not two 63 mm tees
0.3 m apart, 3.5 mm clear of it as built (the probe tells the branch)."""

PROBE_WIDEST_M = 0.085
"""``probe-tee`` feels a branch's turn in tees up to about this diameter (the bundled
robot, a branch's radius one diameter: 80 mm found, 90 and 100 mm not). The IMU, on
the rotational module, must turn 8 degrees into the branch while bend III, 70 mm behind
it, still holds the wall short of the opening (the front half hangs free); the turn
starts in the middle of the opening, and in a wider tee that is too far on."""

BACK_OUT_REACH_M = 0.1075
"""How far behind the front half's trailing end the rear half's first bend module
clamps (the rotational module and half of bend III, the bundled robot): a branch is
left backwards only when half its diameter plus its turn's length is at most this."""


BEND_TOLERANCE_DEG = 3.0
"""A bend whose turn measured is within this of 90 degrees is written as a 90 degree
bend (the network default, no ``angle``)."""


def bend_angle_deg(
    direction: str,
    before_rad: float | None,
    after_rad: float | None,
    *,
    yaw_rad: tuple[float | None, float | None] = (None, None),
) -> float:
    """The turn of a bend, from the IMU before and after it, rounded to 1 degree: up or
    down from its pitch, left or right from its heading and pitch (``yaw_rad``, before
    and after: the angle between the pipe's two directions); 90 without a reading, or
    within :data:`BEND_TOLERANCE_DEG` of 90.

    The IMU reads a pitch in [-90, 90] degrees: a turn past plumb (90 down from
    -2.8, -92.8) reads folded (-87.2), so both turns are candidates, and one within the
    tolerance of 90 is taken as 90.
    """
    if before_rad is None or after_rad is None:
        return 90.0
    if direction in ("left", "right"):
        return _side_turn_deg((before_rad, yaw_rad[0]), (after_rad, yaw_rad[1]))
    if direction not in ("up", "down"):
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


def _side_turn_deg(before: tuple[float, float | None], after: tuple[float, float | None]) -> float:
    """A bend left or right: the angle between the pipe's directions (pitch, heading)
    either side of it, as :func:`bend_angle_deg` rounds it."""
    (p0, y0), (p1, y1) = before, after
    if y0 is None or y1 is None:
        return 90.0
    dot = math.cos(p0) * math.cos(p1) * math.cos(y1 - y0) + math.sin(p0) * math.sin(p1)
    turned = math.degrees(math.acos(max(-1.0, min(1.0, dot))))
    if abs(turned - 90.0) <= BEND_TOLERANCE_DEG or not 0.5 <= turned < 90.0:
        return 90.0  # 90, or no turn the survey can tell: as it was written
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
    if path.exists() and not path.is_file():
        raise InputError(f"explore: output: {path} is not a regular file (a pipe or a device)")
    # the folder it goes in, made when the survey is written: the nearest folder on its
    # way that exists must be one this process can write in (a survey of 42 steps ended
    # on 'No such file or directory' before 2026-12-01, nothing written)
    for parent in path.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"explore: output: {path}: {parent} is not a directory")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise InputError(f"explore: output: {path}: cannot write in {parent}")
            break
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
    imu_side: str | None = None  # the side probe-tee found (the file may hold a roll)

    @property
    def side(self) -> str:
        """The side the branch leaves on, as the IMU reads it (what the PAB turns)."""
        return self.imu_side or str(self.segment["branch"].get("direction"))

    def __str__(self) -> str:
        return f"{self.segment['id']}'s branch ({self.side}, {self.diameter_m * 1000:.0f} mm)"


def tee_start(opening_m: float, diameter_m: float) -> float:
    """Where a tee starts whose opening a straight step felt at ``opening_m``."""
    return opening_m - (OPENING_STOP[0] + OPENING_STOP[1] * diameter_m)


UNPROBED_MARGIN_M = 0.03
"""An opening a joint felt this far or more past where the line's straight began (the
feature before it ends there) is one no step stopped at."""


def unprobed_opening(off_wall: Any, from_m: float) -> Any:
    """The first opening a forward step carried a joint across, past ``from_m`` (where
    the straight being surveyed began), with the joint back at the wall behind it: an
    opening no step stopped at, so no probe told its branch (a second tee close after
    the one passed straight on). A joint still off the wall as the step ended is not
    one: the next straight step starts over it and stops there. ``None``: none."""
    for episode in off_wall:
        if episode.back_m is not None and episode.where_m > from_m + UNPROBED_MARGIN_M:
            return episode
    return None


def slipped_over(why: str, openings: Any, from_m: float) -> tuple[Any, str] | None:
    """The opening past ``from_m`` that a failed step's joint swung off the wall over,
    when the step failed because no half held the robot there (the drive's slip, its
    joints named over an opening), with the slip's words (``slipping: no half holds the
    robot after 0.086 m``); ``None`` for any other failure."""
    slip = why.find("slipping: no half holds the robot")
    if slip < 0 or "over an opening" not in why:
        return None
    crossed = next((o for o in openings if o.where_m > from_m + UNPROBED_MARGIN_M), None)
    return None if crossed is None else (crossed, why[slip:].split(" (")[0])


def rear_over_opening(tee: PendingTee, before: Passed | None, rear_joint_m: float) -> str | None:
    """Why the robot does not turn into ``tee``'s branch: where such a turn starts, its
    rear half's last joint (at ``rear_joint_m``) would be over the opening of the tee
    passed straight on just ``before`` it, with no wall to clamp (a mission is not
    planned there either); ``None`` when it is clear of it."""
    if before is None or before.pab != "t-joint-back" or before.way != "straight":
        return None
    if rear_joint_m >= before.end_m - tee.diameter_m + 0.01:  # the opening's far edge
        return None
    return (
        f"{tee}: not entered, the tee starts {tee.start_m - before.end_m:.2f} m after the"
        " tee before it, and a turn into its branch would start with the rear half over"
        " that tee's opening"
    )


ENDS_UNSURE = "the line ends here, or turns at a roll the survey does not try"
"""What a line's end found may be: ``probe-turn`` tries four rolls, and a bend at
another (45 deg, 100 deg...) blocks every one of them as a cap does."""


def ends_note(ends: list[str]) -> str:
    """What the lines' ends found may be (``""``: none found)."""
    if not ends:
        return ""
    return f"{ENDS_UNSURE}: {'; '.join(ends)} (the survey tries only up, down, left and right)"


def left_by_a_stop(
    line: str | None, tees: list[Any], on_the_way: bool, extension: Any
) -> list[str]:
    """What a survey that stops here leaves unsurveyed, each named with why.

    Args:
        line: The line the robot was in and where it was up to (``None``: none).
        tees: The tees met and not entered, the next to enter first.
        on_the_way: A second insertion on its way to the stub it surveys (the tees
            met then are surveyed ones).
        extension: That insertion's :class:`~pirate_bt.task.explore_extend.Extension`
            (``None``: a first insertion).
    """
    out: list[str] = []
    if line is not None:
        out.append(f"{line}: not surveyed to its end, the survey stopped in it")
    if not on_the_way:
        out.extend(f"{tee}: not entered, the survey stopped first" for tee in tees)
    elif extension is not None:  # stopped on the way to the stub
        out.append(f"{extension.stub_name}'s branch: not entered, the survey stopped first")
    if extension is not None:
        out.extend(
            f"{other}: not entered, a further insertion surveys it" for other in extension.others
        )
        out.extend(extension.notes)  # an earlier insertion's
    return out


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


def write_survey(
    *,
    name: str,
    segments: list[dict[str, Any]],
    diameter_m: float | None,
    stopped: str | None,
    insertion: str,
    earlier_stop: str | None,
    ends_note: str,
    unexplored: list[str],
    radius_m: float,
    output: Path | None,
) -> tuple[Any, str | None, bool]:
    """The network surveyed, built from ``segments`` and written to ``output`` (never a
    file that does not validate, never half a file).

    ``stopped``: why the survey stopped (``None``: every line to where it ends);
    ``insertion``: what a second insertion surveyed, as the description says it;
    ``earlier_stop``: why an earlier insertion stopped; ``ends_note``: what the lines'
    ends may be (``""``: none found); ``unexplored``: what was not surveyed.

    Returns:
        ``(network, invalid, written)``: the ``NetworkSpec`` (``None`` when it does not
        validate), why it was not written when it does not validate, and whether a
        file was written.
    """
    from pirate_bt.pipes.asbuilt import network_yaml
    from pirate_bt.pipes.model import NetworkSpec

    about = "Surveyed by pirate_bt's explore navigator" + insertion
    about += f"; {stopped}" if stopped else " up to where every line ends"
    if earlier_stop:  # its notes are kept
        about += f"; an earlier insertion stopped: {earlier_stop}"
    description = about + "."
    if ends_note:  # a cap, or a bend at a roll not tried: said where it is written
        description += f" Each line's end: {ends_note}."
    if unexplored:  # kept in the network itself, for a second insertion
        description += f" {NOT_SURVEYED}" + "; ".join(unexplored) + "."
    data: dict[str, Any] = {
        "schema_version": 1,
        "name": name,
        "description": description,
        "diameter": f"{(diameter_m or 0.063) * 1000:.1f} mm",
        "segments": segments,
    }
    spec = NetworkSpec.model_validate(data)
    problem = invalid_network(spec)
    if problem is not None:  # never a file that does not validate
        return (
            None,
            f"the network surveyed does not validate ({problem}), so nothing is written",
            False,
        )
    if output is None:
        return spec, None, False
    header = (
        f"{about}.\nLengths from odometry on the centre line (within about 5 % of"
        f" each length);\nbend radius assumed {radius_m * 1000:g} mm, a branch's"
        " turn radius its diameter;\ndiameters from the clamp angles, slopes from the IMU."
    )
    if ends_note:
        header += f"\nEach line's end: {ends_note}."
    if unexplored:
        header += (
            f"\n{NOT_SURVEYED}" + "; ".join(unexplored) + ".\nA tee branch not"
            " entered is written as a stub (no segments), a line not surveyed to its end"
            "\nends at the last feature surveyed in it: neither is a capped end."
        )
    text = network_yaml(spec, header=header)
    part = output.with_name(output.name + ".part")
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        part.write_text(text, encoding="utf-8")
        os.replace(part, output)  # never half a file
    except OSError as exc:  # the survey's result says it (the network is still returned)
        with contextlib.suppress(OSError):
            part.unlink()
        return spec, f"the survey could not be written to {output}: {exc.strerror or exc}", False
    return spec, None, True
