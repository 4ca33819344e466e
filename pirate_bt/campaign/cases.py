"""Expanding a campaign's matrix into cases: plain, picklable, ordered, bounded.

A case is a plain ``dict`` of JSON values (so it crosses a process pipe, a
pickle or a Dask scheduler unchanged). Its ``id`` is its position in the
expansion plus a short digest of its parameters (``000042-1f3a9c0d``), so
``--resume`` can tell a finished case from one of an edited spec; it is a safe
file name whatever the spec says (see :mod:`pirate_bt.campaign.paths`).

Before anything is built, :func:`check_size` counts the cases from the axes'
lengths (the seed range by its count) and refuses a matrix larger than
``max_cases``; :func:`expand` does the same first. :func:`check_inputs` checks
that every file the spec names exists and is a file.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.campaign.spec import CampaignSpec, SpecSource, spec_source
from pirate_bt.errors import ConfigurationError, InputError, ValidationFailed

__all__ = [
    "DEFAULT_MAX_CASES",
    "Case",
    "check_faults",
    "check_inputs",
    "check_runs",
    "check_size",
    "expand",
    "group_key",
]

Case = dict[str, Any]

DEFAULT_MAX_CASES = 100_000
"""The most cases a campaign may expand to unless the caller allows more."""

# The parameters that define a group: every case parameter but the seed.
GROUP_FIELDS = ("run", "robot", "map", "sim_faults", "drop", "corrupt", "dup")


def _source(spec: CampaignSpec) -> SpecSource:
    return spec_source(spec) or SpecSource(f"campaign {spec.name!r}", Path("."))


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except (OSError, ValueError):  # a name too long for the file system
        return False


def _resolve(name: str | None, base: Path) -> str | None:
    """A path relative to the campaign file, when a file is there; else as written."""
    if name is None:
        return None
    candidate = base / name
    return str(candidate.resolve()) if _is_file(candidate) else name


def check_size(spec: CampaignSpec, max_cases: int = DEFAULT_MAX_CASES) -> int:
    """How many cases ``spec`` expands to, counted from its axes without expanding them.

    Args:
        spec: The campaign.
        max_cases: The most cases allowed.

    Returns:
        The number of cases.

    Raises:
        InputError: more than ``max_cases``; one line naming the spec's file and
            the place of its longest axis (``big.campaign.yaml:9:17: the campaign
            expands to 1,000,000,000 cases, more than the limit of 100,000
            (max_cases): ...``). A :class:`~pirate_bt.errors.LocatedError` for a file.
        ValueError: ``max_cases`` is below 1.
    """
    if max_cases < 1:
        raise ValueError("max_cases must be at least 1")
    total = spec.size()
    if total <= max_cases:
        return total
    axes = spec.axes()
    longest, _ = max(axes, key=lambda axis: axis[1])
    factors = " × ".join(f"{'.'.join(path)} {n:,}" for path, n in axes if n > 1)
    raise _source(spec).error(
        longest,
        f"the campaign expands to {total:,} cases, more than the limit of {max_cases:,}"
        f" (max_cases): {factors}",
    )


def expand(
    spec: CampaignSpec, base: Path | None = None, *, max_cases: int = DEFAULT_MAX_CASES
) -> list[Case]:
    """Every case of the matrix, in a fixed order.

    Args:
        spec: The campaign.
        base: The campaign file's folder; file names resolve against it first,
            then as given (the working folder, then the bundled files). Default:
            the folder the spec was loaded from (the working folder for data).
        max_cases: The most cases allowed (:func:`check_size`, checked first).

    Returns:
        The cases.

    Raises:
        InputError: the matrix has more than ``max_cases`` cases.
    """
    check_size(spec, max_cases)
    folder = base if base is not None else _source(spec).base
    max_time_s = spec.quantity("max_time", "time")
    timeout_s = spec.quantity("case_timeout", "time")
    period_s = 1.0 / spec.quantity("rate", "frequency")
    link_grid = list(itertools.product(spec.link.drop, spec.link.corrupt, spec.link.dup))
    # One resolved string per name, shared by every case that names it.
    resolved: dict[str | None, str | None] = {}

    def resolve(name: str | None) -> str | None:
        if name not in resolved:
            resolved[name] = _resolve(name, folder)
        return resolved[name]

    cases: list[Case] = []
    axes = itertools.product(spec.runs, spec.robots, spec.maps, spec.sim_faults, link_grid)
    built = spec.as_built
    variants: list[int | None] = (
        [None] if built is None else list(range(built.first, built.first + built.count))
    )
    for run, robot, truth, sim_faults, (drop, corrupt, dup) in axes:
        params = {k: str(v) for k, v in sorted(run.params.items())}
        for variant, seed in itertools.product(
            variants, range(spec.seeds.start, spec.seeds.start + spec.seeds.count)
        ):
            case: Case = {
                "index": len(cases),
                "run": run.label,
                "tree": resolve(run.tree),
                "route": resolve(run.route),
                "network": resolve(run.network),
                "params": dict(params),
                "robot": resolve(robot),
                "map": resolve(truth),
                "sim_faults": list(sim_faults),
                "drop": drop,
                "corrupt": corrupt,
                "dup": dup,
                "seed": seed,
                "max_time_s": max_time_s,
                "timeout_s": timeout_s,
                "period_s": period_s,
                "keep_traces": spec.keep_traces,
            }
            # only when given: the ids of campaigns without them stay as they were
            if run.navigator is not None:
                case["navigator"] = run.navigator
                case["blind"] = run.blind
            if built is not None:
                case["as_built"] = variant
                case["as_built_scale"] = built.scale
            digest = hashlib.sha256(json.dumps(case, sort_keys=True).encode()).hexdigest()
            # The index and a hex digest: always a safe file name (traces/ID).
            case["id"] = f"{case['index']:06d}-{digest[:8]}"
            cases.append(case)
    return cases


def _bare(name: str) -> bool:
    return "/" not in name and "\\" not in name


def _input_problem(kind: str, name: str, route: str | None = None) -> str | None:
    """Why the input file ``name`` of ``kind`` cannot be used, or ``None`` if it can."""
    return _find_input(kind, name, route)[1]


def _find_input(kind: str, name: str, route: str | None = None) -> tuple[Path | None, str | None]:
    """The input file ``name`` of ``kind``, or why it cannot be used.

    Each kind is looked up as the code that loads it does: a tree or a route as a
    path, else a bundled file; a tree's network as a path, else a bundled network;
    a route's network or truth map next to the route, then among the bundled
    networks; a robot as a path.
    """
    from pirate_bt.api.options import find
    from pirate_bt.resources import bundled, find_file

    shown = name if len(name) <= 80 else name[:77] + "..."
    what = f"{kind} {shown!r}"
    try:
        if kind == "tree":
            path = find_file("trees", name)
        elif kind == "route":
            path = find("scenarios", name, ".route")
        elif kind in ("network", "map") and route is not None:
            from pirate_bt.task.networks import resolve_network_path

            route_path = find("scenarios", route, ".route")
            try:
                path = resolve_network_path(name, route_path.parent)
            except FileNotFoundError as exc:
                return None, f"{what}: {exc}"
        elif kind == "network":
            path = Path(name)
            if not path.exists() and path.parent == Path(".") and not path.suffix:
                path = bundled("scenarios", name)
        else:
            path = Path(name)
        if path.is_file():
            return path, None
        if path.is_dir():
            return None, f"{what}: {path} is a directory, not a file"
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        return None, f"{what}: cannot use this name: {reason}"
    nor = f", nor a bundled {kind}" if kind in ("tree", "route", "network") and _bare(name) else ""
    return None, f"{what}: no such file{nor}"


def check_inputs(spec: CampaignSpec, base: Path | None = None) -> None:
    """Check that every file the spec names (trees, routes, networks, maps, robots) is a file.

    Names resolve as in :func:`expand`. Every problem is reported, each at its
    place in the spec (``file:line:column`` for a file).

    Raises:
        InputError: a named file is missing or is not a file
            (:class:`~pirate_bt.errors.ValidationFailed` for a file).
    """
    source = _source(spec)
    folder = base if base is not None else source.base
    problems: list[tuple[Sequence[str | int], str]] = []
    checked: dict[tuple[str, str, str | None], str | None] = {}

    def check(path: Sequence[str | int], kind: str, name: str, route: str | None = None) -> bool:
        key = (kind, name, route)
        if key not in checked:
            checked[key] = _input_problem(kind, str(_resolve(name, folder)), route)
        problem = checked[key]
        if problem is not None:
            problems.append((path, problem))
        return problem is None

    routes: list[str] = []
    navigators = False
    for i, run in enumerate(spec.runs):
        navigators = navigators or run.navigator is not None
        route: str | None = None
        if run.route is not None:
            if not check(("runs", i, "route"), "route", run.route):
                continue  # its network and maps are looked up next to it
            route = _resolve(run.route, folder)
            routes.append(str(route))
        elif run.tree is not None:
            check(("runs", i, "tree"), "tree", run.tree)
        if run.network is not None:
            check(("runs", i, "network"), "network", run.network, route)
    for i, robot in enumerate(spec.robots):
        if robot is not None:
            check(("robots", i), "robot", robot)
    for i, truth in enumerate(spec.maps):
        if truth is not None:
            for near in dict.fromkeys(routes):
                check(("maps", i), "map", truth, near)
            if navigators:  # a navigator's truth is a network of its own
                check(("maps", i), "network", truth)
    if problems:
        raise source.errors(problems)


def check_faults(spec: CampaignSpec, base: Path | None = None) -> None:
    """Check every simulator fault's target (a motor, state channel or board) on every robot.

    Call after :func:`check_runs` (the robot files then validate). Each case would
    meet the same problem when its simulator is made: it is the spec's, located at
    its ``sim_faults`` entry.

    Raises:
        InputError: a fault names a motor, channel or board a robot lacks
            (:class:`~pirate_bt.errors.LocatedError` for a file).
    """
    faults = [
        ((i, j), text) for i, point in enumerate(spec.sim_faults) for j, text in enumerate(point)
    ]
    if not faults:
        return
    from pirate_bt.pipes import load_network
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.sim.bridge import SimBridge
    from pirate_bt.sim.faults import parse_fault
    from pirate_bt.sim.model import PipeRobotModel

    source = _source(spec)
    folder = base if base is not None else source.base
    world = load_network("straight")
    for robot_name in dict.fromkeys(spec.robots):
        resolved = _resolve(robot_name, folder)
        bridge = SimBridge(PipeRobotModel(load_robot(resolved), world))
        for (i, j), text in faults:
            try:
                bridge.check_fault(parse_fault(text))
            except (ConfigurationError, InputError) as exc:
                robot = f" (robot {robot_name})" if robot_name is not None else ""
                raise source.error(("sim_faults", i, j), f"{exc}{robot}") from None


def group_key(row: dict[str, Any]) -> str:
    """One line naming a case's group (every parameter but the seed)."""
    parts = [str(row.get("run"))]
    if row.get("blind"):
        parts.append("blind")
    if row.get("robot"):
        parts.append(f"robot={Path(str(row['robot'])).stem}")
    if row.get("map"):
        parts.append(f"truth={Path(str(row['map'])).stem}")
    if row.get("as_built") is not None:  # the variants of a group are its runs, like seeds
        parts.append(f"as-built x{float(row.get('as_built_scale') or 1.0):g}")
    if row.get("sim_faults"):
        parts.append("+".join(row["sim_faults"]))
    parts.append(f"drop={row.get('drop', 0):g} corrupt={row.get('corrupt', 0):g}")
    parts[-1] += f" dup={row.get('dup', 0):g}"
    return " ".join(parts)


