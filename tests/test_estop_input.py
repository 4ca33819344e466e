"""The bridge's hardware e-stop input, as the host reports it (protocol 1.2, the default).

A planner whose run ends because someone pressed the mushroom button on the bridge
learns that from the result, not only that "the e-stop is latched".
"""

from __future__ import annotations

import pirate_bt
from pirate_bt.errors import LinkError


def test_a_pressed_estop_input_ends_the_run_and_the_result_names_the_button() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        bridge = robot.simulator.bridge

        def press(now: float) -> None:
            if now > 3.0 and not bridge.estop_input:
                bridge.set_estop_input(True)

        robot.clock.add_listener(press)
        result = robot.run("straight", params={"distance": "1 m"}, max_time="60 s")
        truth = robot.simulator.truth()
        assert robot.supervisor.link_problem() is not None
    assert not result.succeeded
    assert "hardware e-stop input" in result.why, result.why
    assert result.exit_code == 1  # someone stopped it on purpose: a failed run, not a fault
    # nobody can release it (no operator input attached): the run ends at once, not
    # at its 60 s time limit as it did
    assert result.sim_time_s < 4.0, result.sim_time_s
    assert truth.halves  # the robot is still there: clamps hold in the stop category
    assert any(h.clamped for h in truth.halves.values())


def test_a_bridge_that_resets_mid_run_is_named_as_the_cause_of_its_latch() -> None:
    # it boots latched and the host does not release a latch from a reset in the middle
    # of a session: the result said only "the bridge reports its e-stop latched"
    with pirate_bt.connect("sim:straight") as robot:
        sim = robot.simulator
        boot = sim.bridge.boot_id

        def reset(now: float) -> None:
            if now > 3.0 and sim.bridge.boot_id == boot:
                sim.bridge.reset()

        robot.clock.add_listener(reset)
        result = robot.run("straight", params={"distance": "1 m"}, max_time="60 s")
    assert not result.succeeded
    assert "it reset in the middle of the session and booted latched" in result.why, result.why
    assert result.sim_time_s < 5.0
    # a bridge that reset (a brown-out, its watchdog) is a hardware error: exit 3, as a
    # lost link is (it exited 1, as a failed tree does)
    assert result.exit_code == 3
    assert isinstance(result.error, LinkError), result.error
