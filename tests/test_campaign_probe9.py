"""Campaign findings of a probe on 2026-11-29: a link rate written true, two campaigns
writing into one folder at once, and the report's counters."""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.campaign.paths import LOCK_NAME
from pirate_bt.cli import main
from pirate_bt.errors import InputError

SPEC = {
    "name": "tiny",
    "runs": [{"name": "s", "tree": "straight", "params": {"distance": "0.05 m"}}],
    "seeds": {"count": 2},
}


@pytest.mark.parametrize("written", ["true", "yes", "on"])
def test_a_link_rate_written_true_is_refused_not_taken_as_every_frame_lost(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], written: str
) -> None:
    spec = tmp_path / "b.campaign.yaml"
    spec.write_text(f"name: b\nruns:\n  - {{tree: straight}}\nlink: {{drop: [{written}]}}\n")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err == f"{spec}:4:15: drop: should be a rate from 0 to 1, not true\n", err


def test_a_folder_another_campaign_is_writing_in_is_refused(tmp_path: Path) -> None:
    # two started together both passed the 'holds N lines already' check; one's rows
    # were lost without a word
    out = tmp_path / "out"
    out.mkdir()
    held = os.open(out / LOCK_NAME, os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)  # another campaign, running
        with pytest.raises(InputError, match="another campaign is writing there now"):
            pirate_bt.run_campaign(SPEC, output=out, workers=1)
        assert not (out / "results.jsonl").exists()
    finally:
        os.close(held)
    result = pirate_bt.run_campaign(SPEC, output=out, workers=1)  # released: it runs
    assert result.counts["success"] == 2


def test_the_report_sums_e_stops_with_every_other_counter(tmp_path: Path) -> None:
    result = pirate_bt.run_campaign(SPEC, output=tmp_path / "o", workers=1)
    assert "| e-stops |" in (result.output / "report.md").read_text()  # type: ignore[operator]


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_a_device_named_as_a_robot_is_called_what_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "z.campaign.yaml"
    spec.write_text("name: z\nruns:\n  - {tree: straight}\nrobots: [/dev/zero]\n")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err  # it said 'no such file'
    assert "robot '/dev/zero': /dev/zero is not a regular file (a device or a pipe)" in err, err
