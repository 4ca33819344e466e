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

The plan's types live in :mod:`pirate_bt.task.plan`, the tree it runs as in
:mod:`pirate_bt.task.tree`; both are re-exported here. The walk along the map
(one method per route command) is ``_Walker`` in :mod:`pirate_bt.task.walker`.
This module keeps the entry points: :func:`plan_route`, :func:`plan_goal`,
:func:`plan_return` and :func:`validate_route_file`.
"""

from __future__ import annotations

from pathlib import Path

from pirate_bt.errors import ArgumentTypeError, LocatedError, shown
from pirate_bt.pipes import Network
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.networks import load_network_for, resolve_network_path
from pirate_bt.task.plan import (
    MAP_OK_KEY,
    PAB_FILES,
    MapFeature,
    MissionPlan,
    PabContract,
    PlannedPab,
    direction_name,
    rear_lead_m,
    robot_length_m,
)
from pirate_bt.task.route import Route, load_route
from pirate_bt.task.start_check import check_start
from pirate_bt.task.traction import Traction
from pirate_bt.task.tree import mission_tree_spec, pab_torque_nm
from pirate_bt.task.walker import _TOL_M, _Walker

__all__ = [
    "MAP_OK_KEY",
    "PAB_FILES",
    "MapFeature",
    "MissionPlan",
    "PabContract",
    "PlannedPab",
    "direction_name",
    "load_network_for",
    "mission_tree_spec",
    "plan_goal",
    "plan_return",
    "plan_route",
    "rear_lead_m",
    "resolve_network_path",
    "robot_length_m",
    "validate_route_file",
]


def plan_route(
    route: Route,
    network: Network,
    robot: RobotDescription | None,
    contract: PabContract | None = None,
    *,
    start_m: float | None = None,
) -> MissionPlan:
    """Plan a route on a network.

    Args:
        route: The parsed route.
        network: The map.
        robot: The robot description (its length sets where PABs leave it; ``None``:
            the bundled one).
        contract: Where the PABs expect and leave the robot.
        start_m: Plan from here (front tip on the main path; default: the network's
            start), e.g. from the belief when a mission re-plans.

    Returns:
        The plan: the PAB chain, the path, the features passed.

    Raises:
        LocatedError: the route does not fit the network, at the route's line.
        ArgumentTypeError: an argument of the wrong type (files and names are for
            :func:`pirate_bt.plan_route`, which loads them).
    """
    if not isinstance(route, Route):
        raise ArgumentTypeError(
            f"plan_route: route: give a parsed Route (pirate_bt.load_route), not"
            f" {shown(route)}; pirate_bt.plan_route takes a file or a bundled name"
        )
    robot = _checked("plan_route", network, robot)
    contract = contract or PabContract()
    walker = _Walker(
        route,
        network,
        robot_length_m(robot),
        rear_lead_m(robot),
        contract,
        robot.motion.max_unclamped_slope,
        max(c.diameter for c in robot.clamp.contact_angles),
    )
    if start_m is not None:
        walker.start_m = walker.s_m = start_m
    else:  # put in at the network's start: on straight pipe?
        check_start(route, walker.path, walker.start_m, walker.length_m)
    torque = pab_torque_nm()
    traction = Traction.of(robot, network.tether_drag_per_m, torque) if torque is not None else None
    for step in route.steps:
        made = len(walker.pabs)
        walker.walk(step)
        for pab in walker.pabs[made:]:
            problem = traction.problem(walker.path, pab) if traction is not None else None
            if problem is not None:  # its wheels would turn in place (task/traction.py)
                raise LocatedError(f"'{step.text}' cannot be planned: {problem}", step.location)
    if not walker.pabs and start_m is None and route.steps:
        # a route of 'return to start' alone: its tree had no child, and the mission
        # was refused as '<dict>:1:1: needs a list of children', naming no file
        first = route.steps[0]
        raise LocatedError(
            f"'{first.text}' plans nothing to do: the robot is put in at the start"
            f" ({walker.start_m:.2f} m), and the route never leaves it",
            first.location,
        )
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
    robot: RobotDescription | None = None,
    contract: PabContract | None = None,
) -> MissionPlan:
    """Plan the shortest way from the start to a goal segment on the map.

    Args:
        network: The map.
        segment: The goal segment's id.
        robot: The robot description (``None``: the bundled one).
        contract: Where the PABs expect and leave the robot.

    Raises:
        LocatedError: no such segment, or it cannot be reached.
        ArgumentTypeError: an argument of the wrong type.
    """
    from pirate_bt.task.route import parse_route

    robot = _checked("plan_goal", network, robot)
    if not isinstance(segment, str) or not segment or len(segment) > 200 or "\n" in segment:
        raise ArgumentTypeError(
            f"plan_goal: segment: give a segment's id as text, not {shown(segment)}"
        )

    route = parse_route(f"go to {segment}\n", f"<goal {segment}>", name=f"to {segment}")
    return plan_route(route, network, robot, contract)


def _checked(function: str, network: object, robot: object) -> RobotDescription:
    """The robot description (the bundled one for ``None``), once the types are right."""
    if not isinstance(network, Network):
        raise ArgumentTypeError(
            f"{function}: network: give a Network (pirate_bt.load_network), not"
            f" {shown(network)}; pirate_bt.plan_route takes a file or a bundled name"
        )
    if robot is None:
        from pirate_bt.robot.loader import load_robot

        return load_robot()
    if not isinstance(robot, RobotDescription):
        raise ArgumentTypeError(
            f"{function}: robot: give a RobotDescription (pirate_bt.load_robot) or None for"
            f" the bundled one, not {shown(robot)}"
        )
    return robot


def plan_return(plan: MissionPlan, belief_m: float, felt: list[str]) -> MissionPlan:
    """The way back to the start after a mission stopped at ``belief_m``.

    The way back is the pipe as the robot sensed it, not as the map has it: a
    feature the map has but the robot never felt (a bend that was never built)
    is no obstacle. The backward PABs (``bend-back``, ``t-joint-back``) are not
    planned on a map yet, so a way back through a feature the robot did pass
    (``felt``) cannot be planned.

    Args:
        plan: The mission's plan.
        belief_m: Where the robot believes it is.
        felt: Segment ids of the features the robot passed and felt (its fixes).

    Raises:
        LocatedError: the way back passes a felt feature.
    """
    from pirate_bt.errors import SourceLocation
    from pirate_bt.task.route import parse_route

    route = parse_route("return to start\n", f"<return from {plan.route.name}>", name="return")
    step = route.steps[0]
    if felt:
        raise LocatedError(
            f"cannot return to the start: the way back passes {felt[-1]!r}, and the PABs do"
            " not drive backwards through a bend or T-joint yet (pull the robot back by its"
            " tether)",
            SourceLocation(plan.route.source),
        )
    distance = belief_m - plan.start_m
    pabs: tuple[PlannedPab, ...] = ()
    if distance > _TOL_M:
        pabs = (
            PlannedPab(
                "straight",
                {"distance": -distance},
                step,
                belief_m,
                plan.start_m,
                note=f"back {distance:.2f} m to the start",
                absolute=True,
            ),
        )
    return MissionPlan(
        route=route,
        network=plan.network,
        path=plan.path,
        pabs=pabs,
        features=(),
        start_m=belief_m,
        end_m=plan.start_m,
        distance_m=abs(distance),
        robot_length_m=plan.robot_length_m,
        contract=plan.contract,
    )


def validate_route_file(path: str | Path) -> Route:
    """Check a route (``pirate-bt validate``).

    Words, spelling and units first; when the route names its network, it is
    also planned on that network with the bundled robot, so a route that does
    not fit (a "turn up" where the bend turns left) fails at its line.

    Raises:
        ValidationFailed: every problem, each at ``file:line:column``.
    """
    from pirate_bt.errors import ValidationFailed
    from pirate_bt.robot.loader import load_robot

    route = load_route(path)
    if route.network is not None:
        try:
            plan_route(route, load_network_for(route, None), load_robot())
        except LocatedError as exc:
            raise ValidationFailed([exc]) from None
    return route
