"""Session 24: a truth put in further on than its map says reads as a shorter straight.

The localiser's belief starts at the map's start; the robot is truly put in 1.08 m
further on (the truth's `start`), so it meets the bend 1.08 m before the map has it.
The mission stops there, in the safe state, on the block, naming the map's bend and how
far on it is drawn, and its result says where belief and truth parted.
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt

NETWORK = """schema_version: 1
name: drawn
diameter: 63 mm
{start}segments:
  - {{id: before, type: straight, length: 2 m}}
  - {{id: bend, type: bend, direction: right, radius: 90 mm}}
  - {{id: after, type: straight, length: 2 m}}
"""
ROUTE = "network drawn\n\nforward 1 m\nat the bend turn right\ninspect to the end\n"


def test_a_put_in_further_on_stops_at_the_bend_naming_it(tmp_path: Path) -> None:
    (tmp_path / "drawn.yaml").write_text(NETWORK.format(start=""), encoding="utf-8")
    built = tmp_path / "built.yaml"
    built.write_text(NETWORK.format(start="start: {position: 1.6 m}\n"), encoding="utf-8")
    (tmp_path / "r.route").write_text(ROUTE, encoding="utf-8")
    result = pirate_bt.simulate_mission(tmp_path / "r.route", truth=built)
    assert not result.succeeded and result.safe_state
    assert result.why.startswith("belief and map disagree: the pipe blocked the robot at 0.91 m")
    assert "the map's next turn, 'bend', is drawn 1.09 m further on (at 2.00 m)" in result.why
    assert result.truth_m is not None
    assert round(result.truth_m - result.belief_m, 2) == 1.09  # where they parted
    assert result.sim["violations"] == 0
