"""Session 22: the route navigator's refusal of a map names the route's command at
``file:line:column``, as every error does (DESIGN.md) and as the planner's refusals of
the same route do (*lab.route:6:1: 'at the bend turn right' does not fit ...*); it was
``lab.route:19: 'inspect to the end slowly' needs a map``, with no column."""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.errors import InputError


def test_a_route_command_that_needs_a_map_is_placed_at_its_line_and_column() -> None:
    route = pirate_bt.load_route("bend-right")
    line = next(s.line for s in route.steps if s.distance_m is None and s.kind.value != "bend")
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("route", params={"route": "bend-right"})
    assert f"bend-right.route:{line}:1: '" in str(caught.value)
    assert str(caught.value).endswith("needs a map (--map or map=...)")
