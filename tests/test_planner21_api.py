"""What a planner script written from the docs met in the twenty-first session: results
and exceptions that go back from a process pool's worker (docs/api.md: "run them ...
in parallel in processes ... every result pickles")."""

from __future__ import annotations

import pickle
from typing import Any

import py_trees
import pytest
from py_trees.common import Status

import pirate_bt
from pirate_bt.errors import InputError, UnpicklableError
from pirate_bt.runner import RunInterrupted


class _CtrlCWhenStopped(py_trees.behaviour.Behaviour):
    """Runs for ever; a Ctrl-C lands in its terminate() as the runner stops it."""

    def update(self) -> Status:
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID:
            raise KeyboardInterrupt


class _TwoArgs(Exception):
    """A planner's exception that pickles but cannot be read back (two arguments)."""

    def __init__(self, what: str, code: int) -> None:
        super().__init__(f"{what} ({code})")


class _RaisesAtTick2(py_trees.behaviour.Behaviour):
    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.ticks = 0

    def update(self) -> Status:
        self.ticks += 1
        if self.ticks == 2:
            raise _TwoArgs("sensor gone", 7)
        return Status.RUNNING


def _interrupted(root: py_trees.behaviour.Behaviour) -> RunInterrupted:
    with pytest.raises(RunInterrupted) as caught:
        pirate_bt.simulate_tree(root, max_time="1 s")
    return caught.value


def test_a_run_interrupted_goes_back_from_a_process_pool_with_its_result() -> None:
    # a worker of a ProcessPoolExecutor running simulate_tree gets the terminal's Ctrl-C
    # too; the RunInterrupted it raises is pickled back to the planner's process, where
    # reading it back raised AttributeError: 'str' object has no attribute 'message'
    # (its __init__ takes the result, its args hold the message): BrokenProcessPool
    sent = _interrupted(
        py_trees.composites.Sequence("s", memory=True, children=[_CtrlCWhenStopped("watch")])
    )
    back = pickle.loads(pickle.dumps(sent))
    assert isinstance(back, RunInterrupted) and isinstance(back, KeyboardInterrupt)
    assert back.result.outcome == "failure"
    assert back.result.message == sent.result.message
    assert "time limit of 1 s" in back.result.message
    assert str(back) == str(sent)


def test_a_run_interrupted_whose_run_ended_on_a_planner_s_exception_still_goes_back() -> None:
    # the run's first cause is a planner's exception that cannot be read back: it goes
    # as an UnpicklableError with its type's name and message, as a RunResult's does
    root = py_trees.composites.Parallel(
        "p",
        policy=py_trees.common.ParallelPolicy.SuccessOnAll(),
        children=[_CtrlCWhenStopped("watch"), _RaisesAtTick2("sensor")],
    )
    sent = _interrupted(root)
    assert isinstance(sent.result.error, _TwoArgs)  # the caller's own keeps it as raised
    back = pickle.loads(pickle.dumps(sent))
    assert isinstance(back.result.error, UnpicklableError)
    assert "_TwoArgs: sensor gone (7)" in str(back.result.error)
    assert back.result.failing_node == sent.result.failing_node
    assert "sensor gone (7)" in back.result.message


@pytest.mark.parametrize(
    ("run", "shape"),
    [
        (
            lambda observe: pirate_bt.simulate_tree(
                py_trees.behaviours.Success("ok"), observe=observe
            ),
            "observe(runner, connection)",
        ),
        (
            lambda observe: pirate_bt.simulate_mission("straight", observe=observe),
            "observe(runner, values)",
        ),
    ],
    ids=["tree", "mission"],
)
def test_an_observer_that_cannot_take_the_runner_is_refused_in_one_line(
    run: Any, shape: str
) -> None:
    # docs/api.md: every argument is checked before anything connects and a bad one is
    # one InputError line naming it; an observe= of the wrong shape went out of the
    # call as Python's bare "TypeError: <lambda>() takes 0 positional arguments but 2
    # were given", and an async def was called, never awaited, its hooks never attached,
    # and the run went on as if observed (a RuntimeWarning the only sign)
    async def attach(runner: Any, connection: Any) -> None:
        runner.post_tick.append(print)

    for observe, said in [
        (lambda: None, "<lambda>()"),
        (lambda runner: None, "<lambda>(runner)"),
        (attach, "is an async def"),
    ]:
        with pytest.raises(InputError) as caught:
            run(observe)
        message = str(caught.value)
        assert message.startswith("observe: ") and "\n" not in message
        assert said in message and shape in message


