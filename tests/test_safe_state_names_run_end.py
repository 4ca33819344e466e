"""A run that ends on its own (a time limit, an exception) leaves the robot in its safe
state with that end as the reason, so the next run on the same connection names it."""

from __future__ import annotations

import pirate_bt


def test_the_next_run_names_the_time_limit_the_last_one_ended_on() -> None:
    robot = pirate_bt.connect("straight")
    first = robot.run("straight", params={"distance": "1 m"}, max_time="0.5 s")
    assert first.status == "failure"
    assert first.why.startswith("time limit of 0.5 s reached after 10 ticks; ")
    assert "was still running" in first.why  # the run's own why is unchanged
    second = robot.run("straight", params={"distance": "1 m"}, max_time="0.5 s")
    assert second.status == "failure"
    assert second.why == (
        "the robot is in its safe state: tree run ended without success:"
        " time limit of 0.5 s reached after 10 ticks"
    )
    assert robot.supervisor.safe_state_reason is not None
    assert "time limit of 0.5 s" in robot.supervisor.safe_state_reason
