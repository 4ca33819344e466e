"""Probe 15: a hurried or hostile planner's own py_trees behaviours, on the simulator.

Whatever a behaviour does, a run ends with one line naming the node and the first cause,
a trace ``read_trace`` reads, and the robot at rest. Before these fixes a behaviour that
returned ``None`` (a missing ``return``) ran on to the time limit naming nothing; one that
called ``sys.exit()`` went past the runner with the robot driving and the trace empty;
``StopIteration`` named the parent; a non-UTF-8 name emptied the trace; a 100 kB
multi-line feedback message was the why; a blackboard value the trace could not spell
ended the run on its first tick naming nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.drive import Drive
from pirate_bt.behaviours.primitives import Clamp, MoveFrontClear
from pirate_bt.sim import Simulator


class _Late(py_trees.behaviour.Behaviour):
    """RUNNING twice, then does ``bad`` on its third update."""

    bad: Callable[[], Any]

    def initialise(self) -> None:
        self.n = 0

    def update(self) -> Any:
        self.n += 1
        return Status.RUNNING if self.n < 3 else type(self).bad()


def _late(name: str, bad: Callable[[], Any]) -> py_trees.behaviour.Behaviour:
    return type("Bad", (_Late,), {"bad": staticmethod(bad)})(name)


def _raise(exc: BaseException) -> Callable[[], Any]:
    def bad() -> Any:
        raise exc

    return bad


def _driving(node: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
    """Both halves clamped, then ``node`` beside a 2 m drive at 80 mm/s."""
    ctx = BuildContext()
    par = py_trees.composites.Parallel(
        "par", policy=py_trees.common.ParallelPolicy.SuccessOnAll(synchronise=False)
    )
    par.add_children([Drive.build("drive", ctx, velocity=0.08, distance=2.0), node])
    root = py_trees.composites.Sequence("root", memory=True)
    root.add_children(
        [
            Clamp.build("clamp rear", ctx, half="rear", torque=0.7),
            MoveFrontClear.build("clear", ctx),
            Clamp.build("clamp front", ctx, half="front", torque=0.7),
            par,
        ]
    )
    return root


@pytest.fixture
def truth(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """The simulator's truth as each connection closes it."""
    seen: list[Any] = []
    close = Simulator.close

    def closing(self: Simulator) -> None:
        if not self._closed:
            seen.append(self.truth())
        close(self)

    monkeypatch.setattr(Simulator, "close", closing)
    return seen


def _check_trace(path: Path, why: str) -> None:
    read = pirate_bt.read_trace(path)
    assert read.end is not None and read.end["reason"].startswith(why[:40])


def test_a_name_that_is_no_utf8_is_traced_escaped(tmp_path: Path) -> None:
    class Fails(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            self.feedback_message = "bad \udcff byte"
            return Status.FAILURE

    # was: the trace writer failed on the lone surrogate: the trace empty ("no header")
    # and the why the writer's UnicodeEncodeError
    trace = tmp_path / "t.jsonl"
    result = pirate_bt.simulate_tree(Fails("says \udcff"), max_time="1 s", trace=trace)
    assert result.status == "failure"
    read = pirate_bt.read_trace(trace)
    assert read.end is not None and read.end["outcome"] == "failure"
    assert r'"name":"says \udcff"' in trace.read_text("utf-8")  # a JSON escape


@pytest.mark.parametrize("kind", ["cycle", "repr"])
def test_a_blackboard_value_the_trace_cannot_spell_is_noted_not_fatal(
    kind: str, tmp_path: Path
) -> None:
    class Evil:
        def __repr__(self) -> str:
            raise RuntimeError("repr boom")

    cycle: list[Any] = []
    cycle.append(cycle)
    value = cycle if kind == "cycle" else Evil()

    class Writes(py_trees.behaviour.Behaviour):
        def __init__(self, name: str) -> None:
            super().__init__(name)
            self.bb = self.attach_blackboard_client("w")
            self.bb.register_key("probe15_key", access=py_trees.common.Access.WRITE)

        def update(self) -> Status:
            self.bb.probe15_key = value
            return Status.SUCCESS

    # was: "RecursionError: maximum recursion depth exceeded" / "RuntimeError: repr boom"
    # on the first tick, from the trace's hook, no node named
    trace = tmp_path / "t.jsonl"
    result = pirate_bt.simulate_tree(Writes("writes"), max_time="1 s", trace=trace)
    assert result.status == "success", result.why
    assert "not recorded: " in trace.read_text("utf-8")
