"""A navigator run's checks: made once with its parameters, its map, its route's
network line, its files.

:func:`check_navigator` makes a case's navigator once and checks its map, as each case
will (:func:`pirate_bt.campaign.checks.check_runs` calls it for every distinct one).

A ``route`` navigator whose route's ``network`` line names another network than the
run's map (its ``network``, default ``straight``) is refused at the run, as a route
run's is (:func:`pirate_bt.campaign.checks.check_runs`): it passed ``validate`` and
failed at its first turn in every case (*'at the T-joint go left' does not fit the
network*). :func:`navigator_files` names the files a navigator's parameters make it
read (a route, ``explore``'s ``extend``), so that ``--resume`` digests them: a changed
``extend`` file was resumed silently.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pirate_bt.campaign.inputs import run_index, source_of
from pirate_bt.campaign.spec import CampaignSpec
from pirate_bt.errors import InputError

__all__ = ["check_navigator", "check_route_navigator", "navigator_files"]


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


def check_navigator(
    case: dict[str, Any],
    robots: Callable[[str | None], Any],
    spec: CampaignSpec | None,
    base: Path | None,
    case_timeout_s: float | None = None,
) -> list[str]:
    """Make the case's navigator once and check its map, as each case will.

    With the ``spec`` the case came from, a problem is placed at the run: a name
    no navigator has at its ``navigator``, a parameter the navigator refuses at
    that parameter (or its ``params``), a map its ``check_map`` refuses, or one
    that puts the case's robot in across a bend or a T-joint, at its ``network``; a
    blind run's navigator that needs a map, at its ``blind``.

    An installed navigator is made and checked in a forked process first
    (:func:`~pirate_bt.campaign.rehearsal.rehearse`): one that ends that process (an
    ``os._exit``, a signal) or is still at it after the case timeout (the spec's, or
    ``case_timeout_s`` if longer: ``--case-timeout``) is
    refused at its ``navigator``, where it ended or hung ``validate`` and the campaign.

    Returns:
        The files its parameters name that it read (the ``route`` navigator's route).
    """
    from pirate_bt.campaign.rehearsal import rehearse

    if case["navigator"] not in BUILT_IN_NAVIGATORS:
        timeout_s = spec.quantity("case_timeout", "time") if spec is not None else 300.0
        timeout_s = max(timeout_s, case_timeout_s or 0.0)  # never shorter than the cases'
        try:
            rehearse(case["navigator"], lambda: _check(case, robots, spec, base), timeout_s)
        except InputError as exc:
            raise _placed(exc, "navigator", case, spec) from None
    return _check(case, robots, spec, base)


BUILT_IN_NAVIGATORS = frozenset({"route", "goal", "explore"})
"""The navigators of pirate_bt itself (``pirate_bt.task.navigators``): not rehearsed."""


def _placed(
    exc: InputError, key: str, case: dict[str, Any], spec: CampaignSpec | None
) -> InputError:
    """``exc`` at the case's run in the spec: its ``key`` (a parameter it names, under
    ``params``), with the run's name."""
    run = str(case.get("run"))
    params: dict[str, Any] = case["params"]
    index = None if spec is None else run_index(spec, case)
    if spec is None or index is None:
        return InputError(f"run {run!r}: {exc}")
    path: tuple[str | int, ...] = ("runs", index, key)
    if key == "params":
        named = next((k for k in params if f"'{k}'" in str(exc)), None)
        path = (*path, named) if named is not None else path
    return source_of(spec).error(path, f"run {run!r}: {exc}")


def _check(
    case: dict[str, Any],
    robots: Callable[[str | None], Any],
    spec: CampaignSpec | None,
    base: Path | None,
) -> list[str]:
    """:func:`check_navigator`'s checks, in this process."""
    from pirate_bt.task.navigators import load_navigator, navigator_method

    params: dict[str, Any] = case["params"]

    def placed(exc: InputError, key: str) -> InputError:
        return _placed(exc, key, case, spec)

    try:  # made once, as each case will: an unknown name or parameter stops here
        navigator = load_navigator(case["navigator"], params)
    except InputError as exc:
        text = str(exc)
        named = text.startswith(("no navigator named", "navigator: give")) or any(
            words in text for words in (" failed to load: ", "has no next_step")
        )
        where = "navigator" if named or not params else "params"
        raise placed(InputError(_in_spec_words(text)), where) from None
    except (Exception, SystemExit) as exc:  # its maker's own (a plug-in's bug): was 'internal
        # error', and a sys.exit(0) ended 'campaign' and 'validate' with exit 0 and no word
        where = "params" if params else "navigator"
        raise placed(_made_raised(case["navigator"], exc), where) from exc
    try:  # read as navigate() reads it: a property that raised was an 'internal error'
        check_map = navigator_method(navigator, "check_map", case["navigator"])
    except InputError as exc:
        raise placed(exc, "navigator") from None
    if callable(check_map):  # as navigate() will
        from pirate_bt.api.missions import load_network
        from pirate_bt.task.navigators import check_navigator_map
        from pirate_bt.task.start_check import check_map_start

        drawn = None if case.get("blind") else (case.get("network") or "straight")
        the_map = None if drawn is None else load_network(drawn, base=base)
        given = case.get("network") is not None and not case.get("blind")
        try:
            check_navigator_map(navigator, case["navigator"], the_map)
            check_route_navigator(navigator, the_map, case.get("network"))
            if the_map is not None:  # as navigate() will, before it connects
                check_map_start(the_map, robots(case.get("robot")), case["navigator"])
        except InputError as exc:
            if the_map is None:  # blind: said at its 'blind', in the spec's words
                raise placed(_blind(exc), "blind") from None
            raise placed(exc, "network" if given else "navigator") from None
    return navigator_files(navigator, case["navigator"], params)  # --resume digests them


def _blind(exc: InputError) -> InputError:
    """A blind run's map refusal in a spec's words: the navigators say how to give a map
    on the command line and in Python (*needs a map (--map or map=...)*), which a spec
    has neither of; its key is ``blind``."""
    text = str(exc).replace(" (--map or map=...)", "")
    return InputError(
        f"{text}; 'blind: true' gives the run no map: leave 'blind' out (its 'network'"
        " is then its map)"
    )


_PARAM_OPTION = re.compile(r"\(params=\{'(\w+)': \.\.\.\};")


def _in_spec_words(text: str) -> str:
    """A navigator's refusal in a spec's words: a parameter it needs is asked for as a
    Python caller gives it (*needs the parameter 'segment' (params={'segment': ...};
    ...)*); in a spec it goes under the run's ``params``."""
    return _PARAM_OPTION.sub(lambda m: f"(params: {{{m.group(1)}: ...}};", text)


def _made_raised(name: str, exc: BaseException) -> InputError:
    """A navigator whose making raised (not a refusal :func:`load_navigator` words: a
    ``RuntimeError`` of its ``__init__``), named with the place it was raised."""
    from pirate_bt.errors import said_of
    from pirate_bt.task.navigation import raised_at

    at = raised_at(exc)
    return InputError(
        f"navigator {name!r} raised {type(exc).__name__} as it was made:"
        f" {said_of(exc, 200)}" + (f" (at {at})" if at else "")
    )