def test_an_observer_of_any_callable_shape_that_takes_two_arguments_runs() -> None:
    # a bound method, a callable object, *args and a default third argument all take
    # (runner, connection): not refused
    seen: list[str] = []

    class Hooks:
        def attach(self, runner: Any, connection: Any, extra: int = 0) -> None:
            seen.append("method")

        def __call__(self, *args: Any) -> None:
            seen.append(f"call {len(args)}")

    for observe in (Hooks().attach, Hooks()):
        result = pirate_bt.simulate_tree(py_trees.behaviours.Success("ok"), observe=observe)
        assert result.status == "success"
    assert seen == ["method", "call 2"]


class _Broken(py_trees.behaviour.Behaviour):
    def update(self) -> Status:
        raise RuntimeError("sensor gone")


def test_the_summary_of_a_tree_built_in_python_is_one_line_whatever_its_names() -> None:
    # docs/api.md: summary() is the line `pirate-bt run` prints and why is one line a
    # terminal can print; a tree built in Python (no file's name checks) named with a
    # line break or an escape sequence put them raw into summary(), its name first and
    # its failing node after the why: two lines, the second a terminal's clear-screen
    root = py_trees.composites.Sequence(
        "survey\nrun \x1b[2J", memory=True, children=[_Broken("probe\rA")]
    )
    result = pirate_bt.simulate_tree(root)
    line = result.summary()
    assert line.isprintable(), repr(line)
    assert line.startswith("survey\\nrun \\x1b[2J: FAILURE - RuntimeError")
    assert "sensor gone" in line
    # the result's own fields keep the names as given
    assert result.tree == "survey\nrun \x1b[2J"
    assert result.failing_node == "survey\nrun \x1b[2J/probe\rA"


@pytest.mark.parametrize(
    ("options", "said"),
    [
        ({"registry": "default"}, "registry: give a Registry"),
        ({"use_examples": "no"}, "use_examples: give True or False"),
        ({"clock": "wall"}, "clock: give a clock"),
        ({"supervisor": "robot"}, "supervisor: give a Supervisor"),
        ({"params_from_text": True}, "load_tree: no option 'params_from_text'"),
        ({"colour": 1}, "load_tree: no option 'colour'"),
    ],
)
def test_load_tree_checks_the_options_it_passes_on(options: dict[str, Any], said: str) -> None:
    # docs/api.md: every public function checks its arguments and answers a bad one in
    # one line naming it, never a traceback from deep inside; pirate_bt.load_tree passed
    # **options on unchecked: registry='default' raised AttributeError: 'str' object has
    # no attribute 'get' from the loader, use_examples='no' was true, a clock or
    # supervisor of text was taken, and params_from_text=True raised "TypeError:
    # pirate_bt.api.running.load_tree_source() got multiple values for keyword argument"
    with pytest.raises(InputError) as caught:
        pirate_bt.load_tree("straight", params={"distance": "0.1 m"}, **options)
    message = str(caught.value)
    assert message.startswith(said) and "\n" not in message
    if said.startswith("load_tree: no option"):
        assert isinstance(caught.value, TypeError)  # as Python's own was
        assert "registry, use_examples, clock, supervisor" in message


def test_load_tree_takes_the_options_it_documents() -> None:
    from pirate_bt.clock import SimClock
    from pirate_bt.treefile import default_registry

    tree = pirate_bt.load_tree(
        "bend", registry=default_registry(), use_examples=True, clock=SimClock(), supervisor=None
    )
    assert tree.name == "bend"
