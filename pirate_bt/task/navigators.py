"""The built-in navigators, and navigators by name (the ``pirate_bt.navigators`` group).

Each built-in is short on purpose: a model for your own (docs/navigators.md).

- ``route`` (:class:`RouteNavigator`, ``route=FILE``): a route file's commands, one
  step each (``forward``, ``inspect``, ``back``, ``at the bend turn``, ``at the
  T-joint go``, ``pause``; ``forward to the end`` and ``go to`` need the map).
- ``goal`` (:class:`GoalNavigator`, ``segment=NAME``): reach a segment of the map,
  re-planning from the belief before every step (so also after a disagreement the
  navigation was allowed to go on from).
- ``explore`` (:class:`~pirate_bt.task.explore.ExploreNavigator`, ``output=FILE``):
  survey a pipe with no map and write the network found (:mod:`pirate_bt.task.explore`).

Navigators of your own are found by name through the ``pirate_bt.navigators``
entry-point group, as node types are::

    [project.entry-points."pirate_bt.navigators"]
    wall-follower = "my_package.nav:WallFollower"

The entry point is a class (or a function) called with the navigator's parameters
as keyword arguments (the command line's ``--param KEY=VALUE``, as text).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from pirate_bt.errors import (
    ArgumentTypeError,
    InputError,
    LocatedError,
    ValidationFailed,
    file_argument,
    kind_of,
    said_of,
    shown,
)
from pirate_bt.pipes import Network, PieceKind
from pirate_bt.task.explore import ExploreNavigator
from pirate_bt.task.navigate_checks import (
    REFUSAL_LIMIT,
    check_navigator_map,
    check_next_step_shape,
    navigator_method,
)
from pirate_bt.task.navigate_planner import import_failure
from pirate_bt.task.navigate_route_map import check_route_on_map
from pirate_bt.task.navigation import (
    Navigator,
    Observation,
    Step,
    raised_at,
)
from pirate_bt.task.plan import PabContract, direction_name
from pirate_bt.task.route import Route, RouteStep, StepKind, load_route
from pirate_bt.task.walker import branch_problem, branch_side

__all__ = [
    "ENTRY_POINT_GROUP",
    "GoalNavigator",
    "RouteNavigator",
    "check_navigator_map",
    "load_navigator",
    "navigator_defaults",
    "navigator_method",
    "navigator_names",
]

_log = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "pirate_bt.navigators"
"""The entry-point group that names navigators."""

_CONTRACT = PabContract()
_TOL_M = 1e-3
_SLACK, _SLACK_M = 0.1, 0.3
"""How much longer than the room before the next turn a route's leg may be, and be
shortened to fit (10 % of the leg and 0.3 m: where the last turn really ended)."""


def _way(network: Network, choices: Mapping[str, str]) -> Any:
    return network.path(dict(choices))


_NO_RETURN = (
    "{where}: {text!r} is not supported by the route navigator (pirate-bt mission runs"
    " it as one planned mission)"
)


def _route_file(name: str | Path) -> Path:
    """The route file ``name`` means, found as :func:`pirate_bt.simulate_mission` finds
    one (``api.file_options.find``): the path when something is there, else a bundled
    route, ``.route`` added to a name without a suffix: ``"bend-right"`` is
    ``scenarios/bend-right.route``, where it was the network ``bend-right.yaml`` (*a
    YAML file, not a route*)."""
    from pirate_bt.resources import data_dir, exists, missing

    path = Path(name)
    if not missing(path) or path.is_absolute() or len(path.parts) > 1:
        return path
    folder = data_dir("scenarios")
    if not path.suffix and exists(folder / f"{path}.route"):
        return folder / f"{path}.route"
    return folder / path.name if exists(folder / path.name) else path


class RouteNavigator:
    """Follow a route, one command per step; stop at the first step that fails.

    Args:
        route: A route file (``scenarios/lab.route``), a bundled route's name
            (``lab.route``, or ``lab``: a route, not the network ``lab.yaml``) or a
            parsed ``Route``.
    """

    def __init__(self, route: str | Path | Route) -> None:
        if not isinstance(route, str | Path | Route):  # as simulate_mission says it
            raise InputError(
                f"route: give a route file, a bundled name or a Route, not {kind_of(route)}"
            )
        if not isinstance(route, Route):  # '' was the working folder, a NUL Python's words
            route = load_route(_route_file(file_argument(route, "route")))
        self.route = route
        self._goal: GoalNavigator | None = None
        self._next = 0
        self.origin: tuple[str, int] | None = None
        """The route file and line of the command the last step serves: the step is
        planned, refused and labelled at that line (navigate() reads it)."""

    def check_map(self, network: Network | None) -> None:
        """Refuse, before anything moves, a route that this map (or no map) cannot serve.

        Raises:
            ValueError: ``forward to the end`` or ``go to`` without a map, or a ``go to``
                segment the map has no straight of that name for (named by its line);
                a route written for another network than the map (or for none) that
                does not fit the map, planned whole on it as a mission plans it
                (:mod:`pirate_bt.task.navigate_route_map`).
        """
        for command in self.route.steps:
            where = f"{self.route.source}:{command.line}:1"
            needs_map = command.kind is StepKind.GOTO or (
                command.kind in (StepKind.FORWARD, StepKind.INSPECT) and command.distance_m is None
            )
            if needs_map and network is None:
                raise ValueError(f"{where}: {command.text!r} needs a map (--map or map=...)")
            if command.kind is StepKind.RETURN:  # refused at its step, after connecting
                raise ValueError(_NO_RETURN.format(where=where, text=command.text))
            if command.kind is StepKind.GOTO and network is not None:
                assert command.segment is not None
                try:
                    GoalNavigator(command.segment).check_map(network)
                except ValueError as exc:
                    raise ValueError(f"{where}: {exc}") from None
        if network is not None:  # a route of another network: planned whole on the map
            check_route_on_map(self.route, network)

    def next_step(self, obs: Observation) -> Step | None:
        if obs.step == 0:  # a new navigation follows the route from its first command
            self._next, self._goal, self.origin = 0, None, None  # (it was done at once)
        if obs.last is not None and obs.last.outcome != "success":
            return None  # the result names the step's cause
        if self._goal is not None:
            step = self._goal.next_step(obs)
            if step is not None:
                return step
            self._goal = None
        if self._next >= len(self.route.steps):
            return None
        command = self.route.steps[self._next]
        self._next += 1
        self.origin = (self.route.source, command.line)
        return self._step(command, obs)

    def _turn_next(self) -> bool:
        """The route's next command is a turn (a bend or a T-joint)."""
        if self._next >= len(self.route.steps):
            return False
        return self.route.steps[self._next].kind in (StepKind.BEND, StepKind.TEE)

    def _step(self, command: RouteStep, obs: Observation) -> Step | None:
        kind = command.kind
        where = f"{self.route.source}:{command.line}:1"
        if kind in (StepKind.FORWARD, StepKind.INSPECT):
            slow = command.slowly or kind is StepKind.INSPECT
            distance = command.distance_m
            if distance is None:  # to the end
                if obs.map is None:
                    raise ValueError(f"{where}: 'to the end' needs a map")
                path = _way(obs.map, obs.choices)
                distance = path.length_m - _CONTRACT.end_margin_m - obs.belief.position_m
                if distance <= _TOL_M:
                    return self.next_step(obs)
            elif self._turn_next() and obs.map is not None:
                # The route's lengths are the drawing's, measured from where the last turn
                # was planned to end; the robot ends a turn where it really is. A leg up to
                # the turn the route takes next stops at the turn's approach point: the
                # turn's PAB senses the feature and absorbs the rest. A leg much longer
                # than the room is left as written: the planner refuses it, by name.
                ahead = obs.next_feature()
                room = None if ahead is None else ahead.distance_m - _CONTRACT.approach_m
                if room is not None and distance - room <= _SLACK * distance + _SLACK_M:
                    distance = min(distance, room)
                    if distance <= _TOL_M:
                        return self.next_step(obs)
            return Step("straight", distance=distance, slow=slow)
        if kind is StepKind.BACK:
            assert command.distance_m is not None
            return Step("straight", distance=-command.distance_m)
        if kind is StepKind.BEND:  # no direction: the map's next bend, whichever way
            return Step("bend", direction=command.direction) if command.direction else Step("bend")
        if kind is StepKind.TEE:
            return Step("t-joint", direction=command.direction)
        if kind is StepKind.PAUSE:
            return Step("wait", time=command.duration_s)
        if kind is StepKind.GOTO:
            assert command.segment is not None
            self._goal = GoalNavigator(command.segment)
            return self.next_step(obs)
        raise ValueError(_NO_RETURN.format(where=where, text=command.text))


