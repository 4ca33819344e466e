"""The plan's shared types: what a planned mission is, and the PAB contract.

The planner (:mod:`pirate_bt.task.planner`) makes these, the mission tree
(:mod:`pirate_bt.task.tree`), the localiser and the report read them. They
live apart from the planner so that the route language, the planner and the
modules that run a plan import them without importing each other.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pirate_bt.pipes import DIRECTION_ROLL_RAD, Network, TeeChoice
from pirate_bt.pipes import Path as PipePath
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.fixes import ShortLeg
from pirate_bt.task.route import Route, RouteStep

__all__ = [
    "LEG_DISTANCE_KEY",
    "MAP_OK_KEY",
    "PAB_FILES",
    "SHORT_LEG_M",
    "MapFeature",
    "MissionPlan",
    "PabContract",
    "PlannedPab",
    "direction_name",
    "rear_lead_m",
    "robot_length_m",
    "short_leg",
]

MAP_OK_KEY = "map_ok"
"""Blackboard key the localiser clears when belief and map disagree."""

SHORT_LEG_M = 0.05
"""A forward leg blocked more than this short of its distance was cut short (:func:`short_leg`)."""

LEG_DISTANCE_KEY = "leg_distance"
"""Blackboard key the mission writes, when a straight leg starts, with its distance (m)."""

PAB_FILES: dict[str, str] = {
    "straight": "straight.yaml",
    "bend": "bend.yaml",
    "t-joint": "t-joint.yaml",
}
"""PAB name -> tree file in the bundled ``trees/`` folder."""

_DIRECTION_TOL_RAD = math.radians(10.0)


@dataclass(frozen=True)
class PabContract:
    """Where the PAB trees expect the robot and where they leave it.

    Two kinds of numbers live here. *Margins* are the planner's choice: how far
    before a feature a planned leg stops, so that a few centimetres of drift never
    drive the robot into it (the next PAB absorbs the margin: a turn PAB drives
    ``until: blocked``, a straight-through T-joint ``until: front_opening``).
    *Measured* numbers belong to the PAB trees in ``trees/``; they are derived on
    the simulator by :func:`pirate_bt.task.calibrate.calibrate`, and
    ``tests/test_task_contract.py`` fails when one drifts from its measurement
    (``python -m pirate_bt.task.calibrate`` prints them).

    Attributes:
        approach_m: Margin: a leg up to a bend or T-joint ends with the front tip this
            far before the feature's start (the PAB then drives the rest, sensing it).
        min_margin_m: Margin: no planned leg, and no PAB that ends before another
            feature, leaves the front tip closer than this to that feature's start.
            Between ``min_margin_m`` and ``approach_m`` the approach leg is left out.
        clear_m: ``go to SEGMENT`` drives until the rear tip is this far into it.
        end_margin_m: ``forward to the end`` stops the front tip this short of the end.
        slow_factor: ``slowly`` and ``inspect`` drive at this fraction of the
            nominal speed (when the straight PAB takes a speed).
        tee_ways: The ways the T-joint PAB can take.
        follow_m: A turn PAB (``trees/lib/turn.yaml``) drives the front half in until
            the rear half blocks at the turn's start (into a tee's branch, until the
            robot turns: 12 mm sooner in the bundled tee), then the rear half this
            far (its ``follow`` parameter): it ends with the front tip at the turn's
            start + the rear half's lead offset + ``follow_m`` + ``turn_overrun_m``.
        straight_overrun_m: Measured: the straight PAB drives this much further than
            its distance (it stops on the first tick past it).
        turn_overrun_m: Measured: see ``follow_m`` (worst of the four bend
            orientations and the turn into a tee's branch).
        tee_exit_m: Measured: the straight-through T-joint PAB
            (``trees/lib/tee-straight.yaml``) ends with the front tip at the middle
            of the opening + the rear half's lead offset + this, every bend module
            past the opening (its rear half drives until it has sensed the opening
            passed, then both halves drive 150 mm more so every module clears the
            tee: the end is anchored on the sensed opening).
    """

    approach_m: float = 0.25
    min_margin_m: float = 0.10
    clear_m: float = 0.05
    end_margin_m: float = 0.05
    slow_factor: float = 0.5
    tee_ways: tuple[str, ...] = ("left", "right", "straight")
    follow_m: float = 0.55
    straight_overrun_m: float = 0.0
    turn_overrun_m: float = 0.006
    tee_exit_m: float = 0.295


@dataclass(frozen=True)
class PlannedPab:
    """One PAB of the chain.

    Attributes:
        pab: ``straight``, ``bend``, ``t-joint`` or ``pause`` (a ``wait`` node).
        params: Its parameters in SI units (``distance`` m, ``roll`` rad,
            ``direction``, ``duration`` s, ``slow``).
        step: The route command it serves.
        start_m: Front-tip position (along ``MissionPlan.path``) when it starts.
        end_m: Front-tip position when it ends.
        feature: Segment id of the feature it passes, if any.
        inspect: Cameras on: part of an inspection.
        note: One line for people.
        absolute: A straight that goes *to a place on the map* (up to a feature, to
            the end, to a segment, back to the start): at run time it drives from the
            belief to ``end_m``. Otherwise it drives the route's distance from
            wherever it starts. Either way a forward leg keeps its margin before the
            next feature as far as the map's tolerance lets the robot know it.
    """

    pab: str
    params: Mapping[str, Any]
    step: RouteStep
    start_m: float
    end_m: float
    feature: str | None = None
    inspect: bool = False
    note: str = ""
    absolute: bool = False

    def label(self, index: int) -> str:
        """A tree node name: ``03 bend right (line 4)``."""
        return f"{index:02d} {self.note} (line {self.step.line})".replace("/", "-")


@dataclass(frozen=True)
class MapFeature:
    """A feature the robot passes, where the map has it.

    Attributes:
        segment: Its segment id.
        kind: ``bend``, ``tee`` (straight through) or ``tee_turn`` (into the branch).
        start_m: Where it starts along the plan's path.
        end_m: Where it ends.
        angle_rad: How far the pipe turns over it (0 through a tee).
        roll_rad: Roll of the turn (or of the tee's branch).
    """

    segment: str
    kind: str
    start_m: float
    end_m: float
    angle_rad: float
    roll_rad: float


@dataclass(frozen=True)
class MissionPlan:
    """A route planned on a network.

    Attributes:
        route: The route.
        network: The map.
        path: The way through the network (with every T-joint choice made).
        pabs: The chain of PABs.
        features: Features passed, in order (for the localiser).
        start_m: Front tip at the start.
        end_m: Front tip at the end (expected).
        distance_m: Distance driven, forwards and backwards.
        robot_length_m: Front tip to rear tip.
        contract: The PAB contract used.
    """

    route: Route
    network: Network
    path: PipePath
    pabs: tuple[PlannedPab, ...]
    features: tuple[MapFeature, ...]
    start_m: float
    end_m: float
    distance_m: float
    robot_length_m: float
    contract: PabContract = field(default_factory=PabContract)

    @property
    def choices(self) -> Mapping[str, TeeChoice]:
        return self.path.choices

    def describe(self) -> list[str]:
        """One line per PAB, for people and reports."""
        return [
            f"{i:2d}. {p.note:<34} {p.start_m:7.2f} -> {p.end_m:7.2f} m   ({p.step.describe()})"
            for i, p in enumerate(self.pabs, start=1)
        ]


def robot_length_m(robot: RobotDescription) -> float:
    """Front tip to rear tip: the modules end to end."""
    return sum(m.length for m in robot.modules)


def rear_lead_m(robot: RobotDescription) -> float:
    """How far the rear half's first module starts behind the front tip."""
    from pirate_bt.robot.description import Half

    behind = 0.0
    for module in robot.modules:
        if module.half is Half.REAR:
            return behind
        behind += module.length
    return behind


def direction_name(roll_rad: float) -> str | None:
    """``up``/``right``/``down``/``left`` when ``roll_rad`` is within 10° of one."""
    for direction, roll in DIRECTION_ROLL_RAD.items():
        if abs(math.remainder(roll_rad - roll, 2 * math.pi)) <= _DIRECTION_TOL_RAD:
            return direction.value
    return None


def short_leg(plan: MissionPlan, label: str, asked_m: float, travelled_m: float) -> ShortLeg | None:
    """The forward leg ``label``, blocked after ``travelled_m`` of the ``asked_m`` it was
    given, as cut short (``None`` when it drove its distance, to :data:`SHORT_LEG_M`):
    with the turn the route takes next (the first PAB past the straights and pauses,
    when it passes a turn) and whether the leg goes to the end of the line."""
    if asked_m - travelled_m <= SHORT_LEG_M:
        return None
    index = next((i for i, p in enumerate(plan.pabs) if p.label(i + 1) == label), None)
    if index is None:
        return None
    pab = plan.pabs[index]
    turns = {f.segment for f in plan.features if f.angle_rad > 0}
    after = (p for p in plan.pabs[index + 1 :] if p.pab not in ("straight", "pause"))
    following = next(after, None)
    takes = following.feature if following is not None else None
    end_m = plan.path.length_m - plan.contract.end_margin_m - 1e-3
    return ShortLeg(
        label,
        asked_m,
        travelled_m,
        takes if takes in turns else None,
        pab.absolute and pab.end_m >= end_m,
    )
