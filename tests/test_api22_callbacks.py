"""Session 22: a callback the API would call with the wrong arity, or never run (an
async def), is refused before any work is done, as observe= is (docs/api.md,
*Arguments the API refuses*)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.errors import ArgumentTypeError


@pytest.fixture(scope="module")
def mission() -> Any:
    return pirate_bt.simulate_mission("bend-right")


async def _async_warn(message: str) -> None:  # pragma: no cover - never run
    return None


class _TwoArguments:
    def __call__(self, message: str, extra: str) -> None:  # pragma: no cover
        return None


@pytest.mark.parametrize(
    ("warn", "said"),
    [
        (
            lambda: None,
            "warn: <lambda>() cannot be called as warn(message); give a function of one argument",
        ),
        (
            _TwoArguments(),
            "warn: _TwoArguments(message: 'str', extra: 'str') cannot be called as"
            " warn(message); give a function of one argument",
        ),
        (
            _async_warn,
            "warn: _async_warn is an async def, which warn(message) would call and never"
            " run; give a plain function",
        ),
    ],
    ids=["none", "two", "async"],
)
def test_a_warn_callback_it_cannot_call_is_refused_before_the_output_folder_is_made(
    mission: Any, tmp_path: Path, warn: Any, said: str
) -> None:
    # lambda: None was taken, and failed with Python's bare TypeError once a plot could
    # not be made and the report was half done; an async def never ran
    out = tmp_path / "out"
    with pytest.raises(ArgumentTypeError) as caught:
        pirate_bt.write_mission_outputs(mission, out, warn=warn)
    assert str(caught.value) == said
    assert not out.exists()


def _observe_yields(runner: Any, connection: Any) -> Any:  # pragma: no cover - never run
    runner.add_post_tick(lambda info: None)
    yield


class _CallYields:
    def __call__(self, runner: Any, connection: Any) -> Any:  # pragma: no cover
        yield


@pytest.mark.parametrize(
    ("observe", "name"), [(_observe_yields, "_observe_yields"), (_CallYields(), "_CallYields")]
)
def test_an_observe_that_yields_is_refused_before_the_run(observe: Any, name: str) -> None:
    # a generator function's body never ran: no hook attached, the run went on unobserved
    # and succeeded, nothing said
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, observe=observe)
    assert str(caught.value) == (
        f"observe: {name} is a generator function (it yields), which observe(runner,"
        " connection) would never run (its hooks never attached); give a plain function"
    )


def test_a_warn_that_yields_is_refused(mission: Any, tmp_path: Path) -> None:
    def warn(message: str) -> Any:  # pragma: no cover - never run
        yield message

    with pytest.raises(
        ArgumentTypeError, match=r"^warn: warn is a generator function \(it yields\)"
    ):
        pirate_bt.write_mission_outputs(mission, tmp_path / "out", warn=warn)
    assert not (tmp_path / "out").exists()


def _runs_it(runner: Any, other: Any) -> None:
    runner.run()


RAN_IT = (
    "observe: it called runner.run(); attach hooks only (runner.add_post_tick, add_finish,"
    " ...): the run starts once observe returns"
)


def test_an_observe_that_runs_the_runner_itself_is_refused(tmp_path: Path) -> None:
    # the tree ran whole inside observe, then again: the result said the second run
    # ('succeeded after 19 ticks'), the first lost
    trace = tmp_path / "t.jsonl"
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.simulate_tree(
            "straight", params={"distance": "0.05 m"}, trace=trace, observe=_runs_it
        )
    assert str(caught.value) == RAN_IT
    assert not trace.exists()


def test_a_mission_observe_that_runs_the_runner_itself_is_refused() -> None:
    # the mission ran inside observe, then again from where it ended: 'map disagreement'
    with pytest.raises(pirate_bt.InputError) as caught:
        pirate_bt.simulate_mission("bend-right", observe=_runs_it)
    assert str(caught.value) == RAN_IT
