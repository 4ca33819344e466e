"""Live outputs of a run, as options of the API: the Foxglove WebSocket view, ROS 2.

``foxglove="127.0.0.1:8765"`` (or ``True`` for that default, or an open
:class:`~pirate_bt.interop.foxglove_live.FoxgloveServer`) on :func:`pirate_bt.simulate_tree`,
:func:`pirate_bt.run_tree`, :func:`pirate_bt.simulate_mission` and
:func:`pirate_bt.run_mission` serves the run live. A server the API opened is
closed when the run ends; one the caller passed stays open.

``ros2="tcp/127.0.0.1:7447"`` (or ``True`` for that default, or an open
:class:`~pirate_bt.interop.ros2_live.Ros2Node`) shows the run on a ROS 2 graph
over Zenoh, with ``ros_domain_id=`` and ``ros_namespace=``; the node's e-stop
topic reaches the run's supervisor as an operator e-stop (``docs/ros2.md``).

``groot2="127.0.0.1:1667"`` (or ``True`` for that default, or an open
:class:`~pirate_bt.interop.groot2_server.Groot2Server`) serves the run live to
Groot2 (``docs/interop-groot2.md``); :func:`pirate_bt.attach_groot2` does it for a
runner of your own.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

from pirate_bt.api.options import plain_number

__all__ = [
    "FoxgloveOption",
    "Groot2Option",
    "Ros2Option",
    "check_live_options",
    "foxglove_server",
    "groot2_mission_observer",
    "groot2_server",
    "groot2_tree_observer",
    "mission_observer",
    "ros2_mission_observer",
    "ros2_node",
    "ros2_tree_observer",
    "tree_observer",
]

_API_NAMES = {
    "--foxglove": "foxglove",
    "--groot2": "groot2",
    "--ros2": "ros2",
    "--ros-domain-id": "ros_domain_id",
    "--ros-namespace": "ros_namespace",
}


def _renamed(exc: Exception) -> Exception:
    """An interop error worded for the command line (``--foxglove X: ...``), named as the
    API's argument (``foxglove: X: ...``)."""
    from pirate_bt.errors import InputError

    text = str(exc)
    for cli, option in _API_NAMES.items():
        if text.startswith(f"{cli} "):
            return InputError(f"{option}: {text[len(cli) + 1 :]}")
    return InputError(text)


def check_live_options(
    foxglove: Any = None,
    ros2: Any = None,
    ros_domain_id: Any = None,
    ros_namespace: Any = None,
    groot2: Any = None,
) -> None:
    """Check the live-view options before anything opens or connects: each is off
    (``None``/``False``), ``True``, an address as text (a port for Groot2), or an open
    server or node of its kind; ``ros_domain_id`` is 0 to 232 and ``ros_namespace``
    text (both only with ``ros2``).

    Raises:
        InputError: the first that is none of those, named.
    """
    from pirate_bt.errors import InputError

    # a NumPy truth value or integer as the Python one (numpy.bool_(False) is off; it
    # was "not a bool"), as the options below read them (foxglove_server, ...)
    foxglove, ros2, ros_domain_id, groot2 = map(
        plain_number, (foxglove, ros2, ros_domain_id, groot2)
    )

    def server(value: Any, option: str, module: str, name: str, numbers: bool = False) -> None:
        if value is None or isinstance(value, bool | str):
            return
        if numbers and isinstance(value, int):
            if not 0 <= value <= 65534:
                raise InputError(f"{option}: the port must be a number from 0 to 65534")
            return
        import importlib

        kind = getattr(importlib.import_module(module), name)
        if not isinstance(value, kind):
            raise InputError(
                f"{option}: give True, an address 'HOST:PORT' or an open {name}, not a"
                f" {type(value).__name__}"
            )

    server(foxglove, "foxglove", "pirate_bt.interop.foxglove_live", "FoxgloveServer")
    server(ros2, "ros2", "pirate_bt.interop.ros2_node", "Ros2Node")
    server(groot2, "groot2", "pirate_bt.interop.groot2_server", "Groot2Server", numbers=True)
    if ros_domain_id is not None and (
        isinstance(ros_domain_id, bool)
        or not isinstance(ros_domain_id, int)
        or not 0 <= ros_domain_id <= 232
    ):
        raise InputError(f"ros_domain_id: ROS domain ids go from 0 to 232, not {ros_domain_id!r}")
    if ros_namespace is not None and not isinstance(ros_namespace, str):
        raise InputError(f"ros_namespace: give text such as '/pirate', not {ros_namespace!r}")
    if (ros_domain_id is not None or ros_namespace is not None) and ros2 in (None, False):
        raise InputError("ros_domain_id and ros_namespace are for ros2=; give ros2= too")


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
    option = plain_number(option)  # as check_live_options read it
    if option is None or option is False:
        yield None
        return
    if not isinstance(option, str | bool):
        yield option
        return
    from pirate_bt.errors import InputError
    from pirate_bt.interop.foxglove_live import FoxgloveServer, parse_address

    try:
        host, port = parse_address(option if isinstance(option, str) else None)
        server = FoxgloveServer(host, port)
    except InputError as exc:
        raise _renamed(exc) from None
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


