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


def test_the_next_run_of_a_tree_file_says_it_was_held_and_keeps_the_first_cause() -> None:
    # the bundled PAB's recovery enters the safe state naming its cause; a second run
    # read "straight PAB failed: clamp rear half: timeout ..." as if it had just failed
    with pirate_bt.connect("sim:straight", faults="motor_stall:bend_3_joint@0s") as robot:
        first = robot.run("straight", params={"distance": "1 m"})
        assert first.why.startswith("timeout: not done after 5 s (clamping rear: bend_3 0.0°")
        second = robot.run("straight", params={"distance": "1 m"})
        assert second.status == "failure"
        assert second.why == (
            "the robot is in its safe state: straight PAB failed: clamp rear half: " + first.why
        )
        assert second.why in second.summary()


def test_a_tree_built_in_python_keeps_its_failure_as_the_cause_not_the_tick_count() -> None:
    from pirate_bt.behaviours.primitives import Clamp

    with pirate_bt.connect("sim:straight", faults="motor_stall:bend_3_joint@0s") as robot:
        first = robot.run(Clamp.build("clamp rear", robot.context(), half="rear", torque=0.7))
        assert first.why.startswith("timeout: not done after 5 s")
        assert robot.supervisor.safe_state_reason == (
            f"tree run ended without success: {first.why}"
        )
        second = robot.run(Clamp.build("clamp rear", robot.context(), half="rear", torque=0.7))
        assert (
            second.why
            == f"the robot is in its safe state: tree run ended without success: {first.why}"
        )
        assert "ticks" not in second.why
        # the operator's decision to go on: the next run is a run again
        robot.supervisor.resume()
        third = robot.run(Clamp.build("clamp rear", robot.context(), half="rear", torque=0.7))
        assert not third.why.startswith("the robot is in its safe state"), third.why
