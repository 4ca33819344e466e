"""A primitive at work when the supervisor puts the robot in its safe state fails.

The safe state stops the drives and refuses every tree command until an operator
resumes, so the primitive's work cannot go on; its last state may be frozen (a lost
link), and a drive that kept counting its wheels' last speed as distance used to
"succeed" a run whose link had gone (sim killed under ``pirate-bt run --port``).
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt

STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"
FULL_RUN_TICKS = 300  # the same 1 m run without the fault takes 307 ticks


def test_a_link_lost_while_driving_fails_the_drive_with_the_first_cause() -> None:
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"}, faults="link_loss@5s")
    assert result.status == "failure"
    assert result.safe_state
    assert result.why.startswith("link_silent: nothing heard")  # the first cause, kept
    assert result.ticks < FULL_RUN_TICKS / 2
    assert result.exit_code == 3  # a link error
    # The run ends at the tick after the supervisor's stop, the drive at work stopped.
    assert result.loop.message.startswith("the robot is in its safe state: link_silent")
    assert "straight/pass straight/confirm drive/drive straight" in result.loop.stopped_nodes


def test_without_the_fault_the_same_run_completes() -> None:
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"})
    assert result.succeeded, result.why
    assert result.ticks > FULL_RUN_TICKS


def wait_tree(duration: str) -> dict[str, object]:
    """Clamp the rear half (a tree on the robot), then stand still."""
    return {
        "name": "wait",
        "root": {
            "type": "sequence",
            "name": "hold",
            "children": [
                {"type": "clamp", "name": "clamp rear", "half": "rear", "torque": "0.7 N*m"},
                {"type": "wait", "name": "stand still", "duration": duration},
            ],
        },
    }


WAIT_TREE = wait_tree("30 s")


def test_a_wait_does_not_outlast_a_lost_link() -> None:
    # A tree of waits sends nothing, so no primitive fails: the run used to go on to
    # success with nothing heard from the robot for 25 s.
    result = pirate_bt.simulate_tree(WAIT_TREE, faults="link_loss@5s")
    assert result.status == "failure"
    assert result.why.startswith("link_silent: nothing heard")
    assert result.exit_code == 3
    assert result.sim_time_s < 6.0
    assert pirate_bt.simulate_tree(WAIT_TREE).succeeded  # the same run without the fault


def test_a_mission_pause_does_not_outlast_a_lost_link(tmp_path: Path) -> None:
    route = tmp_path / "pause.route"
    route.write_text("network straight\nforward 0.5 m\npause 30 s\n", encoding="utf-8")
    result = pirate_bt.simulate_mission(route, faults="link_loss@15s")
    assert result.status == "failure"
    assert result.why.startswith("link_silent: nothing heard"), result.why
    assert [p.outcome for p in result.pabs] == ["success", "failure"]
    assert result.pabs[1].end_s is not None and result.pabs[1].end_s < 16.0
    assert result.exit_code == 3


def test_a_wait_on_a_connection_left_in_its_safe_state_fails_at_once() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        robot.supervisor.safe_state("an earlier run failed")
        result = robot.run(WAIT_TREE)
        assert result.status == "failure"
        assert result.ticks == 1
        # the first cause, kept, and said to be the one it was held in all along
        assert result.why == "the robot is in its safe state: an earlier run failed"
        assert result.loop.message.startswith("the robot is in its safe state")
        robot.supervisor.resume()  # the operator's decision: the next run goes on
        assert robot.run(wait_tree("1 s")).succeeded


def test_an_input_that_only_stops_is_no_operator_to_wait_for() -> None:
    # The ROS 2 e-stop topic latches the e-stop but cannot reset it: a run waited out
    # its whole time limit for an operator who was never there (docs probe).
    from pirate_bt.interop.ros2_node import EStopInput

    with pirate_bt.connect("sim:straight") as robot:
        estop = EStopInput("/pirate/estop")
        robot.supervisor.add_input(estop)
        assert not robot.supervisor.operator_attached
        estop.push(True)
        result = robot.run(wait_tree("30 s"), max_time="60 s")
        assert result.status == "failure"
        assert result.sim_time_s < 1.0, result.ticks
        assert "e-stop" in result.why and "ROS 2 e-stop on /pirate/estop" in result.why
