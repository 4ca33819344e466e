"""The planner refuses an abrupt widening in a steep pipe where one half holds alone.

A riser probe (2026-11-29) found a bend PAB at a riser's foot sliding, on an exact map
the planner had accepted, when the pipe widened abruptly (a straight of another
diameter, no cone) 0.15 to 0.58 m above the foot: the front half, holding alone while
the rear came through the bend, lost the wall at the step. At 0.58 m it even ended in a
success with three sliding violations. A cone reducer, a narrowing, a 2 mm step or a
level pipe did not slide.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import LocatedError


def _route(tmp: Path, way: str, widened_mm: int, after_m: float) -> Path:
    (tmp / "t.yaml").write_text(
        "schema_version: 1\nname: t\ndiameter: 63 mm\nsegments:\n"
        "  - {id: level, type: straight, length: 1.2 m}\n"
        f"  - {{id: foot, type: bend, direction: {way}, radius: 90 mm}}\n"
        f"  - {{id: riser, type: straight, length: {after_m} m}}\n"
        f"  - {{id: riser2, type: straight, length: 1.0 m, diameter: {widened_mm} mm}}\n"
    )
    route = tmp / "r.route"
    route.write_text(f"network t.yaml\nat the bend turn {way}\nforward to the end\n")
    return route


@pytest.mark.parametrize(
    ("way", "mm", "after_m"), [("up", 66, 0.3), ("up", 71, 0.58), ("down", 71, 0.3)]
)
def test_a_step_wider_above_a_turn_into_a_riser_is_refused_at_the_route_line(
    tmp_path: Path, way: str, mm: int, after_m: float
) -> None:
    route = _route(tmp_path, way, mm, after_m)
    want = (
        f"{route}:2:1: 'at the bend turn {way}' cannot be planned: the pipe widens abruptly"
        f" from 63 to {mm} mm {after_m:.2f} m after 'foot' (at 'riser2'), in a steep pipe"
    )
    with pytest.raises(LocatedError, match=re.escape(want)):
        pirate_bt.plan_route(route)


@pytest.mark.parametrize(("way", "mm"), [("left", 71), ("up", 65), ("up", 55)])
def test_a_level_pipe_a_small_step_or_a_narrowing_is_planned_and_passed_safely(
    tmp_path: Path, way: str, mm: int
) -> None:
    result = pirate_bt.simulate_mission(_route(tmp_path, way, mm, 0.3))
    assert result.succeeded, result.why
    assert result.counters.violations == 0
