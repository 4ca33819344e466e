"""Errors go to another process and come back whole: a process pool (or Dask) sends the
exception a worker raised back to the caller by pickling it."""

from __future__ import annotations

import copy
import pickle
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.api.mission_outputs import OutputsNotWritten
from pirate_bt.errors import InputError, PirateError
from pirate_bt.trace.query import NodeLookupError
from pirate_bt.treefile.registry import UnknownNode


def _first_tick_of_nothing(trace: str) -> object:
    return pirate_bt.read_trace(trace).first_tick("nosuch", "SUCCESS")


def test_a_node_lookup_error_in_a_pool_worker_reaches_the_caller(tmp_path: Path) -> None:
    trace = tmp_path / "run.jsonl"
    pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, trace=trace)
    with ProcessPoolExecutor(1) as pool:
        future = pool.submit(_first_tick_of_nothing, str(trace))
        with pytest.raises(NodeLookupError) as raised:
            future.result(timeout=120)
        # the pool is whole: it runs the next call (a broken pool raises here)
        assert pool.submit(len, "abc").result(timeout=120) == 3
    assert raised.value.query == "nosuch" and "nosuch" in str(raised.value)


class _Own(InputError):
    """A subclass a user writes, with an __init__ of its own and no __reduce__."""

    def __init__(self, what: str, count: int) -> None:
        super().__init__(f"{what} x{count}")
        self.what = what
        self.count = count


@pytest.mark.parametrize(
    "error",
    [
        NodeLookupError("no node answers to 'x'", "x", ["a", "b"]),
        UnknownNode("clmap", ["clamp"]),
        OutputsNotWritten("--output: cannot write out/report.md", {"why": "stall"}),
        _Own("refusals", 3),
    ],
    ids=lambda e: type(e).__name__,
)
def test_an_error_with_its_own_arguments_is_read_back_whole(error: Exception) -> None:
    back = pickle.loads(pickle.dumps(error))
    assert type(back) is type(error)
    assert str(back) == str(error) and back.args == error.args
    assert vars(back) == vars(error)
    if isinstance(error, PirateError):
        assert back.exit_code == error.exit_code


def test_a_robot_description_goes_to_a_pool_worker_and_runs_there() -> None:
    robot = pirate_bt.load_robot()
    with ProcessPoolExecutor(1) as pool:
        result = pool.submit(
            pirate_bt.simulate_tree, "straight", params={"distance": "0.05 m"}, robot=robot
        ).result(timeout=120)
    assert result.succeeded, result.why


def test_a_robot_description_copies_whole() -> None:
    robot = pirate_bt.load_robot()
    for copied in (copy.deepcopy(robot), pickle.loads(pickle.dumps(robot))):
        assert copied == robot and copied.digest() == robot.digest()
        # what is looked up through its index is its own, not the original's
        board = copied.board_of("bend_1_joint")
        assert any(board is b for b in copied.boards)
        assert not any(board is b for b in robot.boards)
        assert copied.motor("bend_1_joint") == robot.motor("bend_1_joint")
