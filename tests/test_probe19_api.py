"""Planner code written from docs/api.md, at the seams the eighteenth probes left:
connections never closed, runs from threads, results kept and sent on."""

from __future__ import annotations

import contextlib
import gc
import os
import weakref
from pathlib import Path

import pytest

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


def _open_here(path: Path) -> list[str]:
    """The file descriptors of this process open on ``path``."""
    fds = Path("/proc/self/fd")
    found = []
    for fd in fds.iterdir():
        with contextlib.suppress(OSError):
            if os.readlink(fd).startswith(str(path)):
                found.append(fd.name)
    return found


@pytest.mark.parametrize("name", ["run.jsonl", "run.mcap"])
def test_an_observer_that_raises_leaves_no_trace_file_open_or_written(
    tmp_path: Path, name: str
) -> None:
    def observe(runner: object, connection: object) -> None:
        raise RuntimeError("my observer broke")

    trace = tmp_path / name
    with pytest.raises(RuntimeError, match="my observer broke"):
        pirate_bt.simulate_tree(
            "straight", params={"distance": "0.1 m"}, observe=observe, trace=trace
        )
    with pirate_bt.connect("sim:straight") as robot, pytest.raises(RuntimeError):
        robot.run("straight", params={"distance": "0.1 m"}, observe=observe, trace=trace)
    # an empty trace was left behind ('empty trace (no header)'), its file still open
    assert not trace.exists()
    assert _open_here(tmp_path) == []


def test_a_firmware_connection_never_closed_stops_its_chain() -> None:
    from firmware_chain_support import build_chain, missing_chain

    why = missing_chain()
    if why:
        pytest.skip(why)
    build_chain()
    robot = pirate_bt.connect("firmware:straight")
    chain = robot.simulator.chain
    del robot
    gc.collect()
    gc.collect()
    # its simavr process ran on for the life of the planner's process, three files open
    assert chain.closed
