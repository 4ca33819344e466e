"""Mission planning: a route (or a goal on the map) becomes one chain of PABs.

The pipe network is the map. The planner walks a route's commands along it,
keeping where the robot's front tip will be (metres along the path from the
start of the main line) and the way it takes at each T-joint, and turns each
command into Partial Autonomous Behaviours with their parameters:

- ``forward 2 m`` becomes the ``straight`` PAB with ``distance: 2 m``;
- ``at the bend turn right`` becomes a ``straight`` up to the bend (so the
  operator never measures the last metre) and the ``bend`` PAB with the bend
  plane's ``roll`` from the map;
- ``at the T-joint go left`` becomes the ``t-joint`` PAB with ``direction:
  left``, after checking that the tee really branches left;
- ``go to SEGMENT`` finds the way on the map (the network is a tree of lines,
  so the shortest way through the junctions is the one path that reaches the
  segment first) and expands into the same commands.

A route that does not fit its network fails here, before anything moves,
with a :class:`~pirate_bt.errors.LocatedError` at the route's line: "turn up"
where the next bend turns left, "forward 50 m" past the end of the pipe, a
forward that would drive into a bend.

The plan is run as ONE tree (:func:`mission_tree_spec`): a sequence of
subtree references to ``trees/straight.yaml``, ``trees/bend.yaml`` and
``trees/t-joint.yaml``, guarded by the localiser's ``map_ok`` blackboard key so
that the tree stops (and the runner puts the robot in its safe state) when
belief and map disagree.

Where each PAB leaves the robot is a contract with the PAB trees, kept in one
place (:class:`PabContract`): legs up to a feature stop ``approach_m`` before it
(a margin the sensing PAB absorbs), and each PAB ends where the simulator says
it does (:mod:`pirate_bt.task.calibrate` measures it; a test keeps the
constants honest).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pirate_bt.errors import ConfigurationError, LocatedError, SourceLocation
from pirate_bt.pipes import DIRECTION_ROLL_RAD, Network, Piece, PieceKind, TeeChoice, load_network
from pirate_bt.pipes import Path as PipePath
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.route import Route, RouteStep, StepKind

__all__ = [
    "MAP_OK_KEY",
    "PAB_FILES",
    "MapFeature",
    "MissionPlan",
    "PabContract",
    "PlannedPab",
    "direction_name",
    "mission_tree_spec",
    "plan_goal",
    "plan_route",
    "resolve_network_path",
    "robot_length_m",
]

MAP_OK_KEY = "map_ok"
"""Blackboard key the localiser clears when belief and map disagree."""

PAB_FILES: dict[str, str] = {
    "straight": "straight.yaml",
    "bend": "bend.yaml",
    "t-joint": "t-joint.yaml",
}
"""PAB name -> tree file in the bundled ``trees/`` folder."""

_TOL_M = 1e-3
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
            the rear half blocks at the turn's start, then the rear half this far
            (its ``follow`` parameter): it ends with the front tip at the turn's
            start + the rear half's lead offset + ``follow_m`` + ``turn_overrun_m``.
        straight_overrun_m: Measured: the straight PAB drives this much further than
            its distance (it stops on the first tick past it).
        turn_overrun_m: Measured: see ``follow_m`` (worst of the four bend
            orientations and the turn into a tee's branch).
        tee_exit_m: Measured: the straight-through T-joint PAB
            (``trees/lib/tee-straight.yaml``) ends with the front tip at the middle
            of the opening + the rear half's lead offset + this, every bend module
            past the opening.
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
    tee_exit_m: float = 0.400


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
    """

    pab: str
    params: Mapping[str, Any]
    step: RouteStep
    start_m: float
    end_m: float
    feature: str | None = None
    inspect: bool = False
    note: str = ""

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


def _roll_text(roll_rad: float) -> str:
    return direction_name(roll_rad) or f"roll {math.degrees(roll_rad):.0f} deg"


def resolve_network_path(name: str, base_dir: Path | None = None) -> Path:
    """The network file a route or ``--sim`` names.

    ``lab`` is looked up next to the route (``lab.yaml``), then among the bundled
    scenarios; a name ending in ``.yaml`` is a path (relative to ``base_dir``).

    Raises:
        FileNotFoundError: no such network, with the bundled names.
    """
    from pirate_bt.resources import data_dir

    candidates: list[Path] = []
    plain = Path(name)
    if plain.suffix in (".yaml", ".yml"):
        candidates.append(plain if plain.is_absolute() else (base_dir or Path.cwd()) / plain)
        candidates.append(plain)
    else:
        if base_dir is not None:
            candidates.append(base_dir / f"{name}.yaml")
        candidates.append(data_dir("scenarios") / f"{name}.yaml")
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    bundled = sorted(p.stem for p in data_dir("scenarios").glob("*.yaml"))
    raise FileNotFoundError(f"no network {name!r}; bundled networks: {', '.join(bundled)}")


