"""Probe 8 of the protective layer: a mission's why names the first cause, not the slide.

When the clamp board of the half that alone held the robot up the riser went away, the
supervisor stopped on the stale readings; the robot slid back down the bend while the
protective clamp landed, its IMU swung, and the localiser found a turn the map does not
have in the run's last ticks. The mission named that (*belief and map disagree: the
pipe turned by 57 deg at 1.42 m*), a symptom found after the robot was already in its
safe state, instead of the stale readings that stopped it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt

RISER = Path(__file__).parents[1] / "scenarios" / "riser.route"


@pytest.mark.parametrize(
    ("fault", "cause"),
    [
        ("board_reset:22@18.25s", "stale data: bend_1_angle"),
        ("motor_stall:bend_2_joint@18.6s+1s", "steep_pipe_unclamped: no half holds the robot"),
    ],
)
def test_a_disagreement_found_in_the_safe_state_is_not_the_first_cause(
    fault: str, cause: str
) -> None:
    result = pirate_bt.simulate_mission(RISER, faults=fault)
    assert result.why.startswith(cause), result.why  # was: belief and map disagree
    assert result.mismatch is None
    assert result.exit_code == 1 and result.safe_state
    failed = [p for p in result.pabs if p.outcome == "failure"]
    assert [p.why[: len(cause)] for p in failed] == [cause]
