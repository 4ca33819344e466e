"""The injected clocks."""

from __future__ import annotations

import math

import pytest

from pirate_bt.clock import Clock, SimClock, WallClock


def test_sim_clock_moves_only_when_advanced_and_notifies() -> None:
    clock = SimClock(start_s=10.0)
    seen: list[float] = []
    clock.add_listener(seen.append)
    assert clock.now() == 10.0
    clock.sleep(0.25)
    clock.advance_to(11.0)
    clock.advance_to(5.0)  # in the past: no-op
    assert clock.now() == 11.0
    assert seen == [10.25, 11.0]
    clock.remove_listener(seen.append)
    clock.advance(1.0)
    assert seen == [10.25, 11.0]


def test_sim_clock_never_goes_back() -> None:
    with pytest.raises(ValueError, match="cannot go back"):
        SimClock().advance(-0.1)


def test_both_clocks_satisfy_the_protocol() -> None:
    assert isinstance(SimClock(), Clock)
    assert isinstance(WallClock(), Clock)
    wall = WallClock()
    before = wall.now()
    wall.sleep(0.001)
    assert wall.now() > before
    assert not wall.is_simulated and SimClock().is_simulated


@pytest.mark.parametrize("seconds", [math.nan, math.inf])
def test_a_sim_clock_refuses_a_time_that_is_no_finite_number(seconds: float) -> None:
    # advance(nan) was taken (nan < 0 is false) and the clock read nan for good, so
    # every deadline and timeout of a run on it compared false
    clock = SimClock()
    clock.advance(1.0)
    with pytest.raises(ValueError, match="finite"):
        clock.advance(seconds)
    assert clock.now() == 1.0
