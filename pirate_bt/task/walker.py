"""The route walker: a route's commands walked along the map, one PAB at a time.

Split out of :mod:`pirate_bt.task.planner`, whose module docstring describes the
planning (what each command becomes, what does not fit a network). ``_Walker``
keeps where the front tip will be, the way taken at each T-joint, the features
passed and the PABs planned so far; one method per route command (``forward``,
``back``, ``bend``, ``tee``, ``pause``, ``goto``, ``return_to_start``) checks the
command against the map and the :class:`~pirate_bt.task.plan.PabContract` and
appends its PABs, or raises a :class:`~pirate_bt.errors.LocatedError` at the
route's line. :func:`~pirate_bt.task.planner.plan_route` drives it.
"""

from __future__ import annotations

import math
from typing import Any

from pirate_bt.errors import LocatedError
from pirate_bt.pipes import DIRECTION_ROLL_RAD, Network, Piece, PieceKind, TeeChoice
from pirate_bt.pipes import Path as PipePath
from pirate_bt.task.plan import (
    _DIRECTION_TOL_RAD,
    PabContract,
    PlannedPab,
    direction_name,
)
from pirate_bt.task.route import Route, RouteStep, StepKind

__all__ = ["BRANCH_ROLL_TOL_RAD", "_Walker", "branch_problem", "branch_side"]

_TOL_M = 1e-3

_STEP_M = 0.0025
"""An abrupt widening this large or larger (a straight of another diameter, no cone)
loses the wall under a half that holds alone: 3 mm slid in a riser, 2 mm did not
(probe, 2026-11-29)."""


def _roll_text(roll_rad: float) -> str:
    return direction_name(roll_rad) or f"roll {math.degrees(roll_rad):.0f} deg"


BRANCH_ROLL_TOL_RAD = math.radians(7.0)
"""How far off the T-joint PAB's roll for its way (left: -90 deg, right: +90 deg, as the
robot's IMU reads roll) a tee's branch may leave, as the IMU would read it there, and be
planned: the PAB aligns the front half on the IMU's -90 or +90 deg, and the robot enters
a turn only within ``motion.alignment_tolerance`` (8 deg in the bundled robot) of its
plane. An as-built variant's slopes of up to 6 deg (twice the stated bounds) before a
bend left or right twist the frame by as much, and its branches are still planned."""


def branch_side(tee: Piece) -> str | None:
    """The way the T-joint PAB turns into ``tee``'s branch: ``up``, ``right``, ``down``
    or ``left`` as the robot's IMU reads roll (from gravity's up), when the branch
    leaves within :data:`BRANCH_ROLL_TOL_RAD` of one there; else ``None``.

    In the pipe's frame (the network's rolls) that is the branch's own direction,
    unless the frame is twisted off gravity's (after a bend at a roll other than the
    four, or a bend left or right, on a slope: :attr:`~pirate_bt.pipes.Piece.imu_roll_rad`).
    """
    imu = tee.imu_roll_rad
    for direction, roll in DIRECTION_ROLL_RAD.items():
        if abs(math.remainder(imu - roll, 2 * math.pi)) <= BRANCH_ROLL_TOL_RAD:
            return str(direction.value)
    return None


def branch_problem(tee: Piece, contract: PabContract) -> str | None:
    """Why the T-joint PAB cannot turn into ``tee``'s branch, or ``None`` when it can.

    The PAB turns ``left`` or ``right`` (``contract.tee_ways``) at a roll of -90 or +90
    degrees as the robot's IMU reads roll (:func:`branch_side`). A branch at another
    roll (``roll: 45 deg``, ``up``, ``down``), also one that the pipe's frame twisted
    off gravity's puts there, is not planned.
    """
    turns = " or ".join(w for w in contract.tee_ways if w != "straight")
    side = branch_side(tee)
    if side is not None and side in contract.tee_ways:
        return None
    drawn = _roll_text(tee.roll_rad)
    imu = tee.imu_roll_rad
    if abs(math.remainder(imu - tee.roll_rad, 2 * math.pi)) <= BRANCH_ROLL_TOL_RAD:
        return (
            f"the T-joint {tee.segment!r} branches {drawn}, and the T-joint PAB turns {turns} only"
        )
    return (
        f"the T-joint {tee.segment!r} branches {drawn} in the pipe's frame, at roll"
        f" {math.degrees(imu):.0f} deg by the IMU (a bend at a roll on a slope before it"
        f" twists the frame off gravity's), and the T-joint PAB turns {turns} only, at"
        " -90 or 90 deg by the IMU"
    )


