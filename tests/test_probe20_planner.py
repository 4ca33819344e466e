"""Probe 20: planner code written from the docs (README, api, navigators, routes,
missions), run against the navigation API."""

from __future__ import annotations

import pickle
from collections.abc import Iterator

import pytest

import pirate_bt
from pirate_bt import Observation, Step
from pirate_bt.task import parse_route


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


_STALL = "motor_stall:bend_3_drive@5s+20s"


def _faults() -> Iterator[str]:
    yield _STALL


def test_faults_given_as_a_generator_are_run_not_dropped() -> None:
    # faults=(f for f in ...) was read by the option check and handed on empty: each
    # run "succeeded" with no fault in it
    tree = pirate_bt.simulate_tree(
        "bend", network="bend-right", params={"roll": "90 deg"}, faults=_faults()
    )
    assert tree.status == "failure" and tree.why.startswith("stall: bend_3_drive"), tree.why
    mission = pirate_bt.simulate_mission(
        "scenarios/bend-right.route", faults=iter(["motor_stall:bend_3_drive@25s+20s"])
    )
    assert mission.status == "failure", mission.why
    assert mission.why.startswith("stall: bend_3_drive"), mission.why
    nav = pirate_bt.navigate(
        "goal", map="bend-right", params={"segment": "after"}, faults=map(str, [_STALL])
    )
    assert nav.status == "failure" and nav.why.startswith("stall: bend_3_drive"), nav.why
    assert nav.safe_state


def test_a_step_is_a_value_a_planner_can_keep_in_a_set() -> None:
    # a frozen dataclass, yet hash(Step(...)) raised TypeError: unhashable type: 'dict'
    seen = {Step("straight", distance="1 m"), Step("bend", direction="left")}
    assert Step("straight", distance="1 m") in seen
    assert Step("straight", distance="2 m") not in seen
    assert hash(Step("wait", time=1)) == hash(Step("wait", time=1.0))


def test_a_number_in_other_digits_is_refused_where_it_is_written() -> None:
    # '２' (a full-width digit, as an IME types it) was read as a number, and the
    # refusal of '２ m' as 'not a quantity' was placed at the unit, column 11
    with pytest.raises(pirate_bt.ValidationFailed) as caught:
        parse_route("network lab\nforward ２ m\n", "wide.route")
    assert str(caught.value) == (
        "wide.route:2:9: forward: '２' is not a number; write e.g. 'forward 2.5 m'"
    )


class _CheckedByAProperty:
    @property
    def check_map(self) -> object:
        raise RuntimeError("no map check here")

    def next_step(self, obs: Observation) -> Step | None:
        return None


class _DecidesByAProperty:
    @property
    def next_step(self) -> object:
        raise KeyError("planner")


def test_a_navigator_whose_method_cannot_be_read_is_refused_in_one_line() -> None:
    # the property's own RuntimeError (KeyError) went out of navigate() bare
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.navigate(_CheckedByAProperty(), sim="straight", map="straight")
    said = str(caught.value)
    assert said.startswith(
        "navigator '_CheckedByAProperty': reading its check_map raised RuntimeError:"
        " no map check here (at "
    ), said
    assert caught.value.exit_code == 2
    with pytest.raises(pirate_bt.InputError, match=r"^navigator '_DecidesByAProperty': "):
        pirate_bt.navigate(_DecidesByAProperty(), sim="straight")
