"""A primitive at work when the supervisor puts the robot in its safe state fails.

The safe state stops the drives and refuses every tree command until an operator
resumes, so the primitive's work cannot go on; its last state may be frozen (a lost
link), and a drive that kept counting its wheels' last speed as distance used to
"succeed" a run whose link had gone (sim killed under ``pirate-bt run --port``).
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

import pirate_bt

STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"
FULL_RUN_TICKS = 300  # the same 1 m run without the fault takes 307 ticks


def test_a_link_lost_while_driving_fails_the_drive_with_the_first_cause(
    caplog: pytest.LogCaptureFixture,
) -> None:
    with caplog.at_level(logging.WARNING, logger="pirate_bt.behaviours"):
        result = pirate_bt.simulate_tree(
            STRAIGHT, params={"distance": "1 m"}, faults="link_loss@5s"
        )
    assert result.status == "failure"
    assert result.safe_state
    assert result.why.startswith("link_silent: nothing heard")  # the first cause, kept
    assert result.ticks < FULL_RUN_TICKS / 2
    failed = [r.getMessage() for r in caplog.records if " failed: " in r.getMessage()]
    assert any(
        m.startswith("drive straight failed: the robot is in its safe state: link_silent")
        for m in failed
    ), failed


def test_without_the_fault_the_same_run_completes() -> None:
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"})
    assert result.succeeded, result.why
    assert result.ticks > FULL_RUN_TICKS
