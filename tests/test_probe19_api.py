"""Planner code written from docs/api.md, at the seams the eighteenth probes left:
connections never closed, runs from threads, results kept and sent on."""

from __future__ import annotations

import contextlib
import gc
import os
import weakref
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt.behaviours.base import Leaf, NodeParams
from pirate_bt.behaviours.primitives import Clamp, Drive, MoveFrontClear


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
    with pytest.raises(RuntimeError, match="my observer broke"):  # a mission's the same
        pirate_bt.simulate_mission(
            Path(__file__).resolve().parents[1] / "scenarios" / "straight.route",
            observe=observe,
            trace=trace,
        )
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


class _CtrlCAsItStops(Leaf):
    """Runs beside a drive; fails at its 80th tick, and Ctrl-C lands in its terminate()
    as the runner stops the running nodes."""

    Params = NodeParams
    needs_robot = False

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.ticks = 0

    def update(self) -> Status:
        self.ticks += 1
        return Status.FAILURE if self.ticks == 80 else Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if self.ticks >= 80:
            raise KeyboardInterrupt


def test_ctrl_c_as_the_runner_stops_the_nodes_leaves_the_robot_in_its_safe_state() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        ctx = robot.context()
        legs = py_trees.composites.Sequence(name="legs", memory=True)
        legs.add_children(
            [
                Clamp.build("clamp rear", ctx, half="rear", torque="0.7 N*m"),
                MoveFrontClear.build("front clear", ctx),
                Clamp.build("clamp front", ctx, half="front", torque="0.7 N*m"),
                Drive.build("drive", ctx, velocity="80 mm/s", distance="2 m"),
            ]
        )
        root = py_trees.composites.Parallel(
            name="both", policy=py_trees.common.ParallelPolicy.SuccessOnAll()
        )
        root.add_children([legs, _CtrlCAsItStops.build("watch", ctx)])
        with pytest.raises(KeyboardInterrupt):
            robot.run(root, max_time="60 s")
        # it went out with the drive at 80 mm/s and no safe state entered: planner code
        # that caught it ran its next tree on a robot taken for fine
        assert robot.supervisor.in_safe_state
        # the runner's own safe state, the first cause kept (the Ctrl-C in the tick)
        reason = "tree run ended without success: interrupted (Ctrl-C)"
        assert robot.supervisor.safe_state_reason == reason
        after = robot.run("straight", params={"distance": "0.1 m"})
        assert after.why.startswith(f"the robot is in its safe state: {reason}")


def test_a_tree_built_without_a_robot_runs_again_and_again() -> None:
    # the first run bound its nodes to its connection for good: the second was refused,
    # 'was built with another connection's context(); build it with this connection's'
    root = pirate_bt.load_tree("straight", params={"distance": "0.1 m"}).root
    assert [pirate_bt.simulate_tree(root, seed=seed).status for seed in (0, 1)] == [
        "success",
        "success",
    ]
    tree = pirate_bt.load_tree("straight", params={"distance": "0.1 m"}).behaviour_tree()
    for _ in range(2):
        with pirate_bt.connect("sim:straight") as robot:
            assert robot.run(tree).succeeded
