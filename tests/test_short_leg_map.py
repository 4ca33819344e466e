"""A straight leg the pipe cuts short is no leg done: a map disagreement, not a success.

The map draws a riser (a level run, a drop) longer than it is. A leg of the
route's own distance (``inspect 2 m``, ``forward 2.9 m``) is stopped *blocked* by
the turn at its end before it has driven that distance. The turn is within the
localiser's reach of one the map has, which used to be enough: the mission
claimed success, the belief ~0.8 m behind the truth. Now the leg's shortfall is
a disagreement unless the turn that blocked it is the one the route takes next
(its PAB senses and crosses it).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt

RISER = """schema_version: 1
name: {name}
diameter: 63 mm
tether_drag_per_metre: 0.2 N
segments:
  - {{id: level, type: straight, length: 1 m}}
  - {{id: foot, type: bend, direction: up}}
  - {{id: riser, type: straight, length: {riser}}}
  - {{id: top, type: bend, direction: down}}
  - {{id: upper, type: straight, length: 1.5 m}}
"""

LEVEL = """schema_version: 1
name: {name}
diameter: 63 mm
segments:
  - {{id: run, type: straight, length: {run}}}
  - {{id: b, type: bend, direction: up}}
  - {{id: riser, type: straight, length: 2 m}}
"""


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _mission(tmp_path: Path, map_text: str, truth_text: str, route: str) -> pirate_bt.MissionResult:
    network = _write(tmp_path, "m", map_text.format(name="m", riser="3 m", run="3.7 m"))
    truth = _write(tmp_path, "t", truth_text.format(name="t", riser="2.2 m", run="3 m"))
    route_path = tmp_path / "leg.route"
    route_path.write_text(f"network {network.stem}\n{route}\n", encoding="utf-8")
    plan = pirate_bt.plan_route(route_path, network=network)
    return pirate_bt.simulate_mission(plan, truth=truth)


@pytest.mark.parametrize(
    ("network", "route", "asked", "leg", "turn"),
    [
        # up a riser, and on level pipe (both legs shortened by their margin first)
        (RISER, "at the bend turn up\ninspect 2 m", "1.86 m", "03 inspect 2 m (line 3)", "top"),
        (LEVEL, "forward 2.9 m", "2.70 m", "01 straight 2.9 m (line 2)", "b"),
    ],
    ids=["riser", "level"],
)
def test_a_leg_cut_short_by_an_early_turn_is_a_map_disagreement(
    tmp_path: Path, network: str, route: str, asked: str, leg: str, turn: str
) -> None:
    result = _mission(tmp_path, network, network, route)
    assert not result.succeeded
    assert result.exit_code == 1
    assert result.mismatch is not None
    assert result.why == result.mismatch
    assert result.why.startswith("belief and map disagree: the pipe blocked the robot at ")
    assert f" of the {asked}" in result.why
    assert f"that {leg!r} was to drive, where the map has no turn there" in result.why
    assert f"the route takes next (the nearest is the turn {turn!r} at" in result.why
    assert result.disagreement is not None
    assert result.disagreement.feature == turn
    assert result.sim["violations"] == 0


def test_the_same_legs_on_the_map_itself_still_succeed(tmp_path: Path) -> None:
    riser = _mission(
        tmp_path, RISER, RISER.replace("{riser}", "3 m"), "at the bend turn up\ninspect 2 m"
    )
    assert riser.succeeded, riser.why
    level = _mission(tmp_path, LEVEL, LEVEL.replace("{run}", "3.7 m"), "forward 2.9 m")
    assert level.succeeded, level.why


def test_a_leg_blocked_by_the_turn_the_route_takes_next_still_hands_on(tmp_path: Path) -> None:
    """``forward 2.9 m`` then ``at the bend turn up``: the early bend is the one the
    route turns at next, and the bend PAB senses and crosses it."""
    result = _mission(tmp_path, LEVEL, LEVEL, "forward 2.9 m\nat the bend turn up")
    assert result.succeeded, result.why
    assert [f.feature for f in result.fixes] == ["b"]
