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

import sys
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


class _Unsayable(Exception):
    def __str__(self) -> str:
        raise RuntimeError("str boom")


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


@pytest.mark.parametrize(
    ("bad", "said"),
    [
        (lambda: None, "update() returned None, not a py_trees Status"),
        (lambda: "SUCCESS", "update() returned 'SUCCESS', not a py_trees Status"),
        (lambda: True, "update() returned True, not a py_trees Status"),
        (_raise(SystemExit(3)), "update() raised SystemExit: 3"),
        (_raise(GeneratorExit()), "update() raised GeneratorExit"),
        (_raise(BaseException("base")), "update() raised BaseException: base"),
        (_raise(StopIteration()), "update() raised StopIteration"),
        (_raise(_Unsayable()), "update() raised _Unsayable (whose str() raised"),
    ],
)
def test_a_node_that_breaks_the_contract_ends_the_run_naming_it(
    bad: Callable[[], Any], said: str, truth: list[Any], tmp_path: Path
) -> None:
    # was: None/'SUCCESS'/True ran on to the time limit (why naming nothing);
    # SystemExit, GeneratorExit, BaseException raised out of simulate_tree with the
    # robot at 36 mm/s and the trace empty; StopIteration named root/par; an exception
    # whose __str__ raised went out of the runner's own handler, the robot at 56 mm/s
    trace = tmp_path / "t.jsonl"
    result = pirate_bt.simulate_tree(_driving(_late("my node", bad)), max_time="4 s", trace=trace)
    assert result.failing_node == "root/par/my node"
    assert result.why.startswith(f"BehaviourBroke in root/par/my node: {said}"), result.why
    assert result.exit_code == 1 and result.safe_state
    assert truth[0].velocity_mps == 0.0
    _check_trace(trace, result.why)