class _Walker:
    """Walks a route along the map, one command at a time."""

    def __init__(
        self,
        route: Route,
        network: Network,
        length_m: float,
        rear_lead_m: float,
        contract: PabContract,
    ) -> None:
        self.route = route
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
        self, step: RouteStep, distance_m: float, note: str, *, inspect: bool = False
    ) -> None:
        params: dict[str, Any] = {"distance": distance_m}
        slow = step.slowly or inspect
        if slow:
            params["slow"] = True
        overrun = math.copysign(self.contract.straight_overrun_m, distance_m)
        end = self.s_m + distance_m + overrun
        self.pabs.append(
            PlannedPab("straight", params, step, self.s_m, end, inspect=inspect, note=note)
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
            self.straight(step, room, f"{verb} {room:.2f} m to the end", inspect=inspect)
            return
        if step.distance_m > room + _TOL_M:
            if feature is not None:
                raise self._feature_in_way(step, feature, f"within {step.distance_m:g} m")
            raise LocatedError(
                f"'{step.text}' does not fit the network: only {max(room, 0.0):.2f} m of pipe"
                f" are left before the end of the line (in {self.line_name()!r})",
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
                f" {max(self.s_m - floor, 0.0):.2f} m here (the PABs do not drive backwards"
                " through a bend or T-joint, nor out of the pipe)",
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
                " the PABs do not drive backwards through a bend or T-joint yet"
                " (pull the robot back by its tether)",
                step.location,
            )
        distance = self.s_m - self.start_m
        if distance < _TOL_M:
            return
        self.straight(step, -distance, f"back {distance:.2f} m to the start")

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
            self.straight(step, gap, f"approach {gap:.2f} m")

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
                {"roll": feature.roll_rad},
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
        branch = _roll_text(feature.roll_rad)
        if way != "straight":
            wanted = DIRECTION_ROLL_RAD[_direction(way)]
            if abs(math.remainder(feature.roll_rad - wanted, 2 * math.pi)) > _DIRECTION_TOL_RAD:
                raise LocatedError(
                    f"'{step.text}' does not fit the network: the T-joint {feature.segment!r}"
                    f" branches {branch}, not {way}; write 'go {branch}' or 'go straight'",
                    step.location,
                )
            if way not in self.contract.tee_ways:
                raise LocatedError(
                    f"'{step.text}' cannot be planned: the T-joint PAB turns"
                    f" {' or '.join(w for w in self.contract.tee_ways if w != 'straight')} only",
                    step.location,
                )
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
                {"direction": way},
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
        for piece in nxt:
            if piece is feature or piece.start_m < feature.end_m - _TOL_M:
                continue
            if piece.kind in (PieceKind.BEND, PieceKind.TEE):
                if end_m > piece.start_m - self.contract.min_margin_m + _TOL_M:
                    raise LocatedError(
                        f"'{step.text}' cannot be planned: {feature.segment!r} and"
                        f" {piece.segment!r} are closer than the robot is long"
                        f" ({self.length_m:.2f} m)",
                        step.location,
                    )
                break

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
                way = "straight" if choice == "straight" else direction_name(piece.roll_rad)
                self.tee(_derived(step, StepKind.TEE, way))
        is_end = goal.end_m >= path.length_m - _TOL_M
        last = goal.end_m - (self.contract.end_margin_m if is_end else self.contract.approach_m)
        target = min(goal.start_m + self.length_m + self.contract.clear_m, last)
        if target > self.s_m + _TOL_M:
            self.straight(step, target - self.s_m, f"straight {target - self.s_m:.2f} m")


def _direction(name: str) -> Any:
    from pirate_bt.pipes import Direction

    return Direction(name)


def _derived(step: RouteStep, kind: StepKind, direction: str | None) -> RouteStep:
    return RouteStep(kind, step.location, step.text, direction=direction)


def plan_route(
    route: Route,
    network: Network,
    robot: RobotDescription,
    contract: PabContract | None = None,
) -> MissionPlan:
    """Plan a route on a network.

    Args:
        route: The parsed route.
        network: The map.
        robot: The robot description (its length sets where PABs leave it).
        contract: Where the PABs expect and leave the robot.

    Returns:
        The plan: the PAB chain, the path, the features passed.

    Raises:
        LocatedError: the route does not fit the network, at the route's line.
    """
    contract = contract or PabContract()
    walker = _Walker(route, network, robot_length_m(robot), rear_lead_m(robot), contract)
    handlers = {
        StepKind.FORWARD: walker.forward,
        StepKind.INSPECT: walker.forward,
        StepKind.BACK: walker.back,
        StepKind.BEND: walker.bend,
        StepKind.TEE: walker.tee,
        StepKind.PAUSE: walker.pause,
        StepKind.GOTO: walker.goto,
        StepKind.RETURN: walker.return_to_start,
    }
    for step in route.steps:
        handlers[step.kind](step)
    features = tuple(
        MapFeature(
            p.segment,
            p.kind.value,
            p.start_m,
            p.end_m,
            p.angle_rad,
            p.roll_rad,
        )
        for p in walker.passed
    )
    return MissionPlan(
        route=route,
        network=network,
        path=walker.path,
        pabs=tuple(walker.pabs),
        features=features,
        start_m=walker.start_m,
        end_m=walker.s_m,
        distance_m=walker.driven_m,
        robot_length_m=walker.length_m,
        contract=contract,
    )


def plan_goal(
    network: Network,
    segment: str,
    robot: RobotDescription,
    contract: PabContract | None = None,
) -> MissionPlan:
    """Plan the shortest way from the start to a goal segment on the map.

    Raises:
        LocatedError: no such segment, or it cannot be reached.
    """
    from pirate_bt.task.route import parse_route

    route = parse_route(f"go to {segment}\n", f"<goal {segment}>", name=f"to {segment}")
    return plan_route(route, network, robot, contract)


def load_network_for(route: Route, sim: str | None) -> Network:
    """The network a mission runs in: ``--sim`` if given, else the route's ``network`` line.

    Raises:
        LocatedError: neither is given, or the named network does not exist.
        ValidationFailed: the network file does not validate.
    """
    name = sim or route.network
    if name is None:
        raise LocatedError(
            "the route names no network; add a line 'network NAME' or give --sim NETWORK",
            SourceLocation(route.source),
        )
    base = Path(route.source).parent if not route.source.startswith("<") else None
    try:
        path = resolve_network_path(name, base)
    except FileNotFoundError as exc:
        where = route.network_location if sim is None and route.network_location else None
        raise LocatedError(str(exc), where or SourceLocation("--sim")) from None
    return load_network(path)


def _pab_file(trees_dir: Path, pab: str) -> Path:
    path = trees_dir / PAB_FILES[pab]
    if not path.is_file():
        raise ConfigurationError(
            f"the PAB tree {path} is missing; the mission needs {', '.join(PAB_FILES.values())}"
        )
    return path


def _declared_params(path: Path) -> set[str]:
    from pirate_bt.yamlfile import load_yaml

    data = load_yaml(path).data
    params = data.get("params") if isinstance(data, dict) else None
    return set(params) if isinstance(params, dict) else set()


def mission_tree_spec(
    plan: MissionPlan,
    trees_dir: Path | None = None,
    nominal_speed_mps: float | None = None,
) -> dict[str, Any]:
    """The plan as one tree, in the mapping form of :func:`pirate_bt.treefile.load_tree`.

    The root is an ``eternal_guard`` on ``map_ok`` around a sequence of subtree
    references, one per PAB, named ``NN what (line L)``.

    Args:
        plan: The mission plan.
        trees_dir: Where the PAB trees are (default: the bundled ``trees/``).
        nominal_speed_mps: The robot's cruise speed; with it, slow straights pass
            ``speed`` when the straight PAB declares that parameter.

    Raises:
        ConfigurationError: a PAB tree file is missing.
    """
    from pirate_bt.resources import data_dir

    folder = trees_dir or data_dir("trees")
    declared: dict[str, set[str]] = {}
    children: list[dict[str, Any]] = []
    for index, pab in enumerate(plan.pabs, start=1):
        name = pab.label(index)
        if pab.pab == "pause":
            children.append({"type": "wait", "name": name, "duration": pab.params["duration"]})
            continue
        path = _pab_file(folder, pab.pab)
        if pab.pab not in declared:
            declared[pab.pab] = _declared_params(path)
        params = {k: v for k, v in pab.params.items() if k != "slow"}
        speed = nominal_speed_mps
        if pab.params.get("slow") and nominal_speed_mps is not None:
            speed = nominal_speed_mps * plan.contract.slow_factor
        if params.get("distance", 0.0) < 0:
            # Backwards: the straight PAB drives a positive distance at a negative velocity.
            params["distance"] = -params["distance"]
            speed = -(speed or 0.08)
        if speed is not None and speed != nominal_speed_mps:
            for key in ("speed", "velocity"):
                if key in declared[pab.pab]:
                    params[key] = speed
        node: dict[str, Any] = {
            "type": "subtree",
            "name": name,
            "ref": str(path.resolve()),
            "params": params,
        }
        if pab.inspect:
            node = {
                "type": "sequence",
                "name": name,
                "children": [
                    {
                        "type": "log",
                        "name": "inspect",
                        "message": f"inspecting {pab.start_m:.2f}-{pab.end_m:.2f} m",
                    },
                    {**node, "name": "drive"},
                ],
            }
        children.append(node)
    return {
        "name": f"mission {plan.route.name}",
        "description": f"route {plan.route.source} in network {plan.network.name}",
        "blackboard": {MAP_OK_KEY: {"type": "boolean", "default": True, "external": True}},
        "root": {
            "type": "eternal_guard",
            "name": "mission",
            "conditions": [
                {
                    "type": "check_blackboard",
                    "name": "belief fits the map",
                    "key": MAP_OK_KEY,
                    "op": "==",
                    "value": True,
                }
            ],
            "child": {"type": "sequence", "name": "route", "children": children},
        },
    }
