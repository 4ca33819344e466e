"""One tree at a time on a connection, whatever starts the run.

``Connection.run`` refused a second run while one ran, but a run of ``simulate_tree``
(its ``observe`` or hooks reaching its connection) and a runner of
``connection.runner()`` did not hold the connection: two trees ticked one robot, each
failed on the other's *motor_conflict* and the robot was left in its safe state.
"""

from __future__ import annotations

import threading
from typing import Any

import pytest

import pirate_bt

BUSY = (
    "connection: simulator: straight is running a tree already; run one tree at a time"
    " on a connection"
)
LONG = {"distance": "0.5 m"}
SHORT = {"distance": "0.1 m"}


def _pause_at(runner: Any, tick: int, reached: threading.Event, go: threading.Event) -> None:
    """Hold ``runner`` at its ``tick``-th tick until ``go`` (the robot mid-run)."""

    def hook(info: Any) -> None:
        if info.tick == tick:
            reached.set()
            go.wait(30)

    runner.add_post_tick(hook)


def test_a_run_beside_a_runner_of_connection_runner_is_refused() -> None:
    reached, go = threading.Event(), threading.Event()
    ended: list[Any] = []
    with pirate_bt.connect("sim:straight") as robot:
        runner = robot.runner("straight", params=LONG, max_time="60 s")
        _pause_at(runner, 20, reached, go)
        thread = threading.Thread(target=lambda: ended.append(runner.run()))
        thread.start()
        try:
            assert reached.wait(30)
            with pytest.raises(pirate_bt.InputError) as refused:
                robot.run("straight", params=SHORT)
            with pytest.raises(pirate_bt.InputError) as second_runner:
                robot.runner("straight", params=SHORT).run()
        finally:
            go.set()
            thread.join(60)
        assert str(refused.value) == BUSY
        assert str(second_runner.value) == BUSY
        assert ended[0].outcome == "success", ended[0].message
        assert robot.counters().safe_states == 0


def test_a_run_asked_for_by_a_hook_of_simulate_tree_is_refused() -> None:
    inner: list[str] = []

    def observe(runner: Any, connection: Any) -> None:
        def hook(info: Any) -> None:
            if info.tick == 20:
                try:
                    connection.run("straight", params=SHORT)
                    inner.append("ran")
                except pirate_bt.InputError as exc:
                    inner.append(str(exc))

        runner.add_post_tick(hook)

    result = pirate_bt.simulate_tree("straight", params=LONG, observe=observe)
    assert inner == [BUSY]
    assert result.status == "success", result.why
    assert result.counters.safe_states == 0


def test_a_runner_run_from_observe_is_refused_before_anything_moves() -> None:
    with pirate_bt.connect("sim:straight") as robot:

        def observe(runner: Any, connection: Any) -> None:
            connection.runner("straight", params=SHORT).run()

        with pytest.raises(pirate_bt.InputError, match="running a tree already"):
            robot.run("straight", params=LONG, observe=observe)
        assert robot.counters().safe_states == 0
        assert robot.run("straight", params=SHORT).status == "success"


def test_a_runner_of_a_closed_connection_is_refused() -> None:
    robot = pirate_bt.connect("sim:straight")
    runner = robot.runner("straight", params=SHORT)
    robot.close()
    with pytest.raises(pirate_bt.InputError, match="is closed"):
        runner.run()
