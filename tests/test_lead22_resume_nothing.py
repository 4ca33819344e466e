"""A resume that finds nothing to resume says so: ``pirate-bt campaign SPEC --resume
--output DIR`` with a DIR that does not exist (a typo) ran every case afresh and
exited 0 without a word."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from pirate_bt.campaign.run import run_campaign

SPEC = {
    "name": "r",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.05 m"}}],
    "seeds": {"count": 1},
    "max_time": "60 s",
}


def test_a_resume_in_a_folder_with_no_results_says_every_case_runs(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    out = tmp_path / "typo"
    with caplog.at_level(logging.WARNING, logger="pirate_bt.campaign"):
        result = run_campaign(SPEC, workers=1, output=out, resume=True)
    assert result.counts["success"] == 1
    said = [r.getMessage() for r in caplog.records if r.name == "pirate_bt.campaign"]
    assert f"{out}: nothing to resume (no results.jsonl there): every case runs" in said
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="pirate_bt.campaign"):
        run_campaign(SPEC, workers=1, output=out, resume=True)  # now there is
    assert not [r for r in caplog.records if "nothing to resume" in r.getMessage()]