class GoalNavigator:
    """Reach a segment of the map: the next turn towards it, or the last straight.

    Before every step the way is worked out again from the belief and the ways
    already taken at T-joints, so a corrected belief (a fix, a re-plan after a
    disagreement) is used at once.

    Args:
        segment: The map's segment to reach (the robot ends wholly inside it).
    """

    def __init__(self, segment: str) -> None:
        if not isinstance(segment, str) or not segment:
            raise InputError(f"segment: give a segment's id as text, not {shown(segment)}")
        self.segment = segment

    def check_map(self, network: Network | None) -> None:
        """Refuse, before anything moves, a goal that this map (or no map) cannot serve.

        Raises:
            ValueError: no map, no segment of that name, one that is not a straight, or
                one behind a T-joint whose branch the T-joint PAB cannot turn into.
        """
        if network is None:
            raise ValueError("the goal navigator needs a map (--map or map=...)")
        ids = network.segment_ids()
        if self.segment not in ids:
            known = ", ".join(sorted(ids)[:30]) + (", ..." if len(ids) > 30 else "")
            raise ValueError(
                f"the map {network.name!r} has no segment {self.segment!r} (it has: {known})"
            )
        kinds = {
            piece.kind
            for path in network.paths()
            for piece in path.pieces
            if piece.segment == self.segment
        }
        if kinds and PieceKind.STRAIGHT not in kinds:
            kind = sorted(k.value for k in kinds)[0]
            raise ValueError(f"{self.segment!r} is a {kind}: give a straight segment")
        for path in network.paths():  # the way to it: every branch on it must be taken
            if self.segment not in path.segments:
                continue
            for piece in path.pieces:
                if piece.segment == self.segment:
                    break
                if piece.kind is PieceKind.TEE and path.choices.get(piece.segment) == "branch":
                    problem = branch_problem(piece, _CONTRACT)
                    if problem is not None:
                        raise ValueError(f"{self.segment!r} cannot be reached: {problem}")
            break

    def next_step(self, obs: Observation) -> Step | None:
        network = obs.map
        self.check_map(network)
        assert network is not None
        if obs.last is not None and obs.last.outcome != "success" and not _map_stop(obs):
            return None
        here = obs.belief.position_m
        best = None
        for path in network.paths():
            if any(path.choices.get(t, c) != c for t, c in obs.choices.items()):
                continue
            if _branch_behind(path, obs.choices, here):
                continue
            for piece in path.pieces:
                if piece.segment == self.segment:
                    if best is None or piece.start_m < best[1].start_m:
                        best = (path, piece)
                    break
        if best is None:
            if _map_stop(obs):  # a turn that failed left the robot on the main line: the
                return None  # navigation ends on that failure, its cause first
            raise ValueError(f"{self.segment!r} cannot be reached from here")
        path, goal = best
        if goal.kind is not PieceKind.STRAIGHT:
            raise ValueError(f"{self.segment!r} is a {goal.kind.value}: give a straight segment")
        for piece in path.pieces:
            if piece.kind not in (PieceKind.BEND, PieceKind.TEE):
                continue
            if piece.start_m <= here + _TOL_M or piece.start_m >= goal.start_m:
                continue
            if piece.kind is PieceKind.BEND:
                side = direction_name(piece.roll_rad)
                if side is None:  # a roll between up, down, left and right (45 deg)
                    return Step("bend", roll=f"{math.degrees(piece.roll_rad):.1f} deg")
                return Step("bend", direction=side)
            way = path.choices.get(piece.segment, "straight")
            return Step(
                "t-joint",
                direction="straight" if way == "straight" else branch_side(piece),
            )
        is_end = goal.end_m >= path.length_m - _TOL_M
        last = goal.end_m - (_CONTRACT.end_margin_m if is_end else _CONTRACT.approach_m)
        target = min(goal.start_m + obs.robot_length_m + _CONTRACT.clear_m, last)
        if target - here > 0.01:
            return Step("straight", distance=target - here)
        return None


