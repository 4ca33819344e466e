"""The seventeenth probe of "a result says why" (docs/api.md, docs/missions.md,
docs/observability.md), each test written from what a planner writer or an operator saw.

- ``pirate-bt trace summary`` of a failed run said ``outcome failure`` and nowhere why:
  the end record's reason (the first cause the run printed) was not shown.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

STALL = "motor_stall:bend_1_drive@1s+20s"


@pytest.mark.parametrize(
    ("faults", "why"),
    [
        (STALL, "why       stall: bend_1_drive draws 1.50 A"),
        ("sensor_dropout:bend_1_spring@2s", "why       stale data: bend_1_spring (0.150 s)"),
    ],
)
def test_trace_summary_says_why_the_run_ended(
    faults: str, why: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace = tmp_path / "run.jsonl"
    argv = ["run", "straight", "--param", "distance=1m", "-q", "--trace", str(trace)]
    assert main([*argv, "--faults", faults]) == 1
    printed = capsys.readouterr().err.strip().splitlines()[-1]
    assert main(["trace", "summary", str(trace)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[2] == "outcome   failure"
    assert lines[3].startswith(why), lines[:5]  # the same first cause as the run's line
    assert lines[3][len("why       ") :] in printed