class _Walker:
    """Walks a route along the map, one command at a time."""

    def __init__(
        self,
        route: Route,
        network: Network,
        length_m: float,
        rear_lead_m: float,
        contract: PabContract,
        max_unclamped_slope_rad: float = math.radians(10.0),
        clamp_max_m: float = math.inf,
    ) -> None:
        self.route = route
        self.steep_sin = math.sin(max_unclamped_slope_rad)
        self.clamp_max_m = clamp_max_m
        self.network = network
        self.length_m = length_m
        self.rear_lead_m = rear_lead_m
        self.contract = contract
        self.choices: dict[str, TeeChoice] = {}
        self.path = network.path({})
        start = network.spec.start.position
        self.start_m = min(
            max(start if start is not None else length_m, length_m), self.path.length_m
        )
        self.s_m = self.start_m
        self.pabs: list[PlannedPab] = []
        self.passed: list[Piece] = []
        self.driven_m = 0.0

    def walk(self, step: RouteStep) -> None:
        """Walk one route command: check it against the map and append its PABs.

        Raises:
            LocatedError: the command does not fit the map from here.
        """
        handler = {
            StepKind.FORWARD: self.forward,
            StepKind.INSPECT: self.forward,
            StepKind.BACK: self.back,
            StepKind.BEND: self.bend,
            StepKind.TEE: self.tee,
            StepKind.PAUSE: self.pause,
            StepKind.GOTO: self.goto,
            StepKind.RETURN: self.return_to_start,
        }[step.kind]
        before_m = self.s_m
        handler(step)
        self._check_wide(step, before_m)

    def _check_wide(self, step: RouteStep, before_m: float) -> None:
        """No part of the robot in pipe wider than it clamps in, where ``step`` takes it.

        There the wheels never reach the wall: no half can hold or drive the robot, so a
        PAB's hold fails (*no wall*), and a leg's drive stops as its front joints swing
        past every wall-contact angle, as over an opening. Until the twenty-second
        session such a leg ended there and the mission said it had completed: 'forward
        to the end' into a 130 mm straight stopped 1.3 m short of the end, exit 0.
        """
        if not math.isfinite(self.clamp_max_m):
            return
        lo = max(min(before_m, self.s_m) - self.length_m, 0.0)
        hi = max(before_m, self.s_m)
        path = self.path
        for piece in path.pieces[path.index_at(lo) :]:
            if piece.start_m >= hi - _TOL_M:
                break
            a, b = max(piece.start_m, lo), min(piece.end_m, hi)
            if b - a <= _TOL_M:
                continue
            widest = max(path.diameter_at(a + _TOL_M), path.diameter_at(b - _TOL_M))
            if widest > self.clamp_max_m + 1e-9:
                raise LocatedError(
                    f"'{step.text}' cannot be planned: {piece.segment!r}"
                    f" ({piece.start_m:.2f}-{piece.end_m:.2f} m) is {widest * 1000:.0f} mm"
                    f" wide where the robot would be, and it clamps in pipes of at most"
                    f" {self.clamp_max_m * 1000:.0f} mm (its clamp.contact_angles): its"
                    " wheels would not reach the wall there, and no half could hold or"
                    " drive it",
                    step.location,
                )

    # -- map queries

    def next_feature(self) -> Piece | None:
        """The next bend or T-joint whose start is ahead of the front tip."""
        for piece in self.path.pieces[self.path.index_at(self.s_m) :]:
            if piece.kind in (PieceKind.BEND, PieceKind.TEE) and piece.start_m > self.s_m - _TOL_M:
                return piece
        return None

    def limit_m(self) -> tuple[float, Piece | None]:
        """How far forward the front tip may go without a turn PAB, and what stops it."""
        feature = self.next_feature()
        if feature is not None:
            return feature.start_m - self.contract.approach_m, feature
        return self.path.length_m - self.contract.end_margin_m, None

    def line_name(self) -> str:
        piece = self.path.piece_at(self.s_m)
        return piece.segment

    # -- planning steps

    def straight(
        self,
        step: RouteStep,
        distance_m: float,
        note: str,
        *,
        inspect: bool = False,
        absolute: bool = False,
    ) -> None:
        params: dict[str, Any] = {"distance": distance_m}
        slow = step.slowly or inspect
        if slow:
            params["slow"] = True
        overrun = math.copysign(self.contract.straight_overrun_m, distance_m)
        end = self.s_m + distance_m + overrun
        self.pabs.append(
            PlannedPab(
                "straight",
                params,
                step,
                self.s_m,
                end,
                inspect=inspect,
                note=note,
                absolute=absolute,
            )
        )
        self.driven_m += abs(distance_m)
        self.s_m = end

    def forward(self, step: RouteStep) -> None:
        limit, feature = self.limit_m()
        inspect = step.kind is StepKind.INSPECT
        verb = "inspect" if inspect else "straight"
        room = limit - self.s_m
        if step.distance_m is None:
            if feature is not None:
                raise self._feature_in_way(step, feature, "before the end of the line")
            if room < _TOL_M:
                raise LocatedError(
                    f"'{step.text}': the robot is already at the end of the line", step.location
                )
            self.straight(
                step, room, f"{verb} {room:.2f} m to the end", inspect=inspect, absolute=True
            )
            return
        if step.distance_m > room + _TOL_M:
            if feature is not None:
                approach = self.contract.approach_m
                raise self._feature_in_way(
                    step,
                    feature,
                    f"and a straight stops {approach:.2f} m before it (here at most"
                    f" {max(room, 0.0):.2f} m)"
                    if feature.start_m - self.s_m > step.distance_m
                    else f"within {step.distance_m:g} m",
                )
            margin = self.contract.end_margin_m  # the end itself was said to be that near
            raise LocatedError(
                f"'{step.text}' does not fit the network: only {max(room, 0.0):.2f} m of pipe"
                f" are left to drive (the line ends {max(room, 0.0) + margin:.2f} m ahead, in"
                f" {self.line_name()!r}, and a straight stops {margin:.2f} m before its end)",
                step.location,
            )
        self.straight(step, step.distance_m, f"{verb} {step.distance_m:g} m", inspect=inspect)

    def _feature_in_way(self, step: RouteStep, feature: Piece, where: str) -> LocatedError:
        ahead = feature.start_m - self.s_m
        if feature.kind is PieceKind.BEND:
            what = f"the bend {feature.segment!r} ({_roll_text(feature.roll_rad)})"
            named = direction_name(feature.roll_rad)
            hint = f"write 'at the bend turn {named}'" if named else "write 'at the bend turn'"
        else:
            what = f"the T-joint {feature.segment!r} (branch {_roll_text(feature.roll_rad)})"
            hint = "write 'at the T-joint go straight' (or into the branch)"
        return LocatedError(
            f"'{step.text}' does not fit the network: {what} starts {ahead:.2f} m ahead,"
            f" {where}; {hint} before driving past it",
            step.location,
        )

    def back(self, step: RouteStep) -> None:
        assert step.distance_m is not None
        floor = self._back_floor()
        if self.s_m - step.distance_m < floor - _TOL_M:
            raise LocatedError(
                f"'{step.text}' does not fit the network: the robot can back up at most"
                f" {max(self.s_m - floor, 0.0):.2f} m here (a route's way back is not"
                " planned through a bend or T-joint, nor out of the pipe)",
                step.location,
            )
        self.straight(step, -step.distance_m, f"back {step.distance_m:g} m")

    def _back_floor(self) -> float:
        if self.passed:
            return self.passed[-1].end_m + self.length_m + self.contract.clear_m
        return self.length_m

    def return_to_start(self, step: RouteStep) -> None:
        if self.passed:
            last = self.passed[-1]
            raise LocatedError(
                f"'{step.text}' cannot be planned: the way back passes {last.segment!r}, and"
                " a route's way back is not planned through a bend or T-joint yet (the"
                " backward PABs, bend-back and t-joint-back, are not planned on a map: pull"
                " the robot back by its tether)",
                step.location,
            )
        distance = self.s_m - self.start_m
        if distance < _TOL_M:
            return
        self.straight(step, -distance, f"back {distance:.2f} m to the start", absolute=True)

    def approach(self, step: RouteStep, feature: Piece) -> None:
        """Drive up to ``approach_m`` before ``feature``; nothing when already within it.

        The PAB that passes the feature senses it (``until: blocked`` or
        ``until: front_opening``), so it absorbs whatever margin is left.
        """
        target = feature.start_m - self.contract.approach_m
        gap = target - self.s_m
        if self.s_m > feature.start_m - self.contract.min_margin_m + _TOL_M:
            raise LocatedError(
                f"'{step.text}' cannot be planned: the robot would be only"
                f" {feature.start_m - self.s_m:.2f} m before {feature.segment!r}, less than"
                f" the {self.contract.min_margin_m:.2f} m margin (two features closer than"
                " the robot is long?)",
                step.location,
            )
        if gap > _TOL_M:
            self.straight(step, gap, f"approach {gap:.2f} m", absolute=True)

    def bend(self, step: RouteStep) -> None:
        feature = self.next_feature()
        if feature is None:
            raise LocatedError(
                f"'{step.text}' does not fit the network: there is no bend ahead on"
                f" {self.line_name()!r}",
                step.location,
            )
        if feature.kind is not PieceKind.BEND:
            raise LocatedError(
                f"'{step.text}' does not fit the network: the next feature is the T-joint"
                f" {feature.segment!r}, not a bend; write 'at the T-joint go ...' first",
                step.location,
            )
        actual = _roll_text(feature.roll_rad)
        if step.direction is not None:
            wanted = DIRECTION_ROLL_RAD[_direction(step.direction)]
            if abs(math.remainder(feature.roll_rad - wanted, 2 * math.pi)) > _DIRECTION_TOL_RAD:
                raise LocatedError(
                    f"'{step.text}' does not fit the network: the next bend, {feature.segment!r},"
                    f" turns {actual}, not {step.direction}",
                    step.location,
                )
        self.approach(step, feature)
        start = self.s_m
        end = self._turn_exit_m(feature)
        self._check_room(step, feature, end)
        self.pabs.append(
            PlannedPab(
                "bend",
                {"roll": feature.imu_roll_rad},  # the IMU's roll of the map's bend
                step,
                start,
                end,
                feature=feature.segment,
                note=f"bend {actual} ({feature.segment})",
            )
        )
        self.driven_m += end - start
        self.passed.append(feature)
        self.s_m = end

    def tee(self, step: RouteStep) -> None:
        feature = self.next_feature()
        if feature is None or feature.kind is not PieceKind.TEE:
            what = (
                f"the next feature is the bend {feature.segment!r}"
                if feature is not None
                else f"there is no T-joint ahead on {self.line_name()!r}"
            )
            raise LocatedError(f"'{step.text}' does not fit the network: {what}", step.location)
        way = step.direction or "straight"
        side = "straight" if way == "straight" else branch_side(feature)
        if way != "straight":
            wanted = DIRECTION_ROLL_RAD[_direction(way)]
            off = abs(math.remainder(feature.roll_rad - wanted, 2 * math.pi))
            if off > _DIRECTION_TOL_RAD and side != way:  # as drawn, or as the IMU reads it
                branch = _roll_text(feature.roll_rad)
                raise LocatedError(
                    f"'{step.text}' does not fit the network: the T-joint {feature.segment!r}"
                    f" branches {branch}, not {way}; write 'go {branch}' or 'go straight'",
                    step.location,
                )
            problem = branch_problem(feature, self.contract)
            if problem is not None:
                raise LocatedError(f"'{step.text}' cannot be planned: {problem}", step.location)
        self.approach(step, feature)
        self.choices[feature.segment] = "straight" if way == "straight" else "branch"
        self.path = self.network.path(self.choices)
        passed = feature
        if way != "straight":
            turns = [
                p
                for p in self.path.pieces
                if p.segment == feature.segment and p.kind is PieceKind.TEE_TURN
            ]
            passed = turns[0]
        else:
            passed = self.path.pieces[self.path.index_at(feature.start_m + _TOL_M)]
        start = self.s_m
        if way == "straight":
            assert feature.opening_m is not None
            end = feature.opening_m + self.rear_lead_m + self.contract.tee_exit_m
        else:
            end = self._turn_exit_m(passed)
        self._check_room(step, passed, end)
        self.pabs.append(
            PlannedPab(
                "t-joint",
                {"direction": side},  # the way the PAB turns, as the IMU reads it
                step,
                start,
                end,
                feature=feature.segment,
                note=f"T-joint {way} ({feature.segment})",
            )
        )
        self.driven_m += end - start
        self.passed.append(passed)
        self.s_m = end

    def _turn_exit_m(self, turn: Piece) -> float:
        return (
            turn.start_m + self.rear_lead_m + self.contract.follow_m + self.contract.turn_overrun_m
        )

    def _check_room(self, step: RouteStep, feature: Piece, end_m: float) -> None:
        if end_m > self.path.length_m + _TOL_M:
            raise LocatedError(
                f"'{step.text}' cannot be planned: after {feature.segment!r} the pipe ends"
                f" before the whole robot ({self.length_m:.2f} m) is through",
                step.location,
            )
        nxt = self.path.pieces[self.path.index_at(feature.end_m + _TOL_M) :]
        before = feature
        for piece in nxt:
            if piece is feature or piece.start_m < feature.end_m - _TOL_M:
                continue
            self._check_step(step, feature, end_m, before, piece)
            before = piece
            if piece.kind in (PieceKind.BEND, PieceKind.TEE):
                if (short := self._short(feature, piece, end_m)) is not None:
                    gap, need = short
                    raise LocatedError(
                        f"'{step.text}' cannot be planned: {feature.segment!r} and"
                        f" {piece.segment!r} are {gap:.2f} m apart, and passing"
                        f" {feature.segment!r} needs {need:.2f} m of straight pipe after it"
                        f" (the robot is {self.length_m:.2f} m long; its rear half must be"
                        " through and clear before the next turn)",
                        step.location,
                    )
                break

    def _short(self, feature: Piece, piece: Piece, end_m: float) -> tuple[float, float] | None:
        """``(gap, need)`` when passing ``feature`` (its PAB ending at ``end_m``) comes
        closer than the planner's margin to ``piece``: how far apart the two are, and
        how much pipe passing ``feature`` needs; ``None`` when there is room."""
        if end_m <= piece.start_m - self.contract.min_margin_m + _TOL_M:
            return None
        return piece.start_m - feature.end_m, end_m - feature.end_m + self.contract.min_margin_m

    def _check_step(
        self, step: RouteStep, feature: Piece, end_m: float, before: Piece, piece: Piece
    ) -> None:
        """No abrupt widening in a steep pipe where passing ``feature`` has one half hold.

        While a bend or T-joint PAB brings the rear half through, the front half alone
        holds, up to the PAB's end; a step wider by :data:`_STEP_M` or more under it
        swings its joints off the wall, and in a steep pipe the robot slides (a cone
        reducer, or a narrowing, does not: the joints follow the wall).
        """
        widening = piece.diameter_start_m - before.diameter_end_m
        steep = abs(piece.tangent[2]) > self.steep_sin
        if widening < _STEP_M or not steep:
            return
        if (short := self._short(feature, piece, end_m)) is not None:
            gap, need = short
            raise LocatedError(
                f"'{step.text}' cannot be planned: the pipe widens abruptly from"
                f" {before.diameter_end_m * 1000:.0f} to {piece.diameter_start_m * 1000:.0f} mm"
                f" {gap:.2f} m after {feature.segment!r} (at {piece.segment!r}), in a steep"
                f" pipe: passing {feature.segment!r} needs {need:.2f} m of pipe after it with"
                " no step (the front half alone holds the robot there, and would lose the"
                " wall at the step); a cone reducer there can be passed",
                step.location,
            )

    def pause(self, step: RouteStep) -> None:
        assert step.duration_s is not None
        self.pabs.append(
            PlannedPab(
                "pause",
                {"duration": step.duration_s},
                step,
                self.s_m,
                self.s_m,
                note=f"pause {step.duration_s:g} s",
            )
        )

    def goto(self, step: RouteStep) -> None:
        assert step.segment is not None
        if step.segment not in self.network.segment_ids():
            import difflib

            close = difflib.get_close_matches(step.segment, self.network.segment_ids(), n=2)
            hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
            raise LocatedError(
                f"'{step.text}': the network {self.network.name!r} has no segment"
                f" {step.segment!r}{hint}",
                step.location,
            )
        best: tuple[float, PipePath, Piece] | None = None
        for path in self.network.paths():
            if any(path.choices.get(t) != c for t, c in self.choices.items()):
                continue
            for piece in path.pieces:
                if piece.segment == step.segment and piece.end_m > self.s_m + _TOL_M:
                    if best is None or piece.start_m < best[2].start_m:
                        best = (piece.start_m, path, piece)
                    break
        if best is None:
            raise LocatedError(
                f"'{step.text}' cannot be planned: {step.segment!r} is not ahead of the robot"
                " on any way through the network from here",
                step.location,
            )
        _, path, goal = best
        if goal.kind is not PieceKind.STRAIGHT:
            raise LocatedError(
                f"'{step.text}': {step.segment!r} is a {goal.kind.value}; go to a straight segment",
                step.location,
            )
        for piece in path.pieces:
            if piece.start_m < self.s_m - _TOL_M or piece.start_m >= goal.start_m:
                continue
            if piece.kind is PieceKind.BEND:
                self.bend(_derived(step, StepKind.BEND, direction_name(piece.roll_rad)))
            elif piece.kind is PieceKind.TEE:
                choice = path.choices.get(piece.segment, "straight")
                way = "straight" if choice == "straight" else branch_side(piece)
                if way is None:  # no word for it: it was planned straight through before
                    problem = branch_problem(piece, self.contract)
                    raise LocatedError(f"'{step.text}' cannot be planned: {problem}", step.location)
                self.tee(_derived(step, StepKind.TEE, way))
        is_end = goal.end_m >= path.length_m - _TOL_M
        last = goal.end_m - (self.contract.end_margin_m if is_end else self.contract.approach_m)
        target = min(goal.start_m + self.length_m + self.contract.clear_m, last)
        if target > self.s_m + _TOL_M:
            self.straight(
                step, target - self.s_m, f"straight {target - self.s_m:.2f} m", absolute=True
            )


def _direction(name: str) -> Any:
    from pirate_bt.pipes import Direction

    return Direction(name)


def _derived(step: RouteStep, kind: StepKind, direction: str | None) -> RouteStep:
    return RouteStep(kind, step.location, step.text, direction=direction)
