"""Backing past the pipe's entry with no map: refused as an invalid step, as a planned
route refuses it with one (the simulator holds the robot at the mouth while its wheels
turn, so odometry would count distance never driven)."""

from __future__ import annotations

from typing import Any

import pirate_bt
from pirate_bt import Step


class BackOut:
    """Half a metre in, then ``back`` metres back."""

    def __init__(self, back: str) -> None:
        self.back = back

    def next_step(self, obs: Any) -> Step | None:
        if obs.step == 0:
            return Step("straight", distance="0.5 m")
        if obs.step == 1:
            return Step("straight", distance=self.back)
        return None


def test_backing_past_the_entry_with_no_map_is_an_invalid_step() -> None:
    result = pirate_bt.navigate(BackOut("-3 m"), sim="straight", max_time="120 s")
    assert result.status == "failure"  # was a success, believed at -2.49 m, truly 0 m
    assert "asked for an invalid step" in result.why
    # 0.5 m driven and the wheels' ramp-down after it (counted since the run waits for it)
    assert "can back up at most 0.51 m here: the pipe's entry" in result.why
    assert result.truth_m is not None and abs(result.belief_m - result.truth_m) < 0.05
    assert result.steps == 1


def test_backing_to_the_entry_is_allowed() -> None:
    result = pirate_bt.navigate(BackOut("-0.5 m"), sim="straight", max_time="120 s")
    assert result.succeeded, result.why
    assert result.truth_m is not None and abs(result.truth_m) < 0.05
