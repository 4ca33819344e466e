"""A straight longer than a drive's default timeout takes at its speed.

A drive's ``timeout`` defaulted to 120 s whatever its distance, and the straight PAB
gives none: a mission's leg of more than 9.6 m at 80 mm/s (4.8 m inspecting, at
40 mm/s) failed with *timeout: not done after 120 s (drove 4.801 m ...)*, in a pipe the
robot drives through. A drive given no timeout now has twice the time its travel takes
at its speed when that is longer (``pirate_bt.behaviours.drive.TIME_MARGIN``); a
timeout given is kept.
"""

from __future__ import annotations

from typing import Any

import pirate_bt
from pirate_bt.pipes import Network, network_from_data
from pirate_bt.task.route import parse_route


def _straight(length: str) -> Network:
    segments = [{"id": "a", "type": "straight", "length": length}]
    return network_from_data({"name": "long", "diameter": "63 mm", "segments": segments})


def test_a_mission_s_leg_of_11_m_is_driven_to_its_end() -> None:
    route = parse_route("forward 11 m\n", "long.route")
    result = pirate_bt.simulate_mission(route, network=_straight("12 m"))
    # was: failure, 'timeout: not done after 120 s (drove 9.598 m at 80 mm/s ...)'
    assert result.succeeded, result.why
    assert result.counters.violations == 0


def test_the_straight_pab_drives_11_m() -> None:
    result = pirate_bt.simulate_tree(
        "straight", network=_straight("12 m"), params={"distance": "11 m"}
    )
    assert result.succeeded, result.why


def test_a_timeout_given_is_kept() -> None:
    tree: dict[str, Any] = {
        "root": {
            "type": "sequence",
            "children": [
                {"type": "clamp", "half": "rear", "torque": "0.7 N*m"},
                {"type": "drive", "velocity": "80 mm/s", "distance": "3 m", "timeout": "10 s"},
            ],
        }
    }
    result = pirate_bt.simulate_tree(tree, network=_straight("4 m"))
    assert result.status == "failure"
    assert "timeout: not done after 10 s" in result.why


def test_a_search_given_a_long_max_distance_gets_the_time_for_it() -> None:
    tree: dict[str, Any] = {
        "root": {
            "type": "sequence",
            "children": [
                {"type": "clamp", "half": "rear", "torque": "0.7 N*m"},
                {
                    "type": "drive",
                    "velocity": "80 mm/s",
                    "until": "blocked",
                    "max_distance": "12 m",
                },
            ],
        }
    }
    result = pirate_bt.simulate_tree(tree, network=_straight("12 m"))
    # the pipe's end blocks it: was 'timeout: not done after 120 s' at 9.6 m
    assert result.succeeded, result.why
