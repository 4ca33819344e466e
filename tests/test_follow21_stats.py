"""Session 21, a campaign's statistics: a group whose seeds feed nothing (no link fault
rate above 0, no sensor noise) runs one run for every seed; its rows are one sample,
not many, and the report, validate and the run say so. docs/campaigns.md (The report)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign.report import write_report
from pirate_bt.campaign.stats import group_stats, wilson_interval
from pirate_bt.cli import main

NOTE = (
    "the seeds repeat one run: run 'straight' draws nothing random (no link fault rate"
    " above 0, and the simulator has no sensor noise), so its 4 seeds give 4 identical"
    " runs; the report counts 1 distinct run, not 4 samples: give 'seeds: {count: 1}',"
    " or a link fault rate above 0"
)


def _spec(tmp_path: Path, link: str = "") -> Path:
    spec = tmp_path / "s.campaign.yaml"
    spec.write_text(
        "name: s\nruns:\n  - {name: straight, tree: straight, params: {distance: 0.1 m}}\n"
        f"{link}seeds: {{count: 4}}\nmax_time: 60 s\n"
    )
    return spec


def _row(index: int, seed: int, outcome: str = "success", **extra: Any) -> dict[str, Any]:
    row = {"index": index, "run": "r", "seed": seed, "outcome": outcome, "sim_time_s": 4.2}
    return row | {"drop": 0.0, "corrupt": 0.0, "dup": 0.0} | extra


def test_a_run_every_seed_repeats_is_reported_as_deterministic(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _spec(tmp_path)
    with caplog.at_level(logging.WARNING, logger="pirate_bt.campaign"):
        assert main(["validate", str(spec)]) == 0
    assert [r.getMessage() for r in caplog.records if r.name == "pirate_bt.campaign"] == [NOTE]
    caplog.clear()
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING, logger="pirate_bt.campaign"):
        assert main(["campaign", str(spec), "--output", str(out), "-q", "--workers", "1"]) == 0
    assert NOTE in [r.getMessage() for r in caplog.records]
    line = next(x for x in (out / "report.md").read_text().splitlines() if "straight" in x)
    # was '| straight drop=0 corrupt=0 dup=0 | 4 | 100.0 % | 51.0–100.0 % | ...'
    assert line.startswith(
        "| straight drop=0 corrupt=0 dup=0 | 4 | 100.0 % | deterministic: 1 distinct run of 4 |"
    )
    assert "deterministic: 1 distinct run of 4" in (out / "report.html").read_text()


def test_a_run_whose_seeds_draw_link_faults_keeps_its_interval(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    spec = _spec(tmp_path, "link: {dup: [0.01]}\n")
    with caplog.at_level(logging.WARNING, logger="pirate_bt.campaign"):
        assert main(["validate", str(spec)]) == 0
    assert not [r for r in caplog.records if r.name == "pirate_bt.campaign"]
    rows = [_row(i, i, dup=0.01) for i in range(4)]
    (group,) = group_stats(rows)
    assert (group.distinct_runs, group.deterministic) == (4, False)
    assert group.interval == wilson_interval(4, 4)
    write_report(rows, tmp_path / "r")
    low, high = wilson_interval(4, 4)
    assert f"| 4 | 100.0 % | {100 * low:.1f}–{100 * high:.1f} % |" in (
        (tmp_path / "r" / "report.md").read_text()
    )


def test_seeds_that_repeat_each_as_built_variant_count_each_variant_once(
    tmp_path: Path,
) -> None:
    # 3 variants x 5 seeds, no link fault: 3 samples (two succeed), not 15
    rows = [
        _row(5 * v + s, s, "success" if v < 2 else "failed-safe", as_built=v)
        for v in range(3)
        for s in range(5)
    ]
    (group,) = group_stats(rows)
    assert (group.n, group.distinct_runs, group.deterministic) == (15, 3, False)
    assert group.interval == wilson_interval(2, 3)
    write_report(rows, tmp_path / "r")
    low, high = wilson_interval(2, 3)
    table = (tmp_path / "r" / "report.md").read_text()
    assert f"| 15 | 66.7 % | {100 * low:.1f}–{100 * high:.1f} % (3 distinct runs of 15) |" in table


def test_rows_of_one_run_that_disagree_are_said_to(tmp_path: Path) -> None:
    # one case timed out (a wall-time limit under load): the same run, another outcome
    rows = [_row(i, i) for i in range(3)] + [_row(3, 3, "timeout")]
    write_report(rows, tmp_path / "r")
    assert (
        "| 4 | 75.0 % | deterministic: 1 distinct run of 4, its rows disagree (wall time or a"
        " crash) |"
    ) in (tmp_path / "r" / "report.md").read_text()
