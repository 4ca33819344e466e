"""Probe 8 of the protective layer: a run hands back a robot held, not one still sliding.

When the half that alone held the robot at the foot of the riser lost its board, the
robot slid back down the bend while the protective clamp of the other half was on its
way. The hold let go of that clamp as soon as the IMU's pitch fell under
``motion.max_unclamped_slope``, and the end of the run, waiting for it, returned on the
very step the slide ended: the simulator's truth said ``sliding``, at 0.2 m/s, with no
half clamped. It waits for the clamp to land now (for at most ``HOLD_SETTLE_S``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Reason, Supervisor
from pirate_bt.safety.supervisor_hold import half_channels
from pirate_bt.safety.testing import FakePort
from pirate_bt.sim import Simulator

ROBOT = load_robot()

ROOT = Path(__file__).parents[1]


@pytest.mark.parametrize("fault", ["board_reset:22@17.2s", "board_reset:23@16s"])
def test_a_slide_ended_at_the_foot_of_the_riser_is_handed_back_held(
    fault: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[Any] = []
    close = Simulator.close

    def closing(self: Simulator) -> None:
        if not seen:
            seen.append(self.truth())
        close(self)

    monkeypatch.setattr(Simulator, "close", closing)
    result = pirate_bt.simulate_mission(ROOT / "scenarios" / "riser.route", faults=fault)
    assert result.why.startswith("stale data: bend_"), result.why
    assert result.exit_code == 1 and result.safe_state
    truth = seen[0]
    # was: sliding at 0.2 m/s, neither half clamped, on the step the slide ended
    assert not truth.sliding and truth.velocity_mps == 0.0
    assert truth.halves["rear"].clamped
    assert result.sim["violations"] == 1  # the slide itself (docs/safety.md, Known limits)


def _hold_clamps(sup: Supervisor) -> list[str]:
    return [
        v.detail
        for v in sup.verdicts
        if v.reason is Reason.STEEP_PIPE_UNCLAMPED and v.detail.startswith("protective clamp")
    ]


def test_a_robot_that_slid_to_the_foot_between_two_ticks_is_clamped() -> None:
    # The half that alone held the robot in the riser lost its board and the robot slid
    # to the foot of the bend between two ticks: on the next tick the IMU read under the
    # unclamped limit and nothing held. The hold looked at the pitch only, sent no clamp,
    # and the end of the run handed back a robot on the step its slide ended (seen when
    # the link's readings came 40 ms later: tests/test_probe15_wire.py).
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.FRONT)
    port.set_pitch(math.radians(30))
    sup = Supervisor(port, clock)
    sup.tick()
    assert not _hold_clamps(sup) and not sup.holding  # the front half holds
    port.freeze(*half_channels(ROBOT)[Half.FRONT])
    port.set_pitch(math.radians(9.9))  # the foot of the bend, under the 10° limit
    clock.advance(0.2)  # the front half's readings stale: it holds no more, as seen
    sup.tick()
    said = "protective clamp: steep_pipe_unclamped: no half holds the robot in a steep pipe"
    assert _hold_clamps(sup) == [
        f"{said} (pitch 10°): the supervisor clamps the front half",  # as in the steep pipe
        f"{said} (pitch 10°): the supervisor clamps the rear half",
    ]
    assert sup.holding and port.sent  # the end of a run waits for it (settle_hold)


def test_a_level_robot_set_free_is_not_clamped() -> None:
    # the other side: nothing steep on the last tick, nothing held: no clamp
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.FRONT)
    port.set_pitch(math.radians(5))
    sup = Supervisor(port, clock)
    sup.tick()
    port.free_half(Half.FRONT)
    clock.advance(0.05)
    sup.tick()
    assert not _hold_clamps(sup) and not sup.holding
