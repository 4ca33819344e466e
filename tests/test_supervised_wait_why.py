"""A supervised run that ran into its time limit while a step waited for an operator's
confirmation says so (its why named only the time limit and the node still running)."""

from __future__ import annotations

import pirate_bt
from pirate_bt.safety.operator import ScriptedOperator


def test_a_supervised_run_names_the_step_nobody_confirmed() -> None:
    # an operator attached who never answers (with none, the run ends at once: the
    # twentieth session's fix, tests/test_fix20_runner.py)
    robot = pirate_bt.connect("straight", mode="supervised")
    robot.supervisor.add_input(ScriptedOperator())
    result = robot.run("straight", params={"distance": "0.3 m"}, max_time="2 s")
    assert result.status == "failure"
    assert result.why.startswith("time limit of 2 s reached after 40 ticks; ")
    assert result.why.endswith(
        "; it waited for an operator to confirm 'hold the pipe with both halves' (supervised mode)"
    )


def test_an_autonomous_run_s_time_limit_says_nothing_of_confirmations() -> None:
    robot = pirate_bt.connect("straight")
    result = robot.run("straight", params={"distance": "1 m"}, max_time="0.5 s")
    assert result.status == "failure" and "confirm" not in result.why
