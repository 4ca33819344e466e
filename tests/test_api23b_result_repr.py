"""A mission's result prints as a short summary a user can read, as a tree run's does.

``print(simulate_mission("scenarios/bend-right.route"))`` printed some 70,000
characters (the dataclass repr: every sample, the coverage of every node, the plan);
the whole data stays in ``as_dict()``.
"""

from __future__ import annotations

import pirate_bt


def test_a_mission_result_prints_its_outcome_cause_and_counts_in_a_few_lines() -> None:
    result = pirate_bt.simulate_mission(
        "scenarios/bend-right.route", faults="motor_stall:bend_3_drive@2s+200s"
    )
    assert not result.succeeded
    shown = str(result)
    assert shown == repr(result)
    assert len(shown) < 1000, len(shown)
    assert shown.startswith("MissionResult(route='bend-right', status='failure', why='stall:")
    assert f"failing_node={result.failing_node!r}" in shown
    assert "pabs=4 (1 failure, 3 not run)" in shown
    assert f"ticks={result.ticks}" in shown
    assert len(result.as_dict()["pabs"]) == 4  # the whole data is still there


class _Twice:
    """Drives forward twice, then is done."""

    def __init__(self) -> None:
        self.left = 2

    def next_step(self, obs: object) -> pirate_bt.Step | None:
        self.left -= 1
        return pirate_bt.Step("straight", distance="0.1 m") if self.left >= 0 else None


def test_a_navigation_result_prints_a_summary_that_does_not_grow_with_its_steps() -> None:
    result = pirate_bt.navigate(_Twice(), sim="straight")
    assert result.succeeded, result.why
    shown = str(result)
    assert len(shown) < 600, len(shown)  # every decision with its observation: 3,000 for two
    assert shown.startswith("NavigationResult(navigator='_Twice', status='success', why=")
    assert "steps=2, pabs=2 (2 success)" in shown
    assert len(result.as_dict()["decisions"]) == 3  # the whole data is still there
