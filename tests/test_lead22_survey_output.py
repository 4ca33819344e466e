"""Where a survey is written, checked before the robot moves, and a write that fails
at the end said as the survey's own cause (before 2026-12-01, ``pirate-bt navigate
explore --sim lab --param output=/proc/nonexist/x.yaml`` surveyed 42 steps and then
failed with *navigator 'explore' raised FileNotFoundError*, the survey lost)."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import InputError


def test_an_output_whose_folder_is_a_file_is_refused_before_anything_moves(
    tmp_path: Path,
) -> None:
    (tmp_path / "plain").write_text("x", encoding="utf-8")
    with pytest.raises(InputError, match=r"explore: output: .*plain is not a directory"):
        pirate_bt.ExploreNavigator(output=tmp_path / "plain" / "found.yaml")
    with pytest.raises(InputError, match=r"parameter 'output': .*plain is not a directory"):
        pirate_bt.navigate(
            "explore", sim="straight", params={"output": str(tmp_path / "plain" / "x.yaml")}
        )


def test_a_survey_that_cannot_be_written_says_so_as_its_cause() -> None:
    # /proc refuses a new folder even to root: the write fails at the survey's end
    out = Path("/proc/pirate-bt-no-such-folder/found.yaml")
    if not Path("/proc").is_dir():  # pragma: no cover - Linux has it
        pytest.skip("no /proc")
    result = pirate_bt.navigate("explore", sim="straight", params={"output": str(out)})
    assert not result.succeeded
    assert f"the survey could not be written to {out}" in str(result.why)
    assert "raised FileNotFoundError" not in str(result.why)
