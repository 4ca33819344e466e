"""Probe 20: planner code written from the docs (README, api, navigators, routes,
missions), run against the navigation API."""

from __future__ import annotations

import pickle

import pirate_bt
from pirate_bt import Observation, Step


class _HalvesTheLast:
    """Retries the last step at half its distance, by editing the step it gave."""

    def next_step(self, obs: Observation) -> Step | None:
        if obs.step == 0:
            return Step("straight", distance=0.4)
        if obs.step >= 3:
            return None
        step = obs.history[-1][0]
        step.params["distance"] = step.params["distance"] / 2  # type: ignore[index]
        return step


def test_a_navigator_that_edits_a_step_it_gave_does_not_rewrite_the_record() -> None:
    # the decisions and obs.history held the navigator's own Step objects: every one
    # read 0.1 m, the last edit, while the robot drove 0.4, 0.2 and 0.1 m
    result = pirate_bt.navigate(_HalvesTheLast(), sim="straight")
    assert result.status == "success", result.why
    asked = [d.step.params["distance"] for d in result.decisions if d.step is not None]
    assert asked == [0.4, 0.2, 0.1]
    told = [s.params["distance"] for s, _ in result.decisions[-1].observation.history]
    assert told == [0.4, 0.2, 0.1]
    assert round(result.belief_m, 1) == 0.7  # what was driven, as recorded
    back = pickle.loads(pickle.dumps(result))
    assert [d.step for d in back.decisions] == [d.step for d in result.decisions]
