"""A route whose tether the clamps cannot pull is refused at planning, saying why.

A bend or T-joint PAB moves the robot on one clamped half (the other is steered into
the turn); past the tether length where the load (the map's tether drag per metre,
and the robot's weight on a climb) beats that half's traction, its wheels turned in
place and the mission blamed the map: a bend after 150 m of level 63 mm pipe at
0.15 N/m read *map disagreement ...: the pipe is not as drawn at bend 'b' (right): the
PAB's search met no turn ...*, and the foot of a riser 7 m in at 1 N/m *the pipe
turned by 71 deg at 'b' ...: the turn there is less sharp than drawn*, the robot stuck
in the bend, its wheels slipping.
"""

from __future__ import annotations

from typing import Any

import pytest

import pirate_bt
from pirate_bt.errors import LocatedError
from pirate_bt.pipes import Network, network_from_data
from pirate_bt.task.route import parse_route


def _network(before: str, direction: str, drag: str) -> Network:
    segments: list[dict[str, Any]] = [
        {"id": "a", "type": "straight", "length": before},
        {"id": "b", "type": "bend", "direction": direction},
        {"id": "c", "type": "straight", "length": "2 m"},
    ]
    data = {"name": "n", "diameter": "63 mm", "tether_drag_per_metre": drag, "segments": segments}
    return network_from_data(data)


@pytest.mark.parametrize(
    ("before", "direction", "drag", "said"),
    [
        ("150 m", "right", "0.15 N", "22.4 N of tether drag (149.2 m at 0.15 N/m)"),
        ("6.4 m", "up", "1 N", "6.3 N of tether drag (6.3 m at 1 N/m) and 15.0 N of its weight"),
    ],
)
def test_a_bend_beyond_one_half_s_traction_is_refused_at_planning(
    before: str, direction: str, drag: str, said: str
) -> None:
    route = parse_route(f"at the bend turn {direction}\n", "t.route")
    with pytest.raises(LocatedError) as refused:
        pirate_bt.plan_route(route, network=_network(before, direction, drag))
    message = str(refused.value)
    # was: planned; run, the wheels turned in place and the map was blamed
    assert message.startswith(f"t.route:1:1: 'at the bend turn {direction}' cannot be planned")
    assert said in message and "the bend PAB drives on one half" in message
    assert "21.0 N of traction at its 0.7 N*m clamp; the wheels would turn in place" in message


def test_a_riser_within_the_traction_is_planned_and_climbed() -> None:
    route = parse_route("at the bend turn up\nforward 1 m\n", "t.route")
    result = pirate_bt.simulate_mission(route, network=_network("5 m", "up", "1 N"))
    assert result.succeeded, result.why  # 19.5 N of the 21.0 N
