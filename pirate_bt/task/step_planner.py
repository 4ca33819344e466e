"""A navigator's steps planned on the map one at a time, from where the robot is.

:class:`StepPlanner` keeps one route walker (:mod:`pirate_bt.task.walker`) for the
whole navigation: the way taken at each T-joint and the features passed carry over
from step to step, and each step starts from the robot's belief, not from where the
previous step was planned to end. A step is one line of the route language
(:meth:`pirate_bt.task.navigation.CheckedStep.route_line`), so it is checked against
the map exactly as a route's command is ("at the bend turn up" where the next bend
turns left is refused) and becomes the same PABs (a turn gets its approach leg).
A refused step leaves the planner as it was.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from pirate_bt.errors import LocatedError
from pirate_bt.pipes import Network, PieceKind, TeeChoice
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.plan import (
    _DIRECTION_TOL_RAD,
    MapFeature,
    MissionPlan,
    PabContract,
    rear_lead_m,
    robot_length_m,
)
from pirate_bt.task.route import RouteStep, parse_route
from pirate_bt.task.start_check import check_start
from pirate_bt.task.walker import _Walker

__all__ = ["StepPlanner"]


class StepPlanner:
    """Plans one step at a time on ``network``, keeping the way taken.

    Args:
        network: The map.
        robot: The robot description (its length sets where PABs leave it).
        source: Names the steps in messages (``<navigator goal>``).
        contract: Where the PABs expect and leave the robot.
    """

    def __init__(
        self,
        network: Network,
        robot: RobotDescription,
        *,
        source: str = "<navigator>",
        contract: PabContract | None = None,
    ) -> None:
        self.network = network
        self.source = source
        self.contract = contract or PabContract()
        empty = parse_route("pause 1 s\n", source, name=source)  # replaced by each step
        # the ways taken, and how many features passed, before the last step planned
        self._before: tuple[dict[str, TeeChoice], int] = ({}, 0)
        self._walker = _Walker(
            empty,
            network,
            robot_length_m(robot),
            rear_lead_m(robot),
            self.contract,
            robot.motion.max_unclamped_slope,
            max(c.diameter for c in robot.clamp.contact_angles),
        )

    @property
    def start_m(self) -> float:
        """Where the robot starts on the map (front tip, metres along the path)."""
        return self._walker.start_m

    @property
    def choices(self) -> Mapping[str, str]:
        """The way taken at each T-joint so far (``straight`` or ``branch``)."""
        return dict(self._walker.choices)

    def segment_at(self, position_m: float) -> str | None:
        """The map's segment at ``position_m`` along the way taken."""
        path = self._walker.path
        if not path.pieces:
            return None
        return path.piece_at(min(max(position_m, 0.0), path.length_m)).segment

    def plan(
        self,
        line: str,
        index: int,
        belief_m: float,
        *,
        roll_rad: float | None = None,
        source: str | None = None,
    ) -> MissionPlan:
        """Plan step ``index`` (1 for the first), written as a route line, from ``belief_m``.

        ``source``: the file the step comes from, ``index`` then its line there (a
        route navigator's step is named by its route's line); by default the planner's
        own name, and the step's number as its line.

        ``roll_rad``: a bend step given by its roll (a bend at a roll other than up,
        down, left or right has no direction word): the next bend must turn at that
        roll, within the tolerance of a direction (10 degrees).

        Returns:
            A plan holding this step's PABs only, on the way taken so far, with the
            features this step passes and the next one ahead (the localiser expects
            to feel those, and no feature an earlier step passed).

        Raises:
            LocatedError: the step does not fit the map from here (at ``index``).
            ValidationFailed: the line does not parse.
        """
        where = source or self.source
        route = parse_route("\n" * (index - 1) + line + "\n", where, name=where)
        (step,) = route.steps
        walker = self._walker
        if not walker.pabs:  # the first step: the robot is where it was put in
            check_start(route, walker.path, walker.start_m, walker.length_m)
        saved = (
            dict(walker.choices),
            walker.path,
            walker.s_m,
            len(walker.pabs),
            len(walker.passed),
            walker.driven_m,
        )
        walker.route = route
        walker.s_m = belief_m
        try:
            if roll_rad is not None:
                _check_roll(walker, step, roll_rad)
            walker.walk(step)
        except BaseException:
            choices, path, s_m, n_pabs, n_passed, driven = saved
            walker.choices.clear()
            walker.choices.update(choices)
            walker.path, walker.s_m, walker.driven_m = path, s_m, driven
            del walker.pabs[n_pabs:]
            del walker.passed[n_passed:]
            raise
        self._before = (saved[0], saved[4])
        pabs = tuple(walker.pabs[saved[3] :])
        # The features this step passes, and the next one ahead: a map whose lengths are
        # off puts it nearer than drawn, and the step may feel it early (a fix, as in a
        # whole mission, not a disagreement). Not reached, it is never missed.
        pieces = list(walker.passed[saved[4] :])
        ahead = walker.next_feature()
        if ahead is not None and ahead not in pieces:
            pieces.append(ahead)
        features = tuple(
            MapFeature(p.segment, p.kind.value, p.start_m, p.end_m, p.angle_rad, p.roll_rad)
            for p in pieces
        )
        return MissionPlan(
            route=route,
            network=self.network,
            path=walker.path,
            pabs=pabs,
            features=features,
            start_m=belief_m,
            end_m=walker.s_m,
            distance_m=walker.driven_m - saved[5],
            robot_length_m=walker.length_m,
            contract=self.contract,
        )

    def forget_unfelt(self, plan: MissionPlan, fixed: Iterable[str]) -> tuple[str, ...]:
        """After ``plan`` (the last step planned) failed: forget the way it took at a
        T-joint it never fixed on (``fixed``: the features the step's localiser fixed
        on), so the way taken there is what it was before the step.

        A turn into a tee's branch is fixed on when the IMU feels the turn. One that
        failed before it did (the branch leaves on another side than drawn, and the
        robot slipped over the opening) left the robot on the main line, where the
        belief now is; before, the belief went on along the branch and the next step
        was planned there.

        Returns:
            The T-joints whose branch the step was to turn into and did not.
        """
        walker = self._walker
        choices, n_passed = self._before
        fixed = set(fixed)
        tees = dict.fromkeys(
            p.feature
            for p in plan.pabs
            if p.pab == "t-joint" and p.feature is not None and p.feature not in fixed
        )
        turned = tuple(t for t in tees if walker.choices.get(t) == "branch")
        for tee in tees:
            before = choices.get(tee)
            if before is None:
                walker.choices.pop(tee, None)
            else:
                walker.choices[tee] = before
            walker.passed[n_passed:] = [p for p in walker.passed[n_passed:] if p.segment != tee]
        if tees:
            walker.path = self.network.path(walker.choices)
        return turned


def _check_roll(walker: _Walker, step: RouteStep, roll_rad: float) -> None:
    """Refuse a bend step whose roll is not the next bend's (the walker checks a
    direction word; a roll is checked here)."""
    feature = walker.next_feature()
    if feature is None or feature.kind is not PieceKind.BEND:
        return  # the walker refuses it, by name
    if abs(math.remainder(feature.roll_rad - roll_rad, 2 * math.pi)) > _DIRECTION_TOL_RAD:
        raise LocatedError(
            f"'{step.text}' does not fit the network: the next bend, {feature.segment!r},"
            f" turns at roll {math.degrees(feature.roll_rad):.0f} deg, not at roll"
            f" {math.degrees(roll_rad):.0f} deg",
            step.location,
        )
