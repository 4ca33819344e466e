"""One run at a time in a process, whatever API call starts it (docs/api.md).

py_trees' blackboard is one per process: four ``simulate_mission("lab.route")`` calls
on four threads ended three of them in a *map disagreement* that was no disagreement
of map and pipe (each read the others' working values), while each alone succeeds.
A run asked for on another thread while one runs is now refused at once, before
anything moves, naming the run that holds the process; the first runs as if alone.
"""

from __future__ import annotations

import multiprocessing
import threading
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt import Observation, Step
from pirate_bt.api.process_run import RunInProcessError, held_by

SHORT = {"distance": "0.1 m"}


class _OneStep:
    def next_step(self, obs: Observation) -> Step | None:
        return Step("straight", distance="0.1 m") if obs.step < 1 else None


def _paused_run(reached: threading.Event, go: threading.Event, out: list[Any]) -> threading.Thread:
    """``simulate_tree`` on a thread, held at its 20th tick until ``go``."""

    def observe(runner: Any, _connection: Any) -> None:
        def hook(info: Any) -> None:
            if info.tick == 20:
                reached.set()
                go.wait(30)

        runner.add_post_tick(hook)

    def run() -> None:
        try:
            out.append(pirate_bt.simulate_tree("straight", params=SHORT, observe=observe))
        except BaseException as exc:  # handed to the test
            out.append(exc)

    thread = threading.Thread(target=run, name="planner-a")
    thread.start()
    return thread


def _simulated_tree() -> None:
    pirate_bt.simulate_tree("straight", params=SHORT)


def _mission() -> None:
    pirate_bt.simulate_mission(
        Path(__file__).resolve().parent.parent / "scenarios" / "straight.route"
    )


def _navigation() -> None:
    pirate_bt.navigate(_OneStep(), sim="straight")


def _runner() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        robot.runner("straight", params=SHORT).run()


def _connection_run() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        robot.run("straight", params=SHORT)


@pytest.mark.parametrize(
    "second", [_simulated_tree, _mission, _navigation, _runner, _connection_run]
)
def test_a_second_run_on_another_thread_is_refused_and_the_first_runs_alone(
    second: Callable[[], None],
) -> None:
    reached, go, out = threading.Event(), threading.Event(), []
    thread = _paused_run(reached, go, out)
    try:
        assert reached.wait(30)
        with pytest.raises(RunInProcessError) as refused:
            second()
    finally:
        go.set()
        thread.join(60)
    message = str(refused.value)
    assert "simulate_tree is running on thread 'planner-a' of this process" in message
    assert "py_trees' blackboard is one per process" in message
    assert "\n" not in message
    assert isinstance(refused.value, pirate_bt.InputError)
    (first,) = out
    assert first.status == "success", first.why
    assert first.counters.safe_states == 0
    assert held_by() is None
    _simulated_tree()  # the process is free again


def _in_child() -> str:
    return pirate_bt.simulate_tree("straight", params=SHORT).status


def test_a_forked_child_starts_with_no_run_held() -> None:
    reached, go, out = threading.Event(), threading.Event(), []
    thread = _paused_run(reached, go, out)
    try:
        assert reached.wait(30)
        context = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(1, mp_context=context) as pool:
            assert pool.submit(_in_child).result(timeout=120) == "success"
    finally:
        go.set()
        thread.join(60)
    assert out[0].status == "success", out[0].why
