"""No robot left falling: the supervisor's protective hold in a steep pipe.

The checks never let a command leave a steep pipe with no half clamped, but a fault
can: a bend joint that stalls on the half that holds stops pressing, a board that
loses power drops its clamp. Before the protective hold, nothing reacted: the robot
slid down the pipe until the run ended, and went on sliding after it, while the run
blamed the map (the IMU's pitch moved) or even claimed success. Now the supervisor
sees that no half holds by fresh readings, stops the drives, names the cause first,
clamps what may clamp, and the run's end waits for the clamp to land.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.behaviours.opening_edge import OpeningEdge
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.safety import Clamp, Reason, Source

ROOT = Path(__file__).parents[1]
DROP = ROOT / "tests" / "data" / "networks" / "drop.yaml"
CAUSE = "steep_pipe_unclamped: no half holds the robot in a steep pipe"


def test_a_joint_stalling_on_the_holding_half_in_a_drop_is_caught_and_held() -> None:
    # bending down into a 2 m vertical drop; the front joint that holds stalls at 25 s
    with pirate_bt.connect(DROP, faults="motor_stall:bend_1_joint@25s+2s") as robot:
        result = robot.run("bend", params={"roll": "180 deg"}, max_time="120 s")
        sim = robot.simulator
        assert sim is not None
        assert not result.succeeded and result.safe_state
        assert result.why.startswith(f"{CAUSE} (pitch -90°): the supervisor clamps")
        clamps = [
            v
            for v in robot.supervisor.verdicts
            if isinstance(v.command, Clamp) and v.source is Source.SUPERVISOR
        ]
        assert clamps and all(v.reason is Reason.STEEP_PIPE_UNCLAMPED for v in clamps)
        # the run handed back a robot that holds: it no longer slides, then or later
        truth = sim.truth()
        assert not truth.sliding and any(h.clamped for h in truth.halves.values())
        front = truth.front_m
        robot.clock.advance(5.0)
        assert sim.truth().front_m == front
        # it slid, and the simulator counts that once (it used to slide on, 2 m and more)
        assert dict(sim.counters().violations) == {"sliding": 1}


def test_a_stall_in_the_riser_names_the_slide_not_the_map() -> None:
    # the mission's own riser: the run blamed a map disagreement (the IMU swung as the
    # robot slid) and ended with the robot still sliding at 0.2 m/s
    result = pirate_bt.simulate_mission(
        "scenarios/riser.route", faults="motor_stall:bend_1_joint@21s+3s"
    )
    assert not result.succeeded
    assert result.why.startswith(CAUSE), result.why
    assert result.sim["violations"] == 1


def test_a_board_losing_power_in_a_drop_has_the_other_half_clamped() -> None:
    # the front half's board goes while it alone holds in the shaft: its readings go
    # stale (the first cause), and the rear half, whose board answers, is clamped
    with pirate_bt.connect(DROP, faults="board_reset:22@24s") as robot:
        result = robot.run("bend", params={"roll": "180 deg"}, max_time="120 s")
        sim = robot.simulator
        assert sim is not None
        assert result.why.startswith("stale data: bend_1_angle")
        held = [
            v.command.half
            for v in robot.supervisor.verdicts
            if isinstance(v.command, Clamp) and v.source is Source.SUPERVISOR
        ]
        assert [h.value for h in held] == ["rear"]
        truth = sim.truth()
        assert truth.halves["rear"].clamped and not truth.sliding
        front = truth.front_m
        robot.clock.advance(5.0)
        assert abs(sim.truth().front_m - front) < 0.01  # the drives' ramp down, no slide


def test_nothing_is_clamped_for_the_tree_on_a_level_pipe() -> None:
    # the hold acts only in a steep pipe: a failed run on the level stays as it was
    with pirate_bt.connect("sim:straight", faults="motor_stall:bend_1_joint@2s") as robot:
        robot.run("straight", params={"distance": "0.5 m"})
        assert not any(
            isinstance(v.command, Clamp) and v.source is Source.SUPERVISOR
            for v in robot.supervisor.verdicts
        )


def test_a_success_the_simulator_judged_unsafe_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a slow link and the straight-through PAB as it was before 2026-11-29 (the front
    # half's 160 mm across counted from where the search stopped, not from the
    # opening's edge): crossing a tee in a riser, the rear half reached the opening and
    # let go before the front clamped; four short slides, each ended by the clamp the
    # PAB was making; "SUCCESS - mission completed" said nothing of them
    monkeypatch.setattr(OpeningEdge, "past", lambda *_args: 0.0)
    # the protective hold reading the newest STATE of each tick only, as before
    # 2026-12-01: it now reads every STATE since the last tick and stops this run at
    # the first slide (tests/test_link22_every_state.py), where this test needs a success
    monkeypatch.delattr(RobotLink, "states_between")
    network = ROOT / "tests" / "data" / "networks" / "vtee.yaml"
    (tmp_path / "vtee.yaml").write_text(network.read_text(encoding="utf-8"), encoding="utf-8")
    route = tmp_path / "vtee.route"
    route.write_text(
        "network vtee.yaml\nat the bend turn up\nat the T-joint go straight\nforward to the end\n",
        encoding="utf-8",
    )
    result = pirate_bt.simulate_mission(route, faults="delay=30ms")
    assert result.succeeded  # the tree's success: the PABs did what they sensed
    assert result.why.endswith(
        "; but the simulator counted 4 sliding violations: the robot did not stay safe"
    ), result.why
    clean = pirate_bt.simulate_mission(route)
    assert clean.succeeded and "simulator counted" not in clean.why