def _branch_behind(path: Any, choices: Mapping[str, str], here_m: float) -> bool:
    """``path`` turns into the branch of a tee the front tip is past with no way taken
    there: the robot went on along the main line (a turn into the branch that failed
    before it was felt leaves the robot there, and the way taken at the tee as it was)."""
    return any(
        piece.kind is PieceKind.TEE
        and piece.segment not in choices
        and piece.start_m <= here_m + _TOL_M
        and path.choices.get(piece.segment) == "branch"
        for piece in path.pieces
    )


_DISAGREEMENTS = ("belief and map disagree", "map disagreement")
"""How the localiser's and a step's map disagreements begin (task.localise, outcome)."""


def _map_stop(obs: Observation) -> bool:
    """The last step was stopped by a disagreement with the map (the robot is safe): its
    why begins as the localiser's and the mission's disagreements do (a why that only
    mentions the map, such as a stall's, is no disagreement)."""
    return obs.last is not None and obs.last.why.startswith(_DISAGREEMENTS)


_BUILT_IN: dict[str, Callable[..., Navigator]] = {
    "route": RouteNavigator,
    "goal": GoalNavigator,
    "explore": ExploreNavigator,
}


def _registered() -> dict[str, Any]:
    found: dict[str, Any] = {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}
    return found


