"""A turn into a tee's branch that fails before it is felt leaves the robot on the main line.

The map draws the branch leaving left; the pipe has it on the right. The T-joint PAB
steers left, slips over the opening and fails (tests/test_fix20_tjoint.py): the robot
never turned. Until the twenty-first session the navigation's belief went on along the
branch all the same (the way taken at the tee was kept as ``branch``), so the ``goal``
navigator planned its next step in the branch and that step failed *no wall* on the
main line. The way a failed step never felt is forgotten now: the belief, its segment,
``obs.choices`` and what the map's helpers say are the main line's.
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt

_NETWORK = """\
schema_version: 1
name: {name}
diameter: 63 mm
segments:
  - {{id: before, type: straight, length: 1.2 m}}
  - id: tee
    type: tee
    branch:
      direction: {side}
      segments:
        - {{id: branch, type: straight, length: 1.2 m}}
  - {{id: after, type: straight, length: 1.5 m}}
"""


def _networks(tmp_path: Path) -> tuple[Path, Path]:
    drawn = tmp_path / "drawn.yaml"
    drawn.write_text(_NETWORK.format(name="drawn", side="left"), encoding="utf-8")
    built = tmp_path / "built.yaml"
    built.write_text(_NETWORK.format(name="built", side="right"), encoding="utf-8")
    return drawn, built


def test_a_turn_that_failed_unfelt_leaves_the_belief_on_the_main_line(tmp_path: Path) -> None:
    drawn, built = _networks(tmp_path)
    result = pirate_bt.navigate("goal", sim=built, map=drawn, params={"segment": "branch"})
    assert result.status == "failure" and result.safe_state
    first = result.decisions[0]
    assert first.step == pirate_bt.Step("t-joint", direction="left")
    assert first.outcome == "failure"
    # the first cause is the failed turn, and nothing after it was run on a belief in
    # the branch (before: a straight planned in 'branch' failed 'no wall')
    assert result.why.startswith("map disagreement at ")
    assert "T-joint 'tee' (left)" in result.why
    assert "no wall" not in result.why
    assert "no turn into the branch of 'tee' was felt" in result.why
    assert "believed on the main line, in 'after'" in result.why
    assert "navigator 'goal' was done after it (step 1)" in result.why
    assert result.steps == 1
    # what the navigator was told after the failed turn: the main line
    told = result.decisions[1].observation
    assert told.belief.segment == "after"  # before: 'branch'
    assert told.choices.get("tee") != "branch"
    assert told.map is not None
    main_line_m = told.map.main_path().length_m
    to_end = told.to_end_m()
    assert to_end is not None
    assert abs(to_end - (main_line_m - told.belief.position_m)) < 1e-6
    assert result.truth_m is not None and abs(result.truth_m - result.belief_m) < 0.2


class _TurnLeft:
    """Turns left at the tee, and is done."""

    def __init__(self) -> None:
        self.told: list[pirate_bt.Observation] = []

    def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
        self.told.append(obs)
        if obs.step == 0:
            return pirate_bt.Step("t-joint", direction="left")
        return None


def test_a_turn_as_drawn_is_still_the_way_taken(tmp_path: Path) -> None:
    drawn, _ = _networks(tmp_path)
    navigator = _TurnLeft()
    result = pirate_bt.navigate(navigator, sim=drawn, map=drawn)
    assert result.status == "success", result.why
    after = navigator.told[-1]
    assert after.choices == {"tee": "branch"}
    assert after.belief.segment == "branch"
    assert "no turn into" not in result.why
