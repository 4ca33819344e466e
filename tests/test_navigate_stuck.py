"""A navigator that asks again for a step that moved the robot nowhere is stopped.

The goal navigator, sent into a branch shorter than the map says (0.5 m where the map
has 2 m, too short for the robot to be wholly in it), asked for the same short
straight step after step: each ended blocked at the cap, a success that moved
nothing, 500 times to the step limit. It is now stopped after three such repeats,
with the step and where the robot is, and the robot is left in its safe state.
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt
from pirate_bt.task.navigate import MAX_IDLE_REPEATS


def test_a_goal_it_cannot_reach_stops_the_navigator_not_its_step_limit() -> None:
    truth = Path(__file__).parent / "data" / "networks" / "t-joint-short-branch.yaml"
    result = pirate_bt.navigate("goal", map="t-joint", sim=truth, params={"segment": "branch"})
    assert not result.succeeded
    assert result.why.startswith("navigator 'goal' is stuck: it asked for Step('straight'")
    assert f"again {MAX_IDLE_REPEATS} times in a row, and the robot did not move" in result.why
    assert result.steps <= 2 + MAX_IDLE_REPEATS  # was 500: the step limit
    assert result.safe_state
    assert result.exit_code == 1


def test_a_navigator_stuck_after_a_map_disagreement_keeps_that_first_cause() -> None:
    # the map bends right, the pipe left: the bend step fails as a map disagreement,
    # the goal navigator goes on from the belief and asks for a straight that goes
    # nowhere; the stop said only "stuck", the disagreement behind it was lost
    result = pirate_bt.navigate(
        "goal", sim="bend-left", map="bend-right", params={"segment": "after"}
    )
    assert not result.succeeded and result.safe_state
    assert result.why.startswith("navigator 'goal' is stuck: it asked for Step('straight'")
    assert "; it went on after a map disagreement: map disagreement at 2.00 m" in result.why
    assert "bend 'bend'" in result.why
