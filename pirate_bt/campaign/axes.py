"""A campaign spec's axes, each point once: :func:`check_axes`.

Two entries of an axis that run the same (``0`` and ``0.0``, a file by two names,
faults written apart or in another order, a run under another name, a parameter
named at its default) run the same deterministic cases, which the report would
count as independent samples: the second is refused, before any case runs. Split
from :mod:`pirate_bt.campaign.checks`, which re-exports :func:`check_axes`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.campaign.inputs import find_input, resolve_name, source_of
from pirate_bt.campaign.loads import Loads
from pirate_bt.campaign.runparams import params_as_read
from pirate_bt.campaign.spec import CampaignSpec
from pirate_bt.errors import InputError

__all__ = ["check_axes"]


def _file_identity(kind: str, name: str | None, folder: Path, route: str | None = None) -> str:
    """One text per file, however it is named (``lab``, ``lab.yaml``, ``./lab.yaml``)."""
    if name is None:
        return ""
    resolved = str(resolve_name(name, folder))
    path, _problem = find_input(kind, resolved, route)
    try:
        return str(path.resolve()) if path is not None else resolved
    except (OSError, RuntimeError):  # pragma: no cover - a name the file system refuses
        return resolved


def _fault_point(point: Sequence[str]) -> str:
    """A point of the ``sim_faults`` axis as parsed (``@1s`` and ``@1 s`` alike), in any
    order, a fault listed twice as once (the simulator runs both points alike)."""
    from pirate_bt.sim.faults import parse_fault

    parsed = {json.dumps(parse_fault(f).model_dump(mode="json"), sort_keys=True) for f in point}
    return json.dumps(sorted(parsed))


def _param_identity(value: str | bool | int | float) -> str:
    """A parameter as the run will read it: ``1 m``, ``1m`` and ``100 cm`` alike.

    A quantity is its dimension and SI value (to 12 digits), a number its value;
    any other text stays as written.
    """
    from pirate_bt.errors import UnitError
    from pirate_bt.units import DIMENSIONS, parse_quantity

    if isinstance(value, bool):
        return str(value).lower()
    if not isinstance(value, str):
        try:
            return f"{float(value):.12g}"
        except OverflowError:  # an integer past a float: refused by the tree later
            return str(value)
    for dimension in DIMENSIONS:
        try:
            si = parse_quantity(value, dimension)
        except (UnitError, ValueError):
            continue
        return f"{dimension} {si:.12g}"
    return value


def _navigator_file_identities(navigator: str, params: Any, folder: Path) -> dict[str, str]:
    """A navigator run's parameters that name a file (``route``'s ``route``,
    ``explore``'s ``extend``, a plug-in's ``file_params``), each as the file it names:
    ``t-joint`` and ``t-joint.route`` were two points of one route."""
    from pirate_bt.task.navigators import navigator_file_params

    kinds = {"route": "route", "extend": "network"} if navigator in ("route", "explore") else {}
    out: dict[str, str] = {}
    for key in navigator_file_params(navigator) & params.keys():
        value = params[key]
        if isinstance(value, str):
            out[key] = "file " + _file_identity(kinds.get(key, "file"), value, folder)
    return out


def _run_map(run: Any, folder: Path) -> str:
    """The identity of the network a run is planned on or runs in, its default filled in.

    A tree's or navigator's ``network`` defaults to ``straight``; a route's to its own
    ``network`` line (``""`` when that cannot be read: the run's own check says why).
    """
    from pirate_bt.api.options import DEFAULT_NETWORK

    route = resolve_name(run.route, folder)
    if run.network is not None:
        return _file_identity("network", run.network, folder, route)
    if route is None:
        return _file_identity("network", DEFAULT_NETWORK, folder)
    try:
        from pirate_bt.api.missions import load_route

        path, _problem = find_input("route", route)
        own = load_route(path).network if path is not None else None
    except (InputError, OSError):
        return ""
    return _file_identity("network", own, folder, route) if own is not None else ""


def _axis_entries(
    spec: CampaignSpec, folder: Path, loads: Loads
) -> list[tuple[str, list[tuple[str, str]]]]:
    """Each axis as ``(its key path, [(an entry's identity, how it reads), ...])``.

    An entry left to its default (``null``) is that default: the bundled robot's file,
    a run's own map; two entries that run the same are one point.
    """
    from pirate_bt.resources import default_robot_path

    routes = [resolve_name(r.route, folder) for r in spec.runs if r.route is not None]
    near = routes[0] if routes else None
    map_kind = "map" if near is not None else "network"
    maps_of_runs = [_run_map(run, folder) for run in spec.runs]
    runs = []
    for run, its_map in zip(spec.runs, maps_of_runs, strict=True):
        kind = "tree" if run.tree else "route" if run.route else "navigator"
        name = run.tree or run.route or run.navigator
        params = {
            k: _param_identity(v)
            for k, v in sorted(params_as_read(run, folder, loads.tree).items())
        }
        if run.navigator is not None:  # a file by its name or its path: one file
            params.update(_navigator_file_identities(run.navigator, run.params, folder))
        identity = [
            kind,
            _file_identity(kind, name, folder) if kind != "navigator" else name,
            its_map,
            params,
            run.blind,
        ]
        runs.append((json.dumps(identity, sort_keys=True), repr(run.label)))
    bundled = str(default_robot_path().resolve())

    def truth(entry: str | None) -> str:
        # the truth each run meets: null is each run's own map
        if entry is None:
            return json.dumps(maps_of_runs)
        return json.dumps([_file_identity(map_kind, entry, folder, near)] * len(spec.runs))

    axes = [
        ("runs", runs),
        (
            "robots",
            [
                (_file_identity("robot", r, folder) or bundled, r if r else "the bundled robot")
                for r in spec.robots
            ],
        ),
        ("maps", [(truth(m), m if m else "the map") for m in spec.maps]),
        (
            "sim_faults",
            [(_fault_point(p), ", ".join(p) if p else "no faults") for p in spec.sim_faults],
        ),
    ]
    for key in ("drop", "corrupt", "dup"):
        rates: list[float] = getattr(spec.link, key)
        # -0.0 is 0 (it was another point, as repr tells them apart)
        axes.append((f"link.{key}", [(repr(float(r) + 0.0), f"{r:g}") for r in rates]))
    return axes


def check_axes(spec: CampaignSpec, base: Path | None = None, loads: Loads | None = None) -> None:
    """Refuse an axis that names one point twice, at the second entry.

    Two equal entries (after normalising: ``0`` and ``0.0``, a file by two names,
    faults written apart or in another order, a run under another name) run the
    same deterministic cases, which the report would count as independent samples.

    ``loads``: what this check of the spec loaded so far (each run's tree with its
    parameters, loaded here for its defaults, is loaded once; :mod:`~pirate_bt.campaign.
    loads`).

    Raises:
        InputError: the first repeated entry, one line naming the entry it repeats
            (a :class:`~pirate_bt.errors.LocatedError` for a file).
    """
    source = source_of(spec)
    folder = base if base is not None else source.base
    for key, entries in _axis_entries(spec, folder, loads or Loads()):
        first: dict[str, int] = {}
        for i, (identity, _shown) in enumerate(entries):
            j = first.setdefault(identity, i)
            if j == i:
                continue
            path: tuple[str | int, ...] = (*key.split("."), i)
            again = " under another name" if key == "runs" else ""
            raise source.error(
                path,
                f"{key}[{i}] repeats {key}[{j}] ({entries[j][1]}){again}: its cases would run twice"
                " and be counted as independent samples; remove one",
            )
