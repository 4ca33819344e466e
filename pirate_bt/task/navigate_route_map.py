"""A route navigator's route on a map it was not written for: planned whole first.

The map stands in for the route's ``network`` line, as ``pirate-bt mission ROUTE
--network MAP`` lets it. A route written for the map (its ``network`` line names that
network) is planned step by step as it runs, each leg from the belief. A route
written for another network, or for none, is first planned whole on the map, as
the mission would plan it, before anything connects: a route that does not fit
the map is bad input (its first line that does not fit, the network it is written
for and the map), where it connected, or started the simulator, and failed at that
step with exit 1.
"""

from __future__ import annotations

from pirate_bt.errors import InputError, shown
from pirate_bt.pipes import Network
from pirate_bt.task.route import Route

__all__ = ["check_route_on_map"]


def _written_for(route: Route) -> Network | None:
    """The network the route's ``network`` line names, or ``None`` (no line, or one
    naming no network that loads: the map is then another network)."""
    from pirate_bt.task.networks import load_network_for

    if route.network is None:
        return None
    try:
        return load_network_for(route, None)
    except InputError:
        return None


def check_route_on_map(route: Route, network: Network) -> None:
    """Refuse a route of another network that does not fit ``network``, the map.

    The plan is made with the bundled robot's length (the map's check knows no
    other): the navigation's own robot plans each step again as it runs.

    Raises:
        ValueError: the route is not written for the map and does not fit it: the
            planner's line (``my.route:5:1: 'at the bend turn right' does not fit the
            network: ...``), then the network the route is written for and the map.
    """
    from pirate_bt.task.planner import plan_route

    own = _written_for(route)
    if own is not None and own.spec == network.spec:
        return  # its own network: each step is planned from the belief as it runs
    try:
        plan_route(route, network, None)
    except InputError as exc:
        written = (
            f"is written for the network {shown(route.network)}"
            if route.network is not None
            else "names no network"
        )
        raise ValueError(
            f"{exc}; the route {written}, and the map is {shown(network.name)}"
        ) from None
