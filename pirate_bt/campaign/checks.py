"""What a campaign spec's files hold, loaded once before any case runs.

Bad input is the campaign's fault, not a case outcome: :func:`check_axes`
(:mod:`pirate_bt.campaign.axes`) refuses an axis that names one point twice (the
report would count its identical, deterministic cases as independent samples);
:func:`check_runs` loads every
distinct tree (with its parameters) against every robot of the axis, plans every
route on its map for every robot and builds its PAB trees, makes every navigator,
and validates every network and robot file the cases name; :func:`check_faults`
checks every simulator fault's target on every robot. Each problem stops the
campaign with exit 2 and one located line instead of an ``error`` row per case.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.campaign.axes import check_axes
from pirate_bt.campaign.faulttimes import check_fault_times
from pirate_bt.campaign.inputs import find_input, resolve_name, run_index, source_of
from pirate_bt.campaign.loads import Loads
from pirate_bt.campaign.navchecks import check_navigator
from pirate_bt.campaign.spec import CampaignSpec, SpecSource
from pirate_bt.errors import (
    ConfigurationError,
    InputError,
    LocatedError,
    ValidationFailed,
    shown,
)

__all__ = ["check_axes", "check_faults", "check_runs"]

Case = dict[str, Any]


def check_faults(spec: CampaignSpec, base: Path | None = None, loads: Loads | None = None) -> None:
    """Check every simulator fault's target (a motor, state channel or board) on every robot.

    Call after :func:`check_runs` (the robot files then validate). Each case would
    meet the same problem when its simulator is made: it is the spec's, located at
    its ``sim_faults`` entry. ``loads``: the check's robots, loaded once
    (:mod:`~pirate_bt.campaign.loads`; those :func:`check_runs` loaded).

    Raises:
        InputError: a fault names a motor, channel or board a robot lacks
            (:class:`~pirate_bt.errors.LocatedError` for a file).
    """
    faults = [
        ((i, j), text) for i, point in enumerate(spec.sim_faults) for j, text in enumerate(point)
    ]
    if not faults:
        return
    check_fault_times(spec)
    from pirate_bt.pipes import load_network
    from pirate_bt.sim.bridge import SimBridge
    from pirate_bt.sim.faults import parse_fault
    from pirate_bt.sim.model import PipeRobotModel

    source = source_of(spec)
    folder = base if base is not None else source.base
    world = load_network("straight")
    robots = loads if loads is not None else Loads()
    for robot_name in dict.fromkeys(spec.robots):
        resolved = resolve_name(robot_name, folder)
        bridge = SimBridge(PipeRobotModel(robots(resolved), world))
        for (i, j), text in faults:
            try:
                bridge.check_fault(parse_fault(text))
            except (ConfigurationError, InputError) as exc:
                robot = f" (robot {robot_name})" if robot_name is not None else ""
                raise source.error(("sim_faults", i, j), f"{exc}{robot}") from None


def _robot_index(spec: CampaignSpec, folder: Path, case: Case) -> int | None:
    """The index in ``spec.robots`` of the robot ``case`` runs."""
    robot = case.get("robot")
    return next((i for i, r in enumerate(spec.robots) if resolve_name(r, folder) == robot), None)


def _entry(
    spec: CampaignSpec | None, base: Path | None, case: Case, kind: str
) -> tuple[str | int, ...] | None:
    """The key path of the spec's entry that names the case's ``kind`` of file (its
    run's ``network`` or ``route``, its ``robots`` or ``maps`` entry), or None."""
    if spec is None:
        return None
    if kind in ("network", "route"):
        index = run_index(spec, case)
        return None if index is None else ("runs", index, kind)
    folder = base if base is not None else source_of(spec).base
    axis, name = ("robots", spec.robots) if kind == "robot" else ("maps", spec.maps)
    given = case.get(kind)
    found = next((i for i, e in enumerate(name) if resolve_name(e, folder) == given), None)
    return None if found is None else (axis, found)


def _named_at(
    exc: ValidationFailed, spec: CampaignSpec | None, entry: tuple[str | int, ...] | None
) -> ValidationFailed:
    """A named file's problems, each at its place in that file, with the spec's entry
    that names it: a network that did not parse was told at its own line alone, and
    which run, robot or truth of the spec had named it was left to guess."""
    if spec is None or entry is None:
        return exc
    return ValidationFailed(_named_by(e, spec, entry) for e in exc.errors)


def _named_by(
    error: LocatedError, spec: CampaignSpec, entry: tuple[str | int, ...]
) -> LocatedError:
    """``error`` at its own place, ending with the spec's ``entry`` that named its file."""
    source = source_of(spec)
    said = f"runs[{entry[1]}].{entry[2]}" if entry[0] == "runs" else f"{entry[0]}[{entry[1]}]"
    # data has no lines: "campaign 'h': maps[1]" names the entry already
    by = f"{said} at {source.where(entry)}" if source.locator is not None else source.where(entry)
    return LocatedError(f"{error.message} (named by {by})", error.location)


def _joined(errors: Sequence[InputError]) -> InputError:
    """Several problems as one error, one line each (a ``ValidationFailed`` if all are located)."""
    if len(errors) == 1:
        return errors[0]
    located = [e for e in errors if isinstance(e, LocatedError)]
    if len(located) == len(errors):
        return ValidationFailed(located)
    return InputError("\n".join(map(str, errors)))


def _params_problems(
    spec: CampaignSpec, base: Path | None, case: Case, exc: ValidationFailed
) -> InputError:
    """``exc``'s problems with a tree's parameters, placed where the spec gives them.

    The tree loader places a parameter's problem at ``--param NAME=VALUE`` (the command
    line's option); in a campaign the parameter was written in ``runs[i].params``,
    at its own key when the problem names it. A problem of a YAML tree file itself
    stays where it is written, followed by the run's entry that named the tree
    (``(named by runs[1].tree at spec.yaml:4:15)``), but a parameter it declares
    without a default that the run does not give is placed at the run
    (``spec.yaml:3:5: run 'b': parameter 'distance' has no default and was not
    given (declared at tree.yaml:6:1)``); one
    of a BehaviorTree.CPP XML file (malformed, an unknown node) is placed at the
    run's ``tree`` entry, naming the XML's own place: ``spec.yaml:3:15: run 'a':
    tree 'bad.xml': unknown node type 'NoSuchNode' (at bad.xml:4:7)``.
    """
    source = source_of(spec)
    index = run_index(spec, case)
    if index is None:
        return exc
    params: dict[str, str] = case["params"]
    xml = _is_xml(case["tree"])
    found: list[InputError] = []
    for error in exc.errors:
        if error.location.file != "--param":
            if xml:
                written = spec.runs[index].tree or case["tree"]  # as the spec writes it
                run = f"run {case.get('run')!r}: tree {shown(written)}"
                message = f"{run}: {error.message} (at {error.location})"
                found.append(source.error(("runs", index, "tree"), message))
            elif _NOT_GIVEN.match(error.message):
                # the run left it out, not the tree: at the run (its params, if any),
                # naming the declaration (two runs of one tree were told apart by nothing)
                where = ("runs", index, "params") if params else ("runs", index)
                message = f"run {case.get('run')!r}: {error.message} (declared at {error.location})"
                found.append(source.error(where, message))
            else:  # the tree's own (or a subtree's), and which run named the tree
                found.append(_named_by(error, spec, ("runs", index, "tree")))
            continue
        path: tuple[str | int, ...] = ("runs", index, "params")
        name = next((k for k in params if f"parameter {k!r}" in error.message), None)
        found.append(source.error((*path, name) if name is not None else path, error.message))
    return _joined(found)


_NOT_GIVEN = re.compile(r"parameter '[^']*' has no default and was not given")
"""The tree loader's problem of a parameter the run must give (treefile/header.py)."""


def _is_xml(tree: str) -> bool:
    """Whether a run's tree is a BehaviorTree.CPP XML file (read as ``pirate-bt run`` does)."""
    return Path(tree).suffix.lower() == ".xml"


def _robot_problems(
    source: SpecSource, robot: tuple[int, str], run: str, exc: ValidationFailed
) -> InputError:
    """``exc``'s problems, which only this robot of the axis meets, at its entry in the spec."""
    index, name = robot
    found: list[InputError] = []
    for error in exc.errors:
        place = "" if error.location.file == "--param" else f" (at {error.location})"
        message = f"robot {name!r}: run {run!r}: {error.message}{place}"
        found.append(source.error(("robots", index), message))
    return _joined(found)


def _check_tree(
    case: Case, robots: Loads, spec: CampaignSpec | None, base: Path | None
) -> list[str]:
    """Load the case's tree with its parameters against its robot, as the case will
    (a YAML tree, or a BehaviorTree.CPP XML file as :func:`pirate_bt.simulate_tree`
    reads it); the files it read (the tree file, then its subtrees' files).

    The tree with these parameters is loaded once for every robot (``robots.tree``),
    and each robot's limits asked of its nodes; only a robot that refuses it (or a
    tree that does not load) loads it again, to be said as the loader says it."""
    from pirate_bt.api.running import load_tree_source
    from pirate_bt.resources import find_file

    once = robots.tree(case["tree"], case["params"])
    if once is not None and robots.fits(once, robots(case.get("robot"))):
        # an XML tree is read through a YAML copy of its own: the XML is the file read
        return [str(find_file("trees", case["tree"]))] if _is_xml(case["tree"]) else once.files

    def load(robot: Any) -> list[str]:
        source = find_file("trees", case["tree"])
        try:
            loaded = load_tree_source(
                source,
                robot=robot,
                params=case["params"],
                params_from_text=True,
                params_origin="--param",
            )
        except LocatedError as exc:  # the XML reader's one problem (malformed XML)
            raise ValidationFailed([exc]) from None
        # an XML tree is read through a YAML copy of its own: the XML is the file read
        return [str(source)] if _is_xml(case["tree"]) else loaded.files

    try:  # as the case will: a parameter without a default must be given
        return load(robots(case.get("robot")))
    except ValidationFailed as exc:
        if spec is None:
            raise
        axis = _axis_robot(spec, base, case)
        # this robot's, when another takes it; else the tree's own problem or its
        # parameters' (a velocity of 0, which every robot refuses, was said at the
        # first robot's entry as that robot's, when it was a run's parameter)
        if axis is not None and once is not None and _taken_by_another(once, robots, spec, base):
            raise _robot_problems(*axis, str(case.get("run")), exc) from None
        raise _params_problems(spec, base, case, exc) from None


def _taken_by_another(loaded: Any, robots: Loads, spec: CampaignSpec, base: Path | None) -> bool:
    """Whether a robot of the axis, or the bundled one, takes ``loaded`` (its limits)."""
    folder = base if base is not None else source_of(spec).base
    for name in dict.fromkeys([None, *(resolve_name(r, folder) for r in spec.robots)]):
        try:
            robot = robots(name)
        except (InputError, OSError):  # its own problem, said at its own cases
            continue
        if robots.fits(loaded, robot):
            return True
    return False


def _axis_robot(
    spec: CampaignSpec, base: Path | None, case: Case
) -> tuple[SpecSource, tuple[int, str]] | None:
    """The spec's source and ``(index, entry)`` of the case's robot on the ``robots``
    axis, where a problem only that robot has is placed; ``None`` for the bundled one."""
    source = source_of(spec)
    folder = base if base is not None else source.base
    index = _robot_index(spec, folder, case)
    if index is None or spec.robots[index] is None:
        return None
    return source, (index, str(spec.robots[index]))


def _route_problem(case: Case, route_file: Path) -> tuple[str, str] | None:
    """Why the route of ``case`` cannot be its map's: its network line names another.

    Returns ``(the key of the run to place it at, the message)``, or ``None``.
    """
    from pirate_bt.api.missions import load_route
    from pirate_bt.task.networks import resolve_network_path

    route = load_route(route_file)
    given = case.get("network")
    if given is None or route.network is None:
        return None
    path, _problem = find_input("network", str(given), str(route_file))
    try:
        own = resolve_network_path(route.network, route_file.parent)
    except FileNotFoundError as exc:
        return "route", str(exc)
    if path is not None and path.resolve() == own.resolve():
        return None
    where = f" ({route.network_location})" if route.network_location else ""
    return "network", (
        f"the route names network {route.network!r}{where}, not {str(given)!r}: a route run's"
        " 'network' is the map it is planned on; leave it out or give the route's own, and"
        " list simulated truths under 'maps'"
    )


def _check_route(
    case: Case, robots: Loads, spec: CampaignSpec | None, base: Path | None
) -> list[str]:
    """Plan the case's route on its map for its robot and build its PAB trees, as the case will.

    A run's ``network`` is the route's map (as ``pirate-bt mission ROUTE --network
    MAP``): a route whose own ``network`` line names another, or that does not fit
    it, is the spec's problem, placed at the run.

    Returns:
        The files read besides those the case names: the route's own network (its
        map when the run names none) and the PAB tree files of its mission.
    """
    from pirate_bt.api.missions import plan_route
    from pirate_bt.api.options import find
    from pirate_bt.filekinds import validate_file
    from pirate_bt.task.tree import mission_tree_spec
    from pirate_bt.treefile.loader import load_tree

    route_file = find("scenarios", case["route"], ".route")
    try:
        validate_file(route_file, "route")
    except ValidationFailed as exc:
        raise _named_at(exc, spec, _entry(spec, base, case, "route")) from None
    run = str(case.get("run"))
    robot = robots(case.get("robot"))
    problem = _route_problem(case, route_file)
    if problem is None:
        try:
            plan = plan_route(route_file, network=case.get("network"), robot=robot)
        except InputError as exc:  # does not fit the map, or names none
            key = "network" if case.get("network") is not None else "route"
            problem = key, str(exc)
    if problem is not None:
        key, message = problem
        index = None if spec is None else run_index(spec, case)
        if spec is None or index is None:
            raise InputError(f"run {run!r}: {message}")
        raise source_of(spec).error(("runs", index, key), f"run {run!r}: {message}")
    try:  # the mission's tree, as the case builds it for its robot
        tree = load_tree(mission_tree_spec(plan, None, robot.motion.nominal_speed), robot=robot)
    except ValidationFailed as exc:
        axis = None if spec is None else _axis_robot(spec, base, case)
        if axis is None:
            raise
        raise _robot_problems(*axis, run, exc) from None
    return [*([str(plan.network.source)] if case.get("network") is None else []), *tree.files]


def check_runs(
    cases: list[Case],
    spec: CampaignSpec | None = None,
    base: Path | None = None,
    case_timeout_s: float | None = None,
    loads: Loads | None = None,
) -> list[Path]:
    """Load every distinct tree (with its parameters) and route once per robot, before any case.

    Bad input is the campaign's fault, not a case outcome: it stops the campaign
    with exit 2 and a located error instead of a thousand ``error`` rows. With the
    ``spec`` the cases came from (and its ``base``, as for :func:`expand`), a
    problem with a tree's parameters is placed at the run's ``params`` in the
    spec, a tree or a route's PAB trees that only a robot of the ``robots`` axis
    refuses at that robot's entry (naming the tree's place), and a route that is
    not its run's ``network``'s (its own ``network`` line names another, or it
    does not fit) at the run. ``case_timeout_s``, a case timeout given beside the
    spec's (``--case-timeout``), is the longest an installed navigator may take to be
    made, if longer than the spec's. ``loads``: what this check of the spec loaded so
    far (:mod:`~pirate_bt.campaign.loads`): each robot file and each distinct tree
    with its parameters is loaded once.

    Returns:
        Every input file the checks read, resolved, once each in the order first
        read: the files the cases name (trees, routes, networks, truth maps,
        robots) and those they pull in (subtree files, a route's own network and
        its PAB trees, a route navigator's route); what ``--resume`` digests
        (:mod:`pirate_bt.campaign.started`).

    Raises:
        ValidationFailed: a tree, route, network (or truth map) or robot file does
            not validate (a route, network, map or robot: with the spec's entry).
        InputError: a route that does not fit its run's network; a navigator that
            cannot be made.
        ConfigurationError: a named file (tree, route, network, map, robot) is
            missing or not a file.
    """
    from pirate_bt.filekinds import validate_file

    seen: set[str] = set()
    read: dict[Path, None] = {}  # in the order first read
    files: dict[tuple[str, str, str | None], str | None] = {}
    valid: set[tuple[str, Path]] = set()
    robots = loads if loads is not None else Loads()
    located: dict[tuple[str, str, str | None], Path | None] = {}
    networks: dict[Path, Any] = {}  # each truth's, to check where the robot is put in
    put_in: set[tuple[Path, str | None]] = set()
    for case in cases:
        route = case.get("route")
        names = [("tree", case.get("tree"), None), ("route", route, None)]
        truth_kind = "map" if route else "network"
        truth: Path | None = None
        names += [("network", case.get("network"), route), (truth_kind, case.get("map"), route)]
        names += [("robot", case.get("robot"), None)]
        for kind, name, near in names:  # a route before its network and map
            if name is None:
                continue
            file_key = (kind, str(name), near)
            if file_key not in files:
                path, files[file_key] = find_input(kind, str(name), near)
                located[file_key] = path
                _note(read, path)
                what = {"map": "network", "network": "network", "robot": "hardware"}.get(kind)
                if path is not None and what is not None and (what, path) not in valid:
                    # as each case will load it: a bad network or robot file is the
                    # campaign's input error, not an error row of every case
                    try:
                        described = validate_file(path, what)
                    except ValidationFailed as exc:
                        raise _named_at(exc, spec, _entry(spec, base, case, kind)) from None
                    valid.add((what, path))
                    if kind == "robot":  # loaded once: the checks below ask for it
                        robots.keep_robot(name, described)
                    else:
                        networks[path] = described
            if kind == _truth_kind(case):
                truth = located[file_key]
            if files[file_key] is not None:
                raise ConfigurationError(f"run {case.get('run')!r}: {files[file_key]}")
        if truth is not None and (truth, case.get("robot")) not in put_in:
            put_in.add((truth, case.get("robot")))
            _check_put_in(case, networks[truth], robots, spec, base)
        key = json.dumps(
            [
                case.get("run"),
                case["tree"],
                case["route"],
                case.get("navigator"),
                case["params"],
                None if case.get("blind") else case.get("network"),
                None if case.get("navigator") and case.get("blind") else case.get("robot"),
            ],
            sort_keys=True,
        )
        if key in seen:
            continue
        seen.add(key)
        if case.get("navigator"):
            more = check_navigator(case, robots, spec, base, case_timeout_s)
        elif case["tree"]:
            more = _check_tree(case, robots, spec, base)
        else:
            more = _check_route(case, robots, spec, base)
        for name in more:
            _note(read, Path(name))
    return list(read)


def _truth_kind(case: Case) -> str | None:
    """The key of the case's file the simulator runs as the world, when it is not also
    the map a plan is checked on (that one is refused at planning): a ``maps`` entry, a
    tree's or a blind navigator's network."""
    if case.get("map"):
        return "map"
    if case.get("tree") or (case.get("navigator") and case.get("blind")):
        return "network"
    return None


def _check_put_in(
    case: Case, network: Any, robots: Loads, spec: CampaignSpec | None, base: Path | None
) -> None:
    """Refuse a truth that puts the case's robot in across a bend or T-joint, at its
    entry in the spec, as the simulator of each case would (an error row each)."""
    from pirate_bt.sim.simulator import put_in_problem

    problem = put_in_problem(network, robots.robot(case.get("robot")))
    if problem is None:
        return
    entry = _entry(spec, base, case, _truth_kind(case) or "network")
    message = f"run {case.get('run')!r}: {problem}"
    if spec is None or entry is None:
        raise ConfigurationError(message)
    raise source_of(spec).error(entry, message)


def _note(read: dict[Path, None], path: Path | None) -> None:
    """Add ``path`` to the files read, resolved, when it is a file (not ``<dict>``)."""
    if path is None:
        return
    try:
        if path.is_file():
            read.setdefault(path.resolve(), None)
    except (OSError, RuntimeError, ValueError):  # pragma: no cover - checked before
        pass
