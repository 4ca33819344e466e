"""A navigator run's checks beyond making it: its route's network line, its files.

A ``route`` navigator whose route's ``network`` line names another network than the
run's map (its ``network``, default ``straight``) is refused at the run, as a route
run's is (:func:`pirate_bt.campaign.checks.check_runs`): it passed ``validate`` and
failed at its first turn in every case (*'at the T-joint go left' does not fit the
network*). :func:`navigator_files` names the files a navigator's parameters make it
read (a route, ``explore``'s ``extend``), so that ``--resume`` digests them: a changed
``extend`` file was resumed silently.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pirate_bt.errors import InputError

__all__ = ["check_route_navigator", "navigator_files"]


def check_route_navigator(navigator: Any, the_map: Any, given: str | None) -> None:
    """Refuse a ``route`` navigator whose route's network line names another network
    than its map (it failed at its first turn in every case).

    ``the_map`` is the run's map (a ``Network``) and ``given`` the run's ``network`` as
    written (``None``: the default).

    Raises:
        InputError: the route names another network, in one line.
    """
    from pirate_bt.task.navigators import RouteNavigator
    from pirate_bt.task.networks import resolve_network_path

    if type(navigator) is not RouteNavigator or the_map is None:
        return
    route = navigator.route
    if route.network is None:
        return
    near = Path(route.source).parent
    try:
        own = resolve_network_path(route.network, near).resolve()
    except (FileNotFoundError, OSError):
        own = None
    source = getattr(the_map, "source", None)
    if own is not None and isinstance(source, str) and Path(source).resolve() == own:
        return
    if own is None and route.network == the_map.name:
        return
    where = f" ({route.network_location})" if route.network_location else ""
    said = repr(given) if given is not None else "'straight' (the default)"
    raise InputError(
        f"the route {route.source!r} names network {route.network!r}{where}, not {said}:"
        " a route navigator's 'network' is the map its route is planned on; give the"
        " route's own, and list simulated truths under 'maps' or 'as_built'"
    )


def navigator_files(navigator: Any, name: str, params: dict[str, Any]) -> list[str]:
    """The files a navigator's parameters made it read: the ``route`` navigator's
    route (the file its route was loaded from), and each other parameter
    :func:`~pirate_bt.task.navigators.navigator_file_params` names (``explore``'s
    ``extend``, a plug-in's ``file_params``), as the case gives it."""
    from pirate_bt.task.navigators import navigator_file_params

    files: list[str] = []
    source = getattr(getattr(navigator, "route", None), "source", None)
    if isinstance(source, str):
        files.append(source)
    for key in sorted(navigator_file_params(name) - {"route"}):
        value = params.get(key)
        if isinstance(value, str | Path):
            files.append(str(value))
    return files
