"""The files a campaign spec names: looked up as the code that loads them does, checked to exist.

A spec names trees, routes, networks, truth maps and robots. :func:`resolve_name`
resolves a name against the spec's folder (a file there wins; else the name
stays as written, for the working folder and the bundled files),
:func:`find_input` looks a name up as the code that loads its kind does, and
:func:`check_inputs` checks that every name of a spec is a file, each problem at
its place in the spec. Loading what the files hold is
:mod:`pirate_bt.campaign.checks`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.campaign.spec import CampaignSpec, SpecSource, spec_source

__all__ = [
    "check_inputs",
    "find_input",
    "input_problem",
    "is_file",
    "resolve_name",
    "run_index",
    "source_of",
]


def source_of(spec: CampaignSpec) -> SpecSource:
    """Where ``spec`` came from (a stand-in naming the campaign for a model built otherwise)."""
    return spec_source(spec) or SpecSource(f"campaign {spec.name!r}", Path("."))


def run_index(spec: CampaignSpec, case: dict[str, Any]) -> int | None:
    """The index in ``spec.runs`` of the run ``case`` is of (run names are distinct)."""
    return next((i for i, run in enumerate(spec.runs) if run.label == case.get("run")), None)


def is_file(path: Path) -> bool:
    """Whether ``path`` is a file (``False`` for a name the file system refuses)."""
    try:
        return path.is_file()
    except (OSError, ValueError):  # a name too long for the file system
        return False


def resolve_name(name: str | None, base: Path) -> str | None:
    """A path relative to the campaign file, when a file is there; else as written."""
    if name is None:
        return None
    candidate = base / name
    return str(candidate.resolve()) if is_file(candidate) else name


def _bare(name: str) -> bool:
    return "/" not in name and "\\" not in name


def input_problem(kind: str, name: str, route: str | None = None) -> str | None:
    """Why the input file ``name`` of ``kind`` cannot be used, or ``None`` if it can."""
    return find_input(kind, name, route)[1]


def find_input(kind: str, name: str, route: str | None = None) -> tuple[Path | None, str | None]:
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
        if path.exists():  # /dev/zero, a pipe: 'no such file' was wrong
            return None, f"{what}: {path} is not a regular file (a device or a pipe)"
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
    source = source_of(spec)
    folder = base if base is not None else source.base
    problems: list[tuple[Sequence[str | int], str]] = []
    checked: dict[tuple[str, str, str | None], str | None] = {}

    def check(path: Sequence[str | int], kind: str, name: str, route: str | None = None) -> bool:
        key = (kind, name, route)
        if key not in checked:
            checked[key] = input_problem(kind, str(resolve_name(name, folder)), route)
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
            route = resolve_name(run.route, folder)
            routes.append(str(route))
        elif run.tree is not None:
            check(("runs", i, "tree"), "tree", run.tree)
        if run.network is not None:
            check(("runs", i, "network"), "network", run.network, route)
        if run.navigator == "explore" and "output" in run.params:
            # every case wrote its survey to that one file, wherever it was
            problems.append(
                (
                    ("runs", i, "params", "output"),
                    f"run {run.label!r}: every case of navigator 'explore' would write its"
                    " survey to this one file, outside the campaign's folder; leave"
                    " 'output' out (a campaign writes only into its own folder)",
                )
            )
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
