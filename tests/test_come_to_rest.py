"""A run hands back a robot at rest: the wheels have stopped when the result comes back.

Before 2026-11-29 a run returned on the tick its drives' stop went out: a straight step
ending at 0.08 m/s handed back a robot that rolled about 7 mm further, and a tree that
succeeded with a speed set left the wheels turning until the connection closed. The
runner now goes on ticking without the tree (the supervisor's ``come_to_rest``) until
every drive reads still, for at most ``settle_limit_s``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.runner import Runner, StopReason

STRAIGHT = {"distance": "1 m"}


def _rolls_after(conn: pirate_bt.Connection, seconds: float = 1.0) -> float:
    """How far the simulated robot goes on by itself after the result came back."""
    before = conn.simulator.truth().front_m
    conn.clock.sleep(seconds)
    return float(conn.simulator.truth().front_m - before)


def test_a_straight_step_returns_with_the_wheels_stopped() -> None:
    with pirate_bt.connect("sim:straight") as conn:
        result = conn.run("trees/straight.yaml", params=STRAIGHT)
        assert result.status == "success"
        assert conn.simulator.truth().velocity_mps == 0.0
        assert abs(_rolls_after(conn)) < 1e-4
    # the wheels ramped down over a few ticks after the tree's last one, counted apart
    assert 1 <= result.loop.settle_ticks <= 10
    assert result.ticks == 307 + result.loop.settle_ticks
    assert "after 307 ticks" in result.why


def test_a_tree_that_succeeds_with_a_speed_set_does_not_leave_the_robot_driving() -> None:
    with pirate_bt.connect("sim:straight") as conn:
        # clamped first, so that wheels that turn would move the robot
        assert conn.run("trees/straight.yaml", params={"distance": "0.1 m"}).status == "success"
        sup = conn.supervisor

        class SetSpeed(py_trees.behaviour.Behaviour):
            def update(self) -> Status:
                assert sup.drive(0.04).ok
                return Status.SUCCESS

        result = conn.run(SetSpeed("set speed"))
        assert result.status == "success"
        assert abs(_rolls_after(conn)) < 1e-3  # was 40 mm: 0.04 m/s for the second


def test_a_failed_run_also_returns_at_rest() -> None:
    # the time limit cuts the drive mid-leg, at speed
    with pirate_bt.connect("sim:straight") as conn:
        result = conn.run("trees/straight.yaml", params=STRAIGHT, max_time="6 s")
        assert result.status == "failure" and result.safe_state
        assert conn.simulator.truth().velocity_mps == 0.0
        assert abs(_rolls_after(conn)) < 1e-4


def test_a_mission_believes_where_the_robot_came_to_rest(tmp_path: Path) -> None:
    route = tmp_path / "ahead.route"
    route.write_text("network straight\nforward 1 m\ninspect 1.5 m\n", encoding="utf-8")
    result = pirate_bt.simulate_mission(route)
    assert result.succeeded
    # odometry counted the ticks the wheels ramped down over (1.8 mm after the last
    # one the tree ticked): belief and truth now agree (0.8 mm apart before)
    assert result.truth_m == pytest.approx(3.026, abs=0.0005)
    assert result.belief_m == pytest.approx(result.truth_m, abs=0.0003)


# -- the runner's side, without a robot --------------------------------------------------


class _Once(py_trees.behaviour.Behaviour):
    def update(self) -> Status:
        return Status.SUCCESS


def test_settling_that_never_ends_is_cut_at_its_limit_and_logged(
    caplog: pytest.LogCaptureFixture,
) -> None:
    clock = SimClock()
    seen: list[int] = []
    runner = Runner(_Once("once"), clock=clock, settle=lambda: False, settle_limit_s=0.5)
    runner.add_post_tick(lambda info: seen.append(info.tick))
    with caplog.at_level(logging.WARNING, logger="pirate_bt.runner"):
        result = runner.run()
    assert result.reason is StopReason.SUCCESS
    assert result.settle_ticks == 10  # 0.5 s at 20 Hz, each seen by the post-tick hooks
    assert seen == list(range(1, 12))
    assert result.sim_time_s == pytest.approx(0.5)
    assert "not at rest 0.5 s after the run ended" in caplog.text


def test_an_error_while_settling_is_logged_and_the_result_stands(
    caplog: pytest.LogCaptureFixture,
) -> None:
    def broken() -> bool:
        raise RuntimeError("no readings")

    runner = Runner(_Once("once"), clock=SimClock(), settle=broken)
    with caplog.at_level(logging.ERROR, logger="pirate_bt.runner"):
        result = runner.run()
    assert result.succeeded and result.settle_ticks == 0
    assert "RuntimeError: no readings" in caplog.text
