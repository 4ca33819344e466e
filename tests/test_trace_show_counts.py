"""``pirate-bt trace show --state`` prints the simulator's counts as the whole numbers
they are (the trace records every counter as a JSON number, ``5.0``), and quantities
in a unit as recorded."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def test_sim_counts_are_whole_numbers_and_quantities_stay_as_recorded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace = tmp_path / "run.jsonl"
    argv = ["run", "straight", "--param", "distance=0.5 m", "--quiet"]
    assert main([*argv, "--trace", str(trace)]) == 0
    capsys.readouterr()
    assert main(["trace", "show", str(trace), "--state"]) == 0
    out = capsys.readouterr().out
    sim = out.split("\nsim:\n", 1)[1].split("\nblackboard:", 1)[0].splitlines()
    shown = dict(line.strip().split(" = ", 1) for line in sim if line.startswith("  "))
    assert shown["violations"] == "0" and shown["watchdog_trips"] == "0"
    assert shown["frames_dropped"] == "0"
    assert "." in shown["distance_m"], shown  # a quantity, printed as recorded
