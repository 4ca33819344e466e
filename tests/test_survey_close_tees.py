"""A second tee close after the one a survey passes straight on: never written as pipe.

Going straight through a tee, the T-joint PAB may carry the front half's joints across
the next tee's opening when it starts within a robot's length after it: no straight
step stops there, so no ``probe-tee`` tells its branch. Until the twentieth session
the survey then wrote the second tee and its branch as straight pipe and exited 0.
Every joint that swings off the wall during a step is now in ``obs.off_wall``, and the
survey ends the line at an opening no step stopped at.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

import pirate_bt
from pirate_bt import OffWall, Step

TWO_TEES = """\
schema_version: 1
name: two-tees
diameter: 63 mm
segments:
- id: before
  type: straight
  length: 1.5 m
- id: t1
  type: tee
  branch:
    direction: left
    segments:
    - id: b1
      type: straight
      length: 1 m
- id: mid
  type: straight
  length: {gap} m
- id: t2
  type: tee
  branch:
    direction: right
    segments:
    - id: b2
      type: straight
      length: 1 m
- id: after
  type: straight
  length: 1.5 m
"""


@pytest.fixture(scope="module")
def close(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Path]:
    """A survey of two 63 mm tees 0.15 m apart (the gap that was written as pipe)."""
    folder = tmp_path_factory.mktemp("close-tees")
    network = folder / "two-tees.yaml"
    network.write_text(TWO_TEES.format(gap=0.15))
    out = folder / "surveyed.yaml"
    return pirate_bt.survey(sim=str(network), output=out), out


def test_a_tee_crossed_with_no_step_stopping_at_it_is_not_a_surveyed_line(
    close: tuple[Any, Path],
) -> None:
    result, _ = close
    assert not result.succeeded and result.exit_code == 1, result.why
    assert "not surveyed past an opening 0.1" in result.why
    assert "after tee-1, which bend_1 crossed with no step stopping at it" in result.why
    assert any("not surveyed past an opening" in u for u in result.unexplored)
    # the robot was never left unsafe on the way
    assert result.navigation.counters.violations == 0 and result.navigation.sim["damage"] == 0


def test_the_file_ends_the_line_at_the_second_opening_and_keeps_the_first_branch(
    close: tuple[Any, Path],
) -> None:
    _, out = close
    data = yaml.safe_load(out.read_text())
    kinds = [(s["type"], s["id"]) for s in data["segments"]]
    assert kinds == [("straight", "run-1"), ("tee", "tee-1"), ("straight", "run-2")]
    # the straight between the tees, as built 0.15 m: written up to the second opening
    gap_m = float(str(data["segments"][2]["length"]).split()[0]) / 1000
    assert gap_m == pytest.approx(0.15, abs=0.02)
    # the first tee's branch was still surveyed (1 m as built)
    branch = data["segments"][1]["branch"]
    assert branch["direction"] == "left"
    assert float(str(branch["segments"][0]["length"]).split()[0]) == pytest.approx(1000, abs=50)
    assert "not surveyed past an opening" in data["description"]
    # and it is a network that plans: nothing after the opening is claimed
    assert pirate_bt.load_network(out).main_path().length_m < 2.0


class _Straight:
    """A navigator that drives 2.5 m straight on, through the tee, and stops."""

    def __init__(self) -> None:
        self.seen: tuple[OffWall, ...] = ()

    def next_step(self, obs: Any) -> Step | None:
        if obs.step == 0:
            return Step("straight", distance=2.5)
        self.seen = obs.off_wall
        return None


def test_a_navigator_is_told_where_each_joint_swung_off_the_wall(tmp_path: Path) -> None:
    nav = _Straight()
    result = pirate_bt.navigate(nav, sim="t-joint", trace=tmp_path)
    assert result.succeeded, result.why
    joints = [o.joint for o in nav.seen]
    # every bend joint crossed the tee's opening, front half first, each back at the wall
    assert joints[:2] == ["bend_1", "bend_2"] and set(joints) == {
        "bend_1",
        "bend_2",
        "bend_3",
        "bend_4",
    }
    assert all(o.back_m is not None and o.back_m > o.at_m for o in nav.seen)
    # each where the tee's opening is: the same place to a few centimetres, all four
    where = [o.where_m for o in nav.seen]
    assert max(where) - min(where) < 0.05
    assert all(o.behind_m > 0 for o in nav.seen)
    # and the navigation's record says what the navigator was told
    records = [json.loads(line) for line in (tmp_path / "navigation.jsonl").open()]
    told = [r["observation"] for r in records if r["type"] == "decision"]
    assert "off_wall" not in told[0]
    assert [o["joint"] for o in told[1]["off_wall"]] == joints


def test_a_step_with_no_opening_tells_none() -> None:
    nav = _Straight()
    result = pirate_bt.navigate(nav, sim="straight")
    assert result.succeeded, result.why
    assert nav.seen == ()
