"""Preconditions of the steps with no map, refused before the robot moves (a probe of
2026-11-29 found two unchecked): ``probe-turn`` only where a straight stopped blocked,
``bend-back`` and ``t-joint-back`` only with a bend (a tee) passed and not backed
through yet. Each refusal is the navigator's invalid step: a failure (exit 1), the robot
left safe where the step before left it."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from typing import Any

import pytest

import pirate_bt
from pirate_bt import Step
from pirate_bt.task.navigation import BlindTrail, Felt, InvalidStep, check_step


@pytest.fixture(autouse=True)
def _quiet(caplog: pytest.LogCaptureFixture) -> Iterator[None]:
    caplog.set_level(logging.ERROR)
    yield


class Only:
    """These steps in turn, then done (stops at a failed step)."""

    def __init__(self, *steps: Step) -> None:
        self.steps = steps

    def next_step(self, obs: Any) -> Step | None:
        if obs.last is not None and obs.last.outcome != "success":
            return None
        return self.steps[obs.step] if obs.step < len(self.steps) else None


def _refused_after_one_step(result: Any, step: Step) -> None:
    """Refused before it moved: the one step before it is all that ran, the robot is
    where that step left it (belief and truth), safe, and the simulator counted nothing."""
    assert result.status == "failure" and result.exit_code == 1
    assert result.steps == 1 and len(result.pabs) == 1
    assert result.decisions[-1].step == step and result.decisions[-1].outcome is None
    assert result.decisions[-1].error == result.why
    assert result.belief_m == result.decisions[-1].observation.belief.position_m
    assert result.truth_m == pytest.approx(result.belief_m, abs=0.005)
    assert result.distance_m == pytest.approx(result.belief_m, abs=0.005)  # forwards only
    assert result.safe_state
    assert result.counters.violations == 0 and result.counters.damage == 0
    assert result.sim["violations"] == 0 and result.sim["damage"] == 0


# -- probe-turn


def test_probe_turn_in_open_pipe_is_refused_before_it_moves() -> None:
    # it answered Felt(kind='bend', direction='up', how='probe'), a success: a bend that
    # is not there
    probe = Step("probe-turn")
    result = pirate_bt.navigate(Only(Step("straight", distance="1 m"), probe), sim="straight")
    _refused_after_one_step(result, probe)
    assert result.why == (
        "navigator 'Only' asked for an invalid step: Step('probe-turn'): the robot is not"
        f" where a straight stopped blocked (at {result.belief_m:.2f} m, after"
        " Step('straight', distance='1 m')): probe-turn finds the way on where a straight"
        " with stop_at_feature stopped blocked; in open pipe it would answer with a turn"
        " that is not there"
    )


def test_probe_turn_as_the_first_step_is_refused() -> None:
    result = pirate_bt.navigate(Only(Step("probe-turn")), sim="straight")
    assert result.status == "failure" and result.exit_code == 1 and result.steps == 0
    assert result.why == (
        "navigator 'Only' asked for an invalid step: Step('probe-turn'): no straight has"
        " stopped blocked since the robot was put in (at 0.00 m): probe-turn finds the"
        " way on where a straight with stop_at_feature stopped blocked; in open pipe it"
        " would answer with a turn that is not there"
    )
    assert result.belief_m == 0.0 and result.truth_m == 0.0 and result.safe_state
    assert result.distance_m == 0.0 and result.counters.violations == 0


def test_probe_turn_over_an_opening_is_refused_and_points_at_probe_tee() -> None:
    probe = Step("probe-turn")
    stop = Step("straight", distance="3 m", stop_at_feature=True)
    result = pirate_bt.navigate(Only(stop, probe), sim="t-joint")
    _refused_after_one_step(result, probe)
    assert result.decisions[-1].observation.felt[0].how == "opening"
    assert "which stopped over an opening: probe-tee finds its branch)" in result.why


def test_probe_turn_where_a_straight_stopped_blocked_still_runs_and_after_a_wait() -> None:
    # the survey's use: a straight with stop_at_feature stopped blocked at the bend; a
    # probe-turn (or a wait) ends where it began, so probing again there is allowed
    steps = (
        Step("straight", distance="3 m", stop_at_feature=True),
        Step("probe-turn"),
        Step("wait", time="1 s"),
        Step("probe-turn"),
        Step("bend", direction="right"),
    )
    result = pirate_bt.navigate(Only(*steps), sim="bend-right")
    assert result.succeeded, result.why
    felt = [d.observation.felt for d in result.decisions]
    assert felt[1][0].how == "blocked"
    assert felt[2][0].kind == "bend" and felt[2][0].direction == "right"
    assert felt[4][0].kind == "bend" and felt[4][0].direction == "right"


# -- bend-back, t-joint-back


@pytest.mark.parametrize(
    ("step", "sim"),
    [
        (Step("bend-back", direction="right"), "straight"),
        (Step("t-joint-back", direction="straight"), "straight"),
        (Step("bend-back", direction="right"), "bend-right"),
    ],
)
def test_a_backward_pab_after_a_straight_that_passed_nothing_is_refused(
    step: Step, sim: str
) -> None:
    # it backed the robot against the mouth while its wheels turned: the belief drifted
    # to -2 m and the step failed 'no feature (blocked) within 3 m'
    result = pirate_bt.navigate(Only(Step("straight", distance="1 m"), step), sim=sim)
    _refused_after_one_step(result, step)
    assert result.why == (
        f"navigator 'Only' asked for an invalid step: {step!r}: the robot has passed"
        f" nothing since it was put in (at {result.belief_m:.2f} m): the pipe's entry is"
        " behind it, no bend or tee"
    )
    assert result.belief_m == pytest.approx(1.0, abs=0.02)


def test_bend_back_with_only_a_tee_behind_is_refused() -> None:
    steps = (
        Step("straight", distance="1.5 m"),
        Step("t-joint", direction="straight"),
        Step("bend-back", direction="right"),
    )
    result = pirate_bt.navigate(Only(*steps), sim="t-joint")
    assert result.status == "failure" and result.exit_code == 1 and result.steps == 2
    assert result.why.endswith(
        "Step('bend-back', direction='right'): no bend is behind the robot to back through"
        f" (at {result.belief_m:.2f} m): it has passed no bend since it was put in"
    ), result.why
    assert result.truth_m == pytest.approx(result.belief_m, abs=0.005)
    assert result.safe_state and result.counters.violations == 0


def test_bend_back_through_the_bend_passed_runs_and_a_second_is_refused() -> None:
    steps = (
        Step("straight", distance="3 m", stop_at_feature=True),
        Step("probe-turn"),
        Step("bend", direction="right"),
        Step("straight", distance="0.5 m"),
        Step("bend-back", direction="right"),
        Step("bend-back", direction="right"),
    )
    result = pirate_bt.navigate(Only(*steps), sim="bend-right")
    assert (
        result.steps == 5
        and [o for _, o in result.decisions[-1].observation.history] == ["success"] * 5
    )
    assert result.status == "failure" and result.exit_code == 1
    assert result.why.endswith(
        "Step('bend-back', direction='right'): no bend is behind the robot to back through"
        f" (at {result.belief_m:.2f} m): it has backed past every bend it passed since it"
        " was put in"
    ), result.why
    assert result.safe_state and result.counters.violations == 0


def test_t_joint_back_through_a_tee_a_plain_straight_crossed_still_runs() -> None:
    # no T-joint PAB passed it, but the straight drove through the tee's run: its
    # joints swung off the wall over the opening, so the tee is behind the robot
    steps = (Step("straight", distance="3 m"), Step("t-joint-back", direction="straight"))
    result = pirate_bt.navigate(Only(*steps), sim="t-joint")
    assert result.succeeded, result.why
    assert result.decisions[-1].observation.felt[0].kind == "tee"


# -- the trail itself


def _noted(trail: BlindTrail, step: Step, *felt: Felt, off_wall: bool = False) -> None:
    trail.note(check_step(step), felt, off_wall)


def test_backing_through_a_bend_backs_past_the_tee_passed_after_it() -> None:
    trail = BlindTrail()
    _noted(trail, Step("bend", direction="up"))
    _noted(trail, Step("t-joint", direction="left"))
    _noted(trail, Step("bend", direction="right"))
    assert trail.behind == ["bend", "tee", "bend"]
    _noted(trail, Step("bend-back", direction="right"))
    assert trail.behind == ["bend", "tee"]
    _noted(trail, Step("bend-back", direction="up"))
    assert trail.behind == []
    with pytest.raises(InvalidStep, match="it has backed past every tee it passed"):
        trail.check(Step("t-joint-back", direction="left"), 1.0)


def test_only_a_forward_straight_stopped_blocked_makes_probe_turn_valid() -> None:
    trail = BlindTrail()
    blocked = Felt("feature", 2.0, how="blocked")
    _noted(trail, Step("straight", distance="-1 m"), blocked)  # backwards: the mouth
    with pytest.raises(InvalidStep, match="not where a straight stopped blocked"):
        trail.check(Step("probe-turn"), 1.0)
    _noted(trail, Step("straight", distance="1 m", stop_at_feature=True), blocked)
    trail.check(Step("probe-turn"), 2.0)
    _noted(trail, Step("probe-turn"), Felt("end", 2.0, how="probe"))
    trail.check(Step("probe-turn"), 2.0)
    _noted(trail, Step("straight", distance="-0.1 m"))
    with pytest.raises(InvalidStep, match="not where a straight stopped blocked"):
        trail.check(Step("probe-turn"), 1.9)


def test_a_backward_straight_over_an_opening_passes_no_tee() -> None:
    trail = BlindTrail()
    _noted(trail, Step("straight", distance="-0.5 m"), off_wall=True)
    assert trail.behind == [] and trail.passed == {}
    _noted(trail, Step("straight", distance="0.5 m"), off_wall=True)
    assert trail.behind == ["tee"]
    trail.check(Step("t-joint-back", direction="straight"), 1.0)