Ros2Option = str | bool | Any | None
"""``None``/``False``: off; ``True``: rmw_zenoh's router on this machine; ``"tcp/HOST:PORT"``;
or an open :class:`~pirate_bt.interop.ros2_live.Ros2Node`."""


@contextlib.contextmanager
def ros2_node(
    option: Ros2Option, *, domain_id: int | None = None, namespace: str | None = None
) -> Iterator[Any]:
    """The ROS 2 node for a ``ros2=`` option (``None`` when off), closed at the end if
    opened here.

    Raises:
        InputError: a bad endpoint, domain id or namespace.
        ConfigurationError: the ``ros2`` extra is missing.
    """
    option, domain_id = plain_number(option), plain_number(domain_id)  # as checked
    if option is None or option is False:
        yield None
        return
    if not isinstance(option, str | bool):
        yield option
        return
    from pirate_bt.errors import InputError
    from pirate_bt.interop.ros2_live import DEFAULT_ENDPOINT, DEFAULT_NAMESPACE, Ros2Node

    try:
        node = Ros2Node(
            option if isinstance(option, str) else DEFAULT_ENDPOINT,
            domain_id=domain_id,
            namespace=DEFAULT_NAMESPACE if namespace is None else namespace,
        )
    except InputError as exc:
        raise _renamed(exc) from None
    try:
        yield node
    finally:
        node.close()


def ros2_tree_observer(node: Any, robot: Any) -> Callable[[Any, Any], None]:
    """``observe(runner, connection)`` showing a tree run on the ROS 2 graph through ``node``;
    the connection's supervisor drains the node's e-stop topic."""
    from pirate_bt.interop.ros2_live import attach_ros2

    def observe(runner: Any, connection: Any) -> None:
        sim = connection.simulator if connection is not None else None
        attach_ros2(
            runner,
            node,
            supervisor=connection.supervisor if connection is not None else None,
            counters=sim.counters if sim is not None else None,
            robot=robot,
        )

    return observe


def ros2_mission_observer(
    node: Any, connection: Any, robot: Any
) -> Callable[[Any, Callable[[], dict[str, float]]], None]:
    """``observe(runner, localiser_values)`` showing every runner of a mission on ROS 2."""
    from pirate_bt.interop.ros2_live import attach_ros2

    def observe(runner: Any, localiser_values: Callable[[], dict[str, float]]) -> None:
        sim = connection.simulator
        attach_ros2(
            runner,
            node,
            supervisor=connection.supervisor,
            counters=sim.counters if sim is not None else None,
            more=localiser_values,
            robot=robot,
        )

    return observe


Groot2Option = str | int | bool | Any | None
"""``None``/``False``: off; ``True``: 127.0.0.1:1667; ``"HOST:PORT"`` or a port; or an open
:class:`~pirate_bt.interop.groot2_server.Groot2Server`."""


@contextlib.contextmanager
def groot2_server(option: Groot2Option) -> Iterator[Any]:
    """The Groot2 server for a ``groot2=`` option (``None`` when off), closed at the end if
    opened here.

    Raises:
        InputError: a bad address, or a port is taken.
        ConfigurationError: the ``groot2`` extra is missing.
    """
    option = plain_number(option)  # as check_live_options read it
    if option is None or option is False:
        yield None
        return
    if not isinstance(option, str | bool | int):
        yield option
        return
    from pirate_bt.errors import InputError
    from pirate_bt.interop.groot2_server import Groot2Server, parse_groot2_address

    text = None if option is True else str(option)
    try:
        host, port = parse_groot2_address(text)
        server = Groot2Server(host, port)
    except InputError as exc:
        raise _renamed(exc) from None
    try:
        yield server
    finally:
        server.close()


def _robot_of(connection: Any) -> str | None:
    """Where a connection runs when that is a robot (``None``: a simulator, or none)."""
    if connection is None or connection.simulator is not None:
        return None
    return str(connection.description)


def groot2_tree_observer(server: Any) -> Callable[[Any, Any], None]:
    """``observe(runner, connection)`` serving a tree run to Groot2 on ``server``."""
    from pirate_bt.interop.groot2_server import attach_groot2

    def observe(runner: Any, connection: Any) -> None:
        attach_groot2(
            runner,
            server,
            supervisor=connection.supervisor if connection is not None else None,
            robot=_robot_of(connection),
        )

    return observe


def groot2_mission_observer(
    server: Any, connection: Any
) -> Callable[[Any, Callable[[], dict[str, float]]], None]:
    """``observe(runner, localiser_values)`` serving every runner of a mission to Groot2
    (the mission, a re-plan, the way back: each a new tree for Groot2)."""
    from pirate_bt.interop.groot2_server import attach_groot2

    def observe(runner: Any, _localiser_values: Callable[[], dict[str, float]]) -> None:
        attach_groot2(runner, server, supervisor=connection.supervisor, robot=_robot_of(connection))

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
