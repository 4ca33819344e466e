"""Probe 8 of the protective layer: a run hands back a robot held, not one still sliding.

When the half that alone held the robot at the foot of the riser lost its board, the
robot slid back down the bend while the protective clamp of the other half was on its
way. The hold let go of that clamp as soon as the IMU's pitch fell under
``motion.max_unclamped_slope``, and the end of the run, waiting for it, returned on the
very step the slide ended: the simulator's truth said ``sliding``, at 0.2 m/s, with no
half clamped. It waits for the clamp to land now (for at most ``HOLD_SETTLE_S``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.sim import Simulator

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
