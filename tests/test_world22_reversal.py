"""A drive reversal (forward, then backward) under the wheels' acceleration limit.

Slowing down is never limited (stopping must always be possible), so a reversal stops
the wheels at once and only its speed-up the other way is limited. Until the
twenty-second session a backward command at +80 mm/s sent +60 mm/s, then +40 and +20:
the wheels were told to go on forward, where a stop would have stopped them, and the
``drive`` primitive's own reckoning (``drive_reach``, a stop first) disagreed with it.
"""

from __future__ import annotations

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Drive, Outcome, Reason, Supervisor
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()
TICK = 0.05


def cruising(speed: float) -> tuple[Supervisor, SimClock]:
    """A supervisor whose wheels were ramped to ``speed`` one tick at a time."""
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    sup = Supervisor(port, clock)
    v = 0.0
    while v != speed:
        v = sup.drive_reach(speed)
        assert sup.command(Drive(v)).ok
        clock.advance(TICK)
    return sup, clock


@pytest.mark.parametrize("speed", [0.08, -0.08])
def test_a_reversal_never_sends_the_old_direction(speed: float) -> None:
    sup, clock = cruising(speed)
    sent: list[float] = []
    for _ in range(12):
        v = sup.command(Drive(-speed))
        assert v.ok, v
        sent.append(v.sent[0].value)
        clock.advance(TICK)
    # the first setpoint after the reversal stops the wheels: none goes on the old way
    assert sent[0] == 0.0
    assert all(s * speed <= 0.0 for s in sent), sent
    first = sup.command(Drive(speed))  # and back: stopped at once again
    assert first.sent[0].value == 0.0


def test_a_reversal_clipped_says_so_and_counts_its_speed_up_from_the_old_speed() -> None:
    """At 80 mm/s, a whole window's step is 40 mm/s: -80 is clipped to a stop, and
    once the old speed is within a step of rest, the speed-up starts past it."""
    sup, clock = cruising(0.08)
    clock.advance(ROBOT.safety.rate_window)
    v = sup.command(Drive(-0.08))
    assert v.outcome is Outcome.CLIP and v.reason is Reason.ACCELERATION_LIMIT
    assert "velocity change from 0.08" in v.detail and "clipped to 0" in v.detail
    assert {c.value for c in v.sent} == {0.0}


def test_the_drive_primitive_s_reckoning_is_what_the_limit_passes() -> None:
    """``drive_reach`` (what a ``drive`` node asks for under a refusing limit) and the
    check agree on a reversal: what one offers the other passes unclipped."""
    sup, clock = cruising(0.08)
    for _ in range(8):
        reach = sup.drive_reach(-0.08)
        v = sup.command(Drive(reach))
        assert v.outcome is Outcome.PASS, v
        assert v.sent[0].value == pytest.approx(reach)
        clock.advance(TICK)
    assert sup.drive_reach(-0.08) == pytest.approx(-0.08)
