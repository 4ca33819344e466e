"""Session 22: a step with a parameter of a name 100,000 characters long (a planner's
``Step("straight", **params)`` from a mapping it read) is refused as any unknown
parameter is, in a bounded line: its ``repr`` and the navigation's ``why`` held the
name whole, twice (200,152 characters), where every value is cut (docs/navigators.md)."""

from __future__ import annotations

from typing import Any

import pirate_bt
from pirate_bt import Step

LONG = "d" * 100_000


class _Asks:
    def __init__(self, step: Step) -> None:
        self.step = step

    def next_step(self, obs: Any) -> Step | None:
        return self.step if obs.step == 0 else None


def test_a_step_s_parameter_of_a_huge_name_is_refused_in_a_bounded_line() -> None:
    step = Step("straight", **{LONG: 1})
    assert len(repr(step)) < 200
    result = pirate_bt.navigate(_Asks(step), sim="straight", max_steps=2)
    assert result.status == "failure" and result.safe_state
    assert result.why.startswith(
        f"navigator '_Asks' asked for an invalid step: Step('straight', '{LONG[:30]}"
    )
    assert f"straight has no parameter '{LONG[:30]}" in result.why
    assert "(it takes distance, slow, stop_at_feature, stop_at_change)" in result.why
    assert len(result.why) < 600


def test_a_parameter_of_a_name_that_is_no_identifier_is_shown_quoted() -> None:
    assert repr(Step("wait", **{"a b": 1})) == "Step('wait', 'a b'=1)"
    assert repr(Step("wait", time="1 s")) == "Step('wait', time='1 s')"
