"""A result sent to another process keeps the cause its error was raised from.

Python pickles an exception without ``__cause__`` and ``__context__``: a navigator's
``raise RuntimeError("no way to the goal") from KeyError("tee-9")`` came back from a
process pool's worker as the ``RuntimeError`` alone, where the same result in the
calling process kept the ``KeyError`` that started it.
"""

from __future__ import annotations

import copy
import pickle

import py_trees

import pirate_bt
from pirate_bt import Observation, Step


class _Chained:
    def next_step(self, obs: Observation) -> Step | None:
        try:
            {}["tee-9"]
        except KeyError as e:
            raise RuntimeError("no way to the goal") from e
        return None


class _Boom(py_trees.behaviour.Behaviour):
    def update(self) -> py_trees.common.Status:
        try:
            int("x")
        except ValueError:
            raise RuntimeError("sensor read failed")  # noqa: B904 (raised while handling)
        return py_trees.common.Status.SUCCESS


def _read_back(result: object) -> object:
    return pickle.loads(pickle.dumps(result))


def test_a_navigations_error_read_back_keeps_the_cause_it_was_raised_from() -> None:
    result = pirate_bt.navigate(_Chained(), sim="straight")
    for back in (_read_back(result), copy.deepcopy(result)):
        assert isinstance(back, pirate_bt.NavigationResult)
        assert repr(back.error) == "RuntimeError('no way to the goal')"
        assert repr(back.error.__cause__) == "KeyError('tee-9')"
        assert back.error.__context__ is back.error.__cause__
        assert back.error.__suppress_context__


def test_a_tree_runs_error_read_back_keeps_what_it_was_raised_while_handling() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        result = robot.run(_Boom("boom"))
    back = _read_back(result)
    assert isinstance(back, pirate_bt.RunResult)
    assert repr(back.error) == "RuntimeError('sensor read failed')"
    assert back.error.__cause__ is None and not back.error.__suppress_context__
    assert isinstance(back.error.__context__, ValueError)
    assert "invalid literal for int()" in str(back.error.__context__)
    assert back.loop is not None and back.loop.error is back.error  # one exception, as sent


def test_a_result_with_an_error_read_back_equals_its_original() -> None:
    # api.md: "one read back equals its original"; an exception compares by identity,
    # so a result whose run ended on one was never equal to itself read back
    navigation = pirate_bt.navigate(_Chained(), sim="straight")
    assert _read_back(navigation) == navigation
    assert copy.deepcopy(navigation) == navigation
    with pirate_bt.connect("sim:straight") as robot:
        run = robot.run(_Boom("boom"))
    back = _read_back(run)
    assert isinstance(back, pirate_bt.RunResult) and back.loop is not None
    assert back == run and back.loop == run.loop
    assert hash(back.loop) == hash(run.loop)  # the runner's result is hashable: alike
    # an error of another message is another value
    other = copy.deepcopy(navigation)
    other.error = RuntimeError("another way")
    assert other != navigation