def _params_problems(
    spec: CampaignSpec, base: Path | None, tree: str, params: dict[str, str], exc: ValidationFailed
) -> InputError:
    """``exc``'s problems with a tree's parameters, placed where the spec gives them.

    The tree loader places a parameter's problem at ``--param:1:1`` (the command
    line's option); in a campaign the parameter was written in ``runs[i].params``.
    """
    source = _source(spec)
    folder = base if base is not None else source.base
    index = next(
        (
            i
            for i, run in enumerate(spec.runs)
            if run.tree is not None
            and _resolve(run.tree, folder) == tree
            and {k: str(v) for k, v in run.params.items()} == params
        ),
        None,
    )
    if index is None:
        return exc
    problems: list[tuple[Sequence[str | int], str]] = []
    for error in exc.errors:
        if error.location.file != "--param":
            return exc  # a problem of the tree file itself: located there
        path: tuple[str | int, ...] = ("runs", index, "params")
        name = next((k for k in params if f"parameter {k!r}" in error.message), None)
        problems.append(((*path, name) if name is not None else path, error.message))
    return source.errors(problems)


def check_runs(
    cases: list[Case], spec: CampaignSpec | None = None, base: Path | None = None
) -> None:
    """Load every distinct tree (with its parameters) and route once, before any case runs.

    Bad input is the campaign's fault, not a case outcome: it stops the campaign
    with exit 2 and a located error instead of a thousand ``error`` rows. With the
    ``spec`` the cases came from (and its ``base``, as for :func:`expand`), a
    problem with a tree's parameters is placed at the run's ``params`` in the spec.

    Raises:
        ValidationFailed: a tree, route, network (or truth map) or robot file does
            not validate.
        ConfigurationError: a named file (tree, route, network, map, robot) is
            missing or not a file.
    """
    from pirate_bt.api.options import find
    from pirate_bt.filekinds import validate_file
    from pirate_bt.resources import find_file

    seen: set[str] = set()
    files: dict[tuple[str, str, str | None], str | None] = {}
    valid: set[tuple[str, Path]] = set()
    for case in cases:
        route = case.get("route")
        names = [("tree", case.get("tree"), None), ("route", route, None)]
        truth_kind = "map" if route else "network"
        names += [("network", case.get("network"), route), (truth_kind, case.get("map"), route)]
        names += [("robot", case.get("robot"), None)]
        for kind, name, near in names:  # a route before its network and map
            if name is None:
                continue
            file_key = (kind, str(name), near)
            if file_key not in files:
                path, files[file_key] = _find_input(kind, str(name), near)
                what = {"map": "network", "network": "network", "robot": "hardware"}.get(kind)
                if path is not None and what is not None and (what, path) not in valid:
                    # as each case will load it: a bad network or robot file is the
                    # campaign's input error, not an error row of every case
                    validate_file(path, what)
                    valid.add((what, path))
            if files[file_key] is not None:
                raise ConfigurationError(f"run {case.get('run')!r}: {files[file_key]}")
        key = json.dumps(
            [
                case["tree"],
                case["route"],
                case.get("navigator"),
                case["params"],
                None if case.get("blind") else case.get("network"),
            ],
            sort_keys=True,
        )
        if key in seen:
            continue
        seen.add(key)
        if case.get("navigator"):
            from pirate_bt.task.navigators import load_navigator

            try:  # made once, as each case will: an unknown name or parameter stops here
                navigator = load_navigator(case["navigator"], case["params"])
            except InputError as exc:
                raise InputError(f"run {case.get('run')!r}: {exc}") from None
            if callable(getattr(navigator, "check_map", None)):  # as navigate() will
                from pirate_bt.api.missions import load_network
                from pirate_bt.task.navigators import check_navigator_map

                drawn = None if case.get("blind") else (case.get("network") or "straight")
                the_map = None if drawn is None else load_network(drawn, base=base)
                try:
                    check_navigator_map(navigator, case["navigator"], the_map)
                except InputError as exc:
                    raise InputError(f"run {case.get('run')!r}: {exc}") from None
        elif case["tree"]:
            from pirate_bt.robot.loader import load_robot
            from pirate_bt.treefile.loader import load_tree

            try:  # as the case will: a parameter without a default must be given
                load_tree(
                    find_file("trees", case["tree"]),
                    robot=load_robot(),
                    params=case["params"],
                    params_from_text=True,
                )
            except ValidationFailed as exc:
                if spec is None:
                    raise
                raise _params_problems(spec, base, case["tree"], case["params"], exc) from None
        else:
            validate_file(find("scenarios", case["route"], ".route"), "route")
