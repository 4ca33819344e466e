"""Probe 16: networks whose truth differs from the map, third round.

A bend built sharper than drawn (90 degrees where the map draws 45): the localiser fixed
on the map's bend at half its drawn angle, then felt the rest of the turn as a new one
and stopped on *the pipe turned by 30 deg ..., where the map has no turn within
0.34 m*, naming no feature, though the map's bend was right behind the robot.
"""

from __future__ import annotations

import json
from typing import Any

import pirate_bt
from pirate_bt.pipes import Network, network_from_data
from pirate_bt.task.route import parse_route


def _bend(angle: str, *, before: str = "1.5 m") -> Network:
    segments: list[dict[str, Any]] = [
        {"id": "a", "type": "straight", "length": before},
        {"id": "b", "type": "bend", "direction": "right", "angle": angle},
        {"id": "c", "type": "straight", "length": "2 m"},
    ]
    return network_from_data({"name": "bend", "diameter": "63 mm", "segments": segments})


BEND_ROUTE = "at the bend turn right\nforward 0.5 m\n"


def test_a_bend_sharper_than_drawn_is_named_as_that_bend() -> None:
    route = parse_route(BEND_ROUTE, "bend.route")
    result = pirate_bt.simulate_mission(route, network=_bend("45 deg"), truth=_bend("90 deg"))
    assert result.status == "failure" and result.safe_state
    assert result.disagreement is not None and result.disagreement.feature == "b"
    # was: "... the pipe turned by 30 deg at 1.90 m (believed), where the map has no
    # turn within 0.34 m", with the map's bend 'b' just behind the robot
    assert "the map has no turn" not in result.why
    assert "through what the map has as 'b', drawn turning right by 45 deg" in result.why
    assert "the pipe turned by 9" in result.why  # the whole turn, not its rest (30 deg)
    assert result.counters.violations == 0 and result.counters.damage == 0
    assert result.why in json.loads(json.dumps(result.as_dict()))["why"]
