"""A pipe wider than the map says, met on a mission (the truth differs from the map).

The bend joints find no wall where the map has pipe: the localiser cannot tell a
branch's opening from a wider pipe, so its disagreement must name both, with the
mapped diameter, and the mission must stop on it (not drive on, believing a tee).
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt

NETWORK = """schema_version: 1
name: straight
diameter: 63 mm
tether_drag_per_metre: 0.2 N
segments:
  - {{id: run, type: straight, length: 1.5 m}}
  - {{id: wide, type: straight, length: 1 m, diameter: {wide}}}
  - {{id: rest, type: straight, length: 2.5 m}}
"""


def test_a_pipe_wider_than_the_clamps_reach_is_named_as_what_it_may_be(tmp_path: Path) -> None:
    truth = tmp_path / "wide.yaml"
    truth.write_text(NETWORK.format(wide="130 mm"), encoding="utf-8")
    plan = pirate_bt.plan_route(Path(__file__).parents[1] / "scenarios" / "straight.route")
    result = pirate_bt.simulate_mission(plan, truth=truth)
    assert not result.succeeded
    assert result.mismatch is not None
    assert "an opening was felt at 1.5" in result.mismatch
    assert "or the pipe is wider than the map's 63 mm there" in result.mismatch
    assert result.why == result.mismatch  # the first cause reaches the caller


def test_a_wider_pipe_the_clamps_still_reach_is_no_disagreement(tmp_path: Path) -> None:
    truth = tmp_path / "wide.yaml"
    truth.write_text(NETWORK.format(wide="80 mm"), encoding="utf-8")
    plan = pirate_bt.plan_route(Path(__file__).parents[1] / "scenarios" / "straight.route")
    result = pirate_bt.simulate_mission(plan, truth=truth)
    assert result.succeeded, result.why
    assert result.mismatch is None
