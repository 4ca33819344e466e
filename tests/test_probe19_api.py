"""Planner code written from docs/api.md, at the seams the eighteenth probes left:
connections never closed, runs from threads, results kept and sent on."""

from __future__ import annotations

import gc
import weakref

import pirate_bt


def test_a_connection_never_closed_lets_its_simulator_go() -> None:
    # a planner's loop of connect() without close() (or with) kept every simulator
    # registered for the life of the process: memory grew by ~200 kB a run
    simulators = []
    for _ in range(3):
        robot = pirate_bt.connect("sim:straight")
        simulators.append(weakref.ref(robot.simulator))
        del robot
    gc.collect()
    gc.collect()
    assert [ref() for ref in simulators] == [None, None, None]


def test_a_runner_outliving_its_unreferenced_connection_still_runs() -> None:
    runner = pirate_bt.connect("sim:straight").runner("straight", params={"distance": "0.1 m"})
    gc.collect()
    gc.collect()
    assert runner.run().succeeded
