"""Navigators written from docs/navigators.md that break in ways the library must absorb
(a probe of 2026-11-29): an exception whose message cannot be shown, a navigator's own
LinkError, and SystemExit from check_map."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from typing import Any

import pytest

import pirate_bt
from pirate_bt import Step
from pirate_bt.errors import InputError, LinkError


@pytest.fixture(autouse=True)
def _quiet(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    caplog.set_level(logging.ERROR)
    yield


class Unprintable(Exception):
    def __str__(self) -> str:
        raise RuntimeError("cannot print me")


class RaisesOnStep1:
    def __init__(self, exc: BaseException) -> None:
        self.exc = exc

    def next_step(self, obs: Any) -> Step:
        if obs.step == 1:
            raise self.exc
        return Step("straight", distance="0.3 m")


def test_an_exception_whose_message_cannot_be_shown_is_still_a_result(tmp_path: Any) -> None:
    # a bare RuntimeError from its __str__ escaped navigate(), and the trace's end had no why
    result = pirate_bt.navigate(RaisesOnStep1(Unprintable()), sim="straight", trace=tmp_path)
    assert result.why == (
        "navigator 'RaisesOnStep1' raised Unprintable: <its message cannot be shown:"
        " Unprintable.__str__ raised>"
    )
    assert result.safe_state and result.exit_code == 1
    assert isinstance(result.error, Unprintable) and result.navigator_raised
    assert '"why": "navigator' in (tmp_path / "navigation.jsonl").read_text()


def test_a_link_error_the_navigator_raises_is_its_failure_not_a_lost_link() -> None:
    result = pirate_bt.navigate(RaisesOnStep1(LinkError("my own")), sim="straight")
    assert result.why == "navigator 'RaisesOnStep1' raised LinkError: my own"
    assert result.exit_code == 1  # was 3, the exit of a link lost


class BadMapCheck:
    def __init__(self, exc: BaseException) -> None:
        self.exc = exc

    def check_map(self, network: Any) -> None:
        raise self.exc

    def next_step(self, obs: Any) -> None:
        return None


@pytest.mark.parametrize(
    ("exc", "said"),
    [
        (SystemExit(2), "check_map raised SystemExit: 2"),
        (Unprintable(), "check_map raised Unprintable: <its message cannot be shown"),
    ],
)
def test_check_map_raising_anything_is_one_line_naming_the_navigator(
    exc: BaseException, said: str
) -> None:
    with pytest.raises(InputError, match=f"^navigator 'BadMapCheck': {said}") as caught:
        pirate_bt.navigate(BadMapCheck(exc), sim="lab", map="lab")
    assert "\n" not in str(caught.value)


def test_every_decision_record_has_its_trace_and_why_keys(tmp_path: Any) -> None:
    import json

    pirate_bt.navigate(RaisesOnStep1(RuntimeError("boom")), sim="straight", trace=tmp_path)
    records = [json.loads(x) for x in (tmp_path / "navigation.jsonl").read_text().splitlines()]
    decisions = [r for r in records if r["type"] == "decision"]
    assert decisions[0]["trace"] == "step-001.jsonl" and "why" in decisions[0]
    assert decisions[-1]["trace"] is None
    assert decisions[-1]["why"] == "navigator 'RaisesOnStep1' raised RuntimeError: boom"


class MutatesTheMap:
    def next_step(self, obs: Any) -> Step | None:
        if obs.step == 0:
            obs.map.spec.segments.clear()  # a navigator's own business
            return Step("t-joint", direction="straight")
        return None


def test_a_navigator_that_mutates_its_map_changes_only_its_own_copy() -> None:
    # it failed the planner with a bare IndexError, and changed the caller's Network
    network = pirate_bt.load_network("t-joint")
    segments = len(network.spec.segments)
    result = pirate_bt.navigate(MutatesTheMap(), sim="t-joint", map=network)
    assert result.succeeded, result.why
    assert len(network.spec.segments) == segments


class Only:
    def __init__(self, *steps: Step) -> None:
        self.steps = steps

    def next_step(self, obs: Any) -> Step | None:
        return self.steps[obs.step] if obs.step < len(self.steps) else None


@pytest.mark.parametrize("pab", ["bend-back", "t-joint-back"])
def test_a_backward_pab_at_the_entry_with_no_map_is_refused_before_it_moves(pab: str) -> None:
    # it backed the robot against the mouth with its wheels turning for 3 m: the belief
    # drifted to -3.0 m and the why said 'no feature (blocked) within 3 m'
    direction = "right" if pab == "bend-back" else "left"
    result = pirate_bt.navigate(Only(Step(pab, direction=direction)), sim="straight")
    assert result.why.endswith(
        "the robot has passed nothing since it was put in (at 0.00 m): the pipe's entry"
        " is behind it, no bend or tee"
    ), result.why
    assert result.belief_m == 0.0 and result.safe_state and result.steps == 0