def test_sys_exit_in_terminate_leaves_the_robot_at_rest(truth: list[Any], tmp_path: Path) -> None:
    class ExitsOnStop(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            return Status.RUNNING

        def terminate(self, new_status: Status) -> None:
            sys.exit("bye")

    # was: SystemExit out of simulate_tree as the time limit stopped the nodes, the
    # robot still at 76 mm/s
    result = pirate_bt.simulate_tree(
        _driving(ExitsOnStop("exits")), max_time="3 s", trace=tmp_path / "t.jsonl"
    )
    assert result.stop == "time_limit" and result.safe_state
    assert truth[0].velocity_mps == 0.0
    _check_trace(tmp_path / "t.jsonl", result.why)


def test_a_tick_of_its_own_that_sets_no_status_is_named(tmp_path: Path) -> None:
    class OwnTick(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            return Status.RUNNING

        def tick(self) -> Any:
            self.status = "WEIRD"
            yield self

    # was: "KeyError: 'WEIRD'" from the trace's coverage, no node, the trace empty
    result = pirate_bt.simulate_tree(OwnTick("own"), max_time="1 s", trace=tmp_path / "t.jsonl")
    assert result.failing_node == "own"
    assert (
        result.why == "BehaviourBroke in own: tick() left its status 'WEIRD', not a py_trees Status"
    )
    _check_trace(tmp_path / "t.jsonl", result.why)


def test_an_observers_hook_that_exits_leaves_the_robot_at_rest(
    truth: list[Any], tmp_path: Path
) -> None:
    class Runs(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            return Status.RUNNING

    def observe(runner: Any, _connection: Any) -> None:
        def hook(info: Any) -> None:
            if info.tick == 70:
                raise SystemExit("observer quits")

        runner.add_post_tick(hook)

    # was: SystemExit out of simulate_tree, the robot at 76 mm/s, the trace empty
    result = pirate_bt.simulate_tree(
        _driving(Runs("runs")), max_time="5 s", observe=observe, trace=tmp_path / "t.jsonl"
    )
    assert result.why.startswith("BehaviourBroke: a post-tick hook raised SystemExit"), result.why
    assert result.safe_state and truth[0].velocity_mps == 0.0
    _check_trace(tmp_path / "t.jsonl", result.why)


def test_a_feedback_message_of_any_length_keeps_the_why_one_line() -> None:
    class Says(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            self.feedback_message = "x" * 100_000 + "\nline two\x00"
            return Status.FAILURE

    # was: the why was the whole 100 kB message, on two lines
    result = pirate_bt.simulate_tree(Says("says"), max_time="1 s")
    assert "\n" not in result.why and len(result.why) < 1100
    assert "...(99014 characters)..." in result.why
    assert result.why.endswith("x\\nline two\\x00"), result.why[-60:]


def test_a_name_that_is_no_utf8_is_traced_escaped(tmp_path: Path) -> None:
    class Fails(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            self.feedback_message = "bad \udcff byte"
            return Status.FAILURE

    # was: the trace writer failed on the lone surrogate: the trace empty ("no header")
    # and the why the writer's UnicodeEncodeError
    trace = tmp_path / "t.jsonl"
    result = pirate_bt.simulate_tree(Fails("says \udcff"), max_time="1 s", trace=trace)
    assert result.why == r"bad \udcff byte"
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


def test_sys_exit_in_setup_is_named(tmp_path: Path) -> None:
    class ExitsInSetup(py_trees.behaviour.Behaviour):
        def setup(self, **kwargs: Any) -> None:
            sys.exit("no hardware")

        def update(self) -> Status:
            return Status.RUNNING

    # was: SystemExit out of simulate_tree, the trace empty
    trace = tmp_path / "t.jsonl"
    result = pirate_bt.simulate_tree(_driving(ExitsInSetup("exits")), max_time="1 s", trace=trace)
    assert result.failing_node == "root/par/exits"
    assert "setup() raised SystemExit: no hardware" in result.why
    _check_trace(trace, result.why)


class _NoText:
    def __repr__(self) -> str:
        raise RuntimeError("repr boom")

    __str__ = __repr__


@pytest.mark.parametrize(
    ("message", "why"), [(42, "42"), (_NoText(), "<_NoText: its str() raised")]
)
def test_a_feedback_message_that_is_no_text_is_the_why_as_text(
    message: Any, why: str, tmp_path: Path
) -> None:
    class Says(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            self.feedback_message = message
            return Status.FAILURE

    # was: the why was the int 42 (and the trace's end reason); an object whose repr
    # raises ended the run in the trace writer, "RuntimeError: repr boom", no node
    trace = tmp_path / "t.jsonl"
    result = pirate_bt.simulate_tree(Says("says"), max_time="1 s", trace=trace)
    assert isinstance(result.why, str) and result.why.startswith(why), result.why
    assert result.failing_node == "says"
    _check_trace(trace, result.why)
    # the trace's feedback is text too (42 was written as a number, which a reader refuses)
    fed = [text for tick in pirate_bt.read_trace(trace).ticks for text in tick.feedback.values()]
    assert fed and all(isinstance(text, str) for text in fed), fed


def test_a_node_is_handed_back_unwrapped_and_held_again_on_the_next_run() -> None:
    node = _late("mine", lambda: None)
    for _ in range(2):
        result = pirate_bt.simulate_tree(node, max_time="1 s")
        assert result.failing_node == "mine" and "update() returned None" in result.why
        # a copy made after the run calls its own update, not the wrapper's node's
        assert "update" not in vars(node) and "_pirate_bt_held" not in vars(node)


def test_a_huge_node_name_keeps_the_cause_in_the_why() -> None:
    # the middle is left out, not the end: the cause comes after the node's path
    node = _late("n" * 5000, _raise(SystemExit("the cause")))
    result = pirate_bt.simulate_tree(node, max_time="1 s")
    assert len(result.why) < 1100 and "raised SystemExit: the cause" in result.why


def test_a_behaviour_that_blocks_its_tick_is_named_in_the_why() -> None:
    import time

    class Sleeps(py_trees.behaviour.Behaviour):
        def initialise(self) -> None:
            self.n = 0

        def update(self) -> Status:
            self.n += 1
            if self.n == 2:
                time.sleep(1.1)
            return Status.RUNNING

    # was: "time limit of 0.5 s reached after 11 ticks; sleeps was still running" and
    # nothing else; on a robot's port (a reader thread feeding the bridge's watchdog)
    # the wheels kept turning at 80 mm/s through a 3 s sleep, nothing checked
    result = pirate_bt.simulate_tree(Sleeps("sleeps"), max_time="0.5 s")
    assert "; a tick took more than 1 s (the first, tick 2), the longest 1.1 s:" in result.why
    assert result.why.endswith("(on a robot the drives keep their setpoints)")


def test_a_tree_handler_that_exits_leaves_the_robot_at_rest(
    truth: list[Any], tmp_path: Path
) -> None:
    class Runs(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            return Status.RUNNING

    def handler(tree: py_trees.trees.BehaviourTree) -> None:
        if tree.count > 60:
            sys.exit("handler exit")

    tree = py_trees.trees.BehaviourTree(_driving(Runs("runs")))
    tree.add_pre_tick_handler(handler)
    # was: SystemExit out of simulate_tree, the robot at 76 mm/s, the trace empty
    result = pirate_bt.simulate_tree(tree, max_time="5 s", trace=tmp_path / "t.jsonl")
    assert result.why.startswith(
        "BehaviourBroke: a pre-tick handler of the tree raised SystemExit: handler exit"
    ), result.why
    assert result.safe_state and truth[0].velocity_mps == 0.0
    _check_trace(tmp_path / "t.jsonl", result.why)
