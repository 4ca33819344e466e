"""Navigators, as a probe found them (docs/navigators.md), held to what a user sees.

- The first cause comes first: a navigation that went on after a failed step (a map
  disagreement) and then ended on the navigator's own error (an invalid step, an
  exception, a late answer) said the navigator's error first and the step's cause
  after it, with no failing node.
- A bend at a roll other than up, down, left or right (45 deg): ``goal`` asked for
  ``Step('bend', direction=None)``, refused as invalid before anything moved, where a
  mission through the same network passes it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pirate_bt
from pirate_bt import Observation, Step

ROLL45 = Path(__file__).parent / "data" / "networks" / "goal-bend-roll45.yaml"


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


# -- 2. a bend at a roll of 45 degrees ---------------------------------------------------


def test_the_goal_navigator_passes_a_bend_at_a_roll_of_45_degrees() -> None:
    result = pirate_bt.navigate("goal", sim=ROLL45, map=ROLL45, params={"segment": "after"})
    assert result.succeeded, result.why
    assert result.counters.violations == 0
    assert [str(d.step) for d in result.decisions][:1] == ["Step('bend', roll='45.0 deg')"]
    assert result.decisions[-1].observation.belief.segment == "after"
    assert result.truth_m is not None and result.truth_m > 1.0 + 0.14 + 0.5


def test_a_route_navigator_passes_it_with_at_the_bend_turn(tmp_path: Path) -> None:
    route = tmp_path / "r.route"
    route.write_text("at the bend turn\nforward 0.1 m\n")
    result = pirate_bt.navigate("route", sim=ROLL45, map=ROLL45, params={"route": str(route)})
    assert result.succeeded, result.why
    assert str(result.decisions[0].step) == "Step('bend')"


def test_a_bend_step_whose_roll_is_not_the_maps_is_refused_naming_the_bend() -> None:
    result = pirate_bt.navigate(Asks(Step("bend", roll="90 deg")), sim=ROLL45, map=ROLL45)
    assert not result.succeeded and result.steps == 0
    assert result.why.startswith("navigator 'Asks' asked for an invalid step"), result.why
    assert "the next bend, 'bend', turns at roll 45 deg, not at roll 90 deg" in result.why


def test_a_bend_step_with_neither_direction_nor_roll_needs_a_map() -> None:
    result = pirate_bt.navigate(Asks(Step("bend")), sim="straight")
    assert not result.succeeded and result.steps == 0
    assert result.why == (
        "navigator 'Asks' asked for an invalid step: Step('bend'): with no map, give the"
        " bend's direction or roll"
    )