def builtin_name(navigator: object) -> str | None:
    """The name of a built-in navigator's class (``ExploreNavigator()``: ``explore``)."""
    return next((n for n, cls in _BUILT_IN.items() if type(navigator) is cls), None)


_FILE_PARAMS: dict[str, frozenset[str]] = {
    "route": frozenset({"route"}),
    "explore": frozenset({"extend"}),
}
"""The built-in navigators' parameters that name a file (a campaign resolves them
against the spec's folder, as it does its trees and routes)."""


def navigator_file_params(name: str) -> frozenset[str]:
    """The parameters of navigator ``name`` that name a file: a built-in's, or a plug-in
    factory's ``file_params`` attribute (empty when it has none; one name given as text
    is that name, where it was read as its letters).

    Raises:
        InputError: ``file_params`` is not names (a number was a bare ``TypeError``).
    """
    if name in _FILE_PARAMS:
        return _FILE_PARAMS[name]
    try:
        entry = _registered().get(name)
        factory = entry.load() if entry is not None else None
        given = getattr(factory, "file_params", ())
    except (Exception, SystemExit):  # a broken plug-in (one that exits): making it says why
        return frozenset()
    if isinstance(given, str):
        return frozenset({given})
    try:
        names = frozenset(given)
    except TypeError:
        names = frozenset({0})  # refused below
    if not all(isinstance(n, str) for n in names):
        raise InputError(
            f"navigator {name!r}: file_params: give the names of the parameters that name a"
            f" file (file_params = frozenset({{'plan'}})), not {shown(given)}"
        )
    return names


