"""What a campaign spec's files hold, loaded once before any case runs.

Bad input is the campaign's fault, not a case outcome: :func:`check_runs` loads
every distinct tree (with its parameters), route and navigator of the cases, and
validates every network and robot file they name; :func:`check_faults` checks
every simulator fault's target on every robot. Each problem stops the campaign
with exit 2 and one located line instead of an ``error`` row per case.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.campaign.inputs import find_input, resolve_name, source_of
from pirate_bt.campaign.spec import CampaignSpec
from pirate_bt.errors import ConfigurationError, InputError, ValidationFailed

__all__ = ["check_faults", "check_runs"]

Case = dict[str, Any]


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

    source = source_of(spec)
    folder = base if base is not None else source.base
    world = load_network("straight")
    for robot_name in dict.fromkeys(spec.robots):
        resolved = resolve_name(robot_name, folder)
        bridge = SimBridge(PipeRobotModel(load_robot(resolved), world))
        for (i, j), text in faults:
            try:
                bridge.check_fault(parse_fault(text))
            except (ConfigurationError, InputError) as exc:
                robot = f" (robot {robot_name})" if robot_name is not None else ""
                raise source.error(("sim_faults", i, j), f"{exc}{robot}") from None


def _params_problems(
    spec: CampaignSpec, base: Path | None, tree: str, params: dict[str, str], exc: ValidationFailed
) -> InputError:
    """``exc``'s problems with a tree's parameters, placed where the spec gives them.

    The tree loader places a parameter's problem at ``--param:1:1`` (the command
    line's option); in a campaign the parameter was written in ``runs[i].params``.
    """
    source = source_of(spec)
    folder = base if base is not None else source.base
    index = next(
        (
            i
            for i, run in enumerate(spec.runs)
            if run.tree is not None
            and resolve_name(run.tree, folder) == tree
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
                path, files[file_key] = find_input(kind, str(name), near)
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
