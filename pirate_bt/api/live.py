"""Live outputs of a run, as options of the API: the Foxglove WebSocket view.

``foxglove="127.0.0.1:8765"`` (or ``True`` for that default, or an open
:class:`~pirate_bt.interop.foxglove_live.FoxgloveServer`) on :func:`pirate_bt.simulate_tree`,
:func:`pirate_bt.run_tree`, :func:`pirate_bt.simulate_mission` and
:func:`pirate_bt.run_mission` serves the run live. A server the API opened is
closed when the run ends; one the caller passed stays open.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["FoxgloveOption", "foxglove_server", "mission_observer", "tree_observer"]

FoxgloveOption = str | bool | Any | None
"""``None``/``False``: off; ``True``: the default address; ``"HOST:PORT"``; or a server."""


@contextlib.contextmanager
def foxglove_server(option: FoxgloveOption) -> Iterator[Any]:
    """The server for a ``foxglove=`` option (``None`` when off), closed at the end if
    opened here.

    Raises:
        InputError: a bad address, or the port is taken.
        ConfigurationError: the ``foxglove`` extra is missing.
    """
    if option is None or option is False:
        yield None
        return
    if not isinstance(option, str | bool):
        yield option
        return
    from pirate_bt.interop.foxglove_live import FoxgloveServer, parse_address

    host, port = parse_address(option if isinstance(option, str) else None)
    server = FoxgloveServer(host, port)
    try:
        yield server
    finally:
        server.close()


def _extras(connection: Any, more: Callable[[], dict[str, float]] | None = None) -> Any:
    from pirate_bt.trace import supervised_extras

    if connection is None:
        return None
    sim = connection.simulator
    return supervised_extras(
        connection.supervisor, counters=sim.counters if sim is not None else None, more=more
    )


def tree_observer(server: Any, robot: Any) -> Callable[[Any, Any], None]:
    """``observe(runner, connection)`` serving a tree run on ``server``."""
    from pirate_bt.interop.foxglove_live import attach_foxglove

    def observe(runner: Any, connection: Any) -> None:
        attach_foxglove(
            runner,
            server,
            extras=_extras(connection),
            robot=robot,
            scenario=connection.target if connection is not None else None,
            seed=connection.seed if connection is not None else None,
        )

    return observe


def mission_observer(
    server: Any, connection: Any, robot: Any
) -> Callable[[Any, Callable[[], dict[str, float]]], None]:
    """``observe(runner, localiser_values)`` serving every runner a mission makes (the
    mission, a re-plan, the way back), the localiser's belief beside the state."""
    from pirate_bt.interop.foxglove_live import attach_foxglove

    def observe(runner: Any, localiser_values: Callable[[], dict[str, float]]) -> None:
        attach_foxglove(
            runner,
            server,
            extras=_extras(connection, localiser_values),
            robot=robot,
            scenario=connection.target,
            seed=connection.seed,
        )

    return observe


def chain(*observers: Callable[..., None] | None) -> Callable[..., None] | None:
    """One observer calling each given one in turn (``None`` when none is given)."""
    present = [o for o in observers if o is not None]
    if not present:
        return None
    if len(present) == 1:
        return present[0]

    def observe(*args: Any) -> None:
        for o in present:
            o(*args)

    return observe
