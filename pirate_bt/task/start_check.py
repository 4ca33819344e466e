"""Where the robot is put in: no turn and no T-joint may be under it at the start.

The robot is put in with its front tip at the network's start position (by default
its own length from the pipe's mouth). A network whose first straight is shorter
than the robot put it in *across* what follows, and the plan went on as if it were
in straight pipe:

- across a bend (0.3 m of straight, then a bend right): the robot drove 0.08 m, was
  blocked by the bend under it, and the localiser took that bend for the block's
  reason: ``forward to the end`` "completed" 1.85 m short of the end;
- across a tee (a network that begins with one): the rear half's joints swung into
  its opening, and a mission on an exact map stopped on *an opening was felt at 0.12
  m (believed, by bend_4), where the map has no T-joint within 0.30 m* (the map's
  tee was behind the front tip, so the plan did not list it); the rear half cannot
  clamp over the opening either.

:func:`check_start` refuses such a plan before anything moves, naming the feature.
"""

from __future__ import annotations

from pirate_bt.errors import InputError, LocatedError
from pirate_bt.pipes.network import Network, Piece, PieceKind
from pirate_bt.pipes.network import Path as PipePath
from pirate_bt.robot.description import RobotDescription
from pirate_bt.task.plan import PabContract, robot_length_m
from pirate_bt.task.route import Route

__all__ = ["check_map_start", "check_start"]

_TOL_M = 1e-6
_KINDS = {
    PieceKind.BEND: "bend",
    PieceKind.TEE: "T-joint",
    PieceKind.TEE_TURN: "turn into the branch of T-joint",
}


def _under(path: PipePath, start_m: float, length_m: float) -> Piece | None:
    """The bend or T-joint under a robot ``length_m`` long with its front tip at ``start_m``."""
    rear_m = start_m - length_m
    return next(
        (
            piece
            for piece in path.pieces
            if piece.kind in _KINDS
            and piece.start_m < start_m - _TOL_M
            and piece.end_m > rear_m + _TOL_M
        ),
        None,
    )


def _across(under: Piece, start_m: float, length_m: float) -> str:
    return (
        f"the robot ({length_m:.2f} m long) is put in"
        f" with its front tip at {start_m:.2f} m, across the {_KINDS[under.kind]}"
        f" {under.segment!r} ({under.start_m:.2f}-{under.end_m:.2f} m): it must be put"
        " in on straight pipe (the network needs a straight at least as long as the"
        " robot before its first bend or T-joint, or a start position with the whole"
        " robot past it)"
    )


def check_start(route: Route, path: PipePath, start_m: float, length_m: float) -> None:
    """Refuse a start with a bend or a T-joint under the robot (front tip at ``start_m``).

    Raises:
        LocatedError: one is under it, at the route's first command.
    """
    under = _under(path, start_m, length_m)
    if under is not None and route.steps:
        step = route.steps[0]
        raise LocatedError(
            f"'{step.text}' cannot be planned: {_across(under, start_m, length_m)}",
            step.location,
        )


def check_map_start(network: Network, robot: RobotDescription, name: str) -> None:
    """Refuse a navigation whose map puts the robot in across a bend or a T-joint,
    before anything connects: every step of it would be refused at its planning, the
    first one after connecting (exit 1), where a mission is refused at planning
    (exit 2).

    Raises:
        InputError: the map puts the robot in across one (named, as a mission's).
    """
    path = network.path({})
    length_m = robot_length_m(robot)
    start = network.spec.start.position
    start_m = min(max(start if start is not None else length_m, length_m), path.length_m)
    under = _under(path, start_m, length_m)
    if under is not None:
        raise InputError(
            f"navigator {name!r} cannot start on the map {network.spec.name!r}:"
            f" {_across(under, start_m, length_m)}"
        )
    margin_m = PabContract().min_margin_m
    ahead = next(
        (p for p in path.pieces if p.kind in _KINDS and p.start_m >= start_m - _TOL_M), None
    )
    if ahead is not None and ahead.start_m - start_m < margin_m - _TOL_M:
        # a step through it is refused at its planning, as a mission's route is (exit 2),
        # and so is every straight: only waits were left, the first refusal after connecting
        raise InputError(
            f"navigator {name!r} cannot start on the map {network.spec.name!r}: the robot"
            f" is put in with its front tip at {start_m:.2f} m, only"
            f" {ahead.start_m - start_m:.2f} m before the {_KINDS[ahead.kind]}"
            f" {ahead.segment!r}, less than the {margin_m:.2f} m margin: no step through it"
            f" can be planned, nor a straight (the first bend or T-joint must be at least"
            f" {margin_m:.2f} m ahead of the front tip where the robot is put in)"
        )
