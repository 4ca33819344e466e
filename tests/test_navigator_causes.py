"""Navigators, as a probe found them (docs/navigators.md), held to what a user sees.

- The first cause comes first: a navigation that went on after a failed step (a map
  disagreement) and then ended on the navigator's own error (an invalid step, an
  exception, a late answer) said the navigator's error first and the step's cause
  after it, with no failing node.
"""

from __future__ import annotations

from typing import Any

import pirate_bt
from pirate_bt import Observation, Step


class Asks:
    """Answers each decision from a list (then ``None``)."""

    def __init__(self, *answers: Any) -> None:
        self.answers = list(answers)

    def next_step(self, obs: Observation) -> Any:
        return self.answers.pop(0) if self.answers else None


# -- 1. the first cause first --------------------------------------------------------


def test_goal_refused_after_a_disagreement_names_the_disagreement_first() -> None:
    # the map has a tee where the pipe bends: the tee step is blocked there (a map
    # disagreement), and the goal navigator then asks to drive on through the tee, which
    # the planner refuses; the why began "navigator 'goal' asked for an invalid step"
    result = pirate_bt.navigate(
        "goal", sim="bend-right", map="t-joint", params={"segment": "after"}
    )
    assert not result.succeeded and result.exit_code == 1 and result.safe_state
    assert result.why.startswith("map disagreement at 2.00 m (believed): "), result.why
    first, _, later = result.why.partition(" (step 1, Step('t-joint', direction='straight'))")
    assert "T-joint 'tee'" in first and "asked for an invalid step" not in first
    assert later.startswith("; navigator 'goal' went on from it, and then: "), later
    assert "navigator 'goal' asked for an invalid step Step('straight'" in later
    assert "does not fit the network" in later
    assert result.failing_node is not None and "T-joint" in result.failing_node


def test_an_invalid_step_after_a_disagreement_keeps_the_disagreement_first() -> None:
    result = pirate_bt.navigate(
        Asks(Step("bend", direction="right"), Step("fly")), sim="bend-left", map="bend-right"
    )
    assert not result.succeeded and result.exit_code == 1 and result.safe_state
    assert result.why.startswith("map disagreement at 2.00 m (believed): "), result.why
    assert "bend 'bend'" in result.why.split(" (step 1, ")[0]
    assert result.why.endswith(
        "(step 1, Step('bend', direction='right')); navigator 'Asks' went on from it, and"
        " then: navigator 'Asks' asked for an invalid step: Step('fly'): unknown PAB 'fly'"
        " (known: straight, bend, t-joint, wait, probe-turn, probe-tee, bend-back,"
        " t-joint-back)"
    ), result.why
    summary = result.summary()
    assert summary.startswith("navigator Asks: FAILURE - map disagreement at 2.00 m"), summary


def test_a_navigator_that_raises_after_a_disagreement_keeps_the_disagreement_first() -> None:
    class Raises:
        def next_step(self, obs: Observation) -> Step | None:
            if obs.step == 0:
                return Step("bend", direction="right")
            raise RuntimeError("no idea")

    result = pirate_bt.navigate(Raises(), sim="bend-left", map="bend-right")
    assert not result.succeeded and isinstance(result.error, RuntimeError)
    assert result.why.startswith("map disagreement at 2.00 m (believed): "), result.why
    assert result.why.endswith(
        "navigator 'Raises' went on from it, and then: navigator 'Raises' raised"
        " RuntimeError: no idea"
    ), result.why


def test_an_invalid_first_step_is_still_named_alone() -> None:
    result = pirate_bt.navigate(Asks(Step("fly")), sim="straight")
    assert result.why.startswith("navigator 'Asks' asked for an invalid step: Step('fly')")