def navigator_defaults(name: str) -> dict[str, str | float | int | bool]:
    """The parameters navigator ``name`` leaves to a default, with their defaults (those
    written as text, a number or a boolean): ``explore``'s ``search`` is ``3 m``. Empty
    for a name no navigator has, or a signature that cannot be read."""
    import inspect

    factory: Any = _BUILT_IN.get(name)
    try:
        if factory is None and (entry := _registered().get(name)) is not None:
            factory = entry.load()
        parameters = inspect.signature(factory).parameters.values()
    except (Exception, SystemExit):  # a broken plug-in (one that exits): making it says why
        return {}
    return {
        p.name: p.default
        for p in parameters
        if isinstance(p.default, str | float | int | bool) and not p.name.startswith("_")
    }


def navigator_names() -> list[str]:
    """Every navigator name: the built-ins and those of installed packages."""
    return sorted({*_BUILT_IN, *_registered()})


def _takes(factory: Callable[..., Any]) -> tuple[list[str], list[str]] | None:
    """The parameters ``factory`` takes, and those of them it needs (``None``: it takes
    any, or its signature cannot be read)."""
    import inspect

    try:
        signature = inspect.signature(factory)
    except (TypeError, ValueError):
        return None
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in signature.parameters.values()):
        return None
    taken = [p for p in signature.parameters.values() if p.kind in kinds]
    needed = [p.name for p in taken if p.default is inspect.Parameter.empty]
    return [p.name for p in taken], needed


def load_navigator(name: str, params: Mapping[str, Any] | None = None) -> Navigator:
    """The navigator called ``name``, made with ``params`` (keyword arguments).

    Raises:
        InputError: no such navigator (the known ones are listed), a parameter it needs
            and is not given (asked for as ``params={'segment': ...}``), parameters it
            does not take, an object without ``next_step``; a plug-in that does not
            load, or whose making raised anything else (a ``sys.exit()`` too), in one
            line with where it raised (*navigator 'mine' raised RuntimeError as it was
            made: ... (at FILE:LINE)*).
    """
    if not isinstance(name, str):
        raise InputError(f"navigator: give a navigator's name as text, not {name!r}"[:200])
    if params is not None and (
        not isinstance(params, Mapping) or not all(isinstance(k, str) for k in params)
    ):
        raise InputError(
            f"params: give a mapping of parameter names to values, not {params!r}"[:200]
        )
    factory: Callable[..., Any] | None = _BUILT_IN.get(name)
    if factory is not None and (shadowed := _registered().get(name)) is not None:
        # an installed package's navigator of a built-in's name is never the one made
        _log.warning(
            "navigator %r: the built-in one is used; the plug-in of that name (%s) is"
            " shadowed: register it under another name",
            name,
            shadowed.value,
        )
    if factory is None:
        entry = _registered().get(name)
        if entry is None:
            raise InputError(f"no navigator named {name!r} (known: {', '.join(navigator_names())})")
        try:
            factory = entry.load()
        except (Exception, SystemExit) as exc:  # a broken plug-in is named, not a traceback
            # (a sys.exit() of its module's ended the command with its code and no word)
            raise InputError(
                f"navigator {name!r} ({entry.value[:200]}) failed to load: {import_failure(exc)}"
            ) from exc
    assert factory is not None
    takes = _takes(factory)
    given = dict(params or {})
    if takes is not None:  # a parameter it needs, named as a Python caller gives it
        missing = [n for n in takes[1] if n not in given and not set(given) - set(takes[0])]
        if missing:  # (Python's words were "GoalNavigator.__init__() missing 1 ...")
            raise InputError(  # in a Python caller's words: the command line says --param
                f"navigator {name!r} needs the parameter {missing[0]!r}"
                f" (params={{{missing[0]!r}: ...}}; it takes: {', '.join(takes[0])})"[:300]
            )
        unknown = sorted(set(given) - set(takes[0]))
        if unknown:  # (Python's words were "__init__() got an unexpected keyword ...")
            known = ", ".join(takes[0]) or "none"
            said = f"navigator {name!r} takes no parameter {unknown[0][:40]!r}"
            raise InputError(f"{said} (it takes: {known})"[:300])
    try:
        navigator = factory(**given)
    except InputError as exc:  # a refusal of its parameters (a route file not found),
        # not its maker's bug: it was "navigator 'route' raised ValidationFailed as it was
        # made: ... (at .../route.py:545)"
        raise _refusal(name, exc, given) from None
    except TypeError as exc:
        known = f" (it takes: {', '.join(takes[0]) or 'none'})" if takes is not None else ""
        raise InputError(f"navigator {name!r}: {exc}{known}"[:300]) from None
    except (ValueError, OSError) as exc:  # a refusal of its parameters, one line
        raise InputError(f"navigator {name!r}: {said_of(exc, REFUSAL_LIMIT)}") from None
    except (Exception, SystemExit) as exc:  # its maker's own error (a plug-in's bug): it was
        # 'internal error', and a sys.exit(0) ended `navigate` with exit 0 and no word
        _log.debug("navigator %r raised as it was made", name, exc_info=exc)
        at = raised_at(exc)
        raise InputError(
            f"navigator {name!r} raised {type(exc).__name__} as it was made:"
            f" {said_of(exc, 200)}" + (f" (at {at})" if at else "")
        ) from exc
    if isinstance(navigator, type):  # its next_step unbound: was 'type.next_step(self, obs)'
        from pirate_bt.behaviours.foreign import one_line

        cls = one_line(navigator.__name__, 80)
        raise InputError(
            f"navigator {name!r} made the class {cls}, not a navigator: its entry point"
            f" should make an instance ({cls}(...))"
        )
    decide = navigator_method(navigator, "next_step", name)  # read as navigate() does
    if not callable(decide):
        raise InputError(f"navigator {name!r} made {shown(navigator)}, which has no next_step(obs)")
    problem = check_next_step_shape(decide)  # a campaign's cases would each have failed on it
    if problem is not None:
        raise ArgumentTypeError(f"navigator {name!r}: {problem}"[:300])
    return navigator  # type: ignore[no-any-return]


