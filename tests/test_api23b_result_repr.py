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