def _refusal(name: str, exc: InputError, given: Mapping[str, Any]) -> InputError:
    """A navigator's :class:`InputError` as it was made, as a refusal of its parameters:
    one line naming the navigator and, where it can be told, the parameter (*navigator
    'route', parameter 'route': missing.route:1:1: no such file*). A file's several
    problems give the first and how many more."""
    from pirate_bt.behaviours.foreign import one_line

    errors = exc.errors if isinstance(exc, ValidationFailed) else ()
    text = said_of(errors[0] if errors else exc)
    if len(errors) > 1:
        more = len(errors) - 1
        text += f" (and {more} more problem{'s' if more > 1 else ''} there)"
    text = text.removeprefix(f"{name}: ")  # its own name ('explore: search: ...'): said once
    key = _parameter_of(name, exc, text, given)
    if key is None:
        return InputError(one_line(f"navigator {name!r}: {text}", REFUSAL_LIMIT))
    text = text.removeprefix(f"{key}: ")  # its own words named it: named once
    return InputError(one_line(f"navigator {name!r}, parameter {key!r}: {text}", REFUSAL_LIMIT))


def _parameter_of(name: str, exc: InputError, text: str, given: Mapping[str, Any]) -> str | None:
    """The parameter a refusal is about: the one its words begin with (*segment: give
    ...*); for a file's problem the one parameter given that names a file (``route``'s
    ``route``, ``explore``'s ``extend``, a plug-in's ``file_params``); else the one
    whose value the words quote, or the only one given; ``None`` when none can be told."""
    starts = [k for k in given if text.startswith(f"{k}: ")]
    if starts:
        return starts[0]
    if isinstance(exc, ValidationFailed | LocatedError):
        try:  # a plug-in's file_params that are no names: its own refusal is said
            files = [k for k in sorted(navigator_file_params(name)) if k in given]
        except InputError:
            files = []
        if len(files) == 1:
            return files[0]
    quoted = [k for k in given if isinstance(given[k], str | Path) and str(given[k]) in text]
    if len(quoted) == 1 and str(given[quoted[0]]):
        return quoted[0]
    return next(iter(given)) if len(given) == 1 else None
