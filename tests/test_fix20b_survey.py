"""Survey messages and hand-edited surveys (the twentieth session's survey fixes)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import InputError

STUB_AT_A_ROLL = """\
schema_version: 1
name: surveyed
diameter: 63 mm
segments:
- {{id: run-1, type: straight, length: 1.5 m}}
- id: tee-1
  type: tee
  branch: {{roll: {roll}, segments: []}}
- {{id: run-2, type: straight, length: 1.5 m}}
"""


@pytest.mark.parametrize("roll", ["-45 deg", "45 deg", "30 deg", "-135 deg"])
def test_a_stub_at_a_roll_the_survey_cannot_take_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, roll: str
) -> None:
    """A hand-edited stub's branch at roll -45 deg was read by extend as 'up' (the
    nearest of the four within 45 deg), and the robot went to turn up into it."""
    monkeypatch.chdir(tmp_path)
    Path("surveyed.yaml").write_text(STUB_AT_A_ROLL.format(roll=roll))
    with pytest.raises(InputError) as caught:
        pirate_bt.survey(sim="t-joint", extend="surveyed.yaml", output=tmp_path / "out.yaml")
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith("extend: 'surveyed.yaml' (network 'surveyed'): ")
    assert "tee-1's branch leaves at roll" in message
    assert "none of up, down, left or right" in message
    assert not (tmp_path / "out.yaml").exists()


def test_a_stub_at_a_roll_the_survey_cannot_take_exits_2_in_one_line(tmp_path: Path) -> None:
    surveyed = tmp_path / "surveyed.yaml"
    surveyed.write_text(STUB_AT_A_ROLL.format(roll="-45 deg"))
    cmd = [sys.executable, "-m", "pirate_bt", "survey", "--sim", "t-joint", "-q"]
    done = subprocess.run(
        [*cmd, "--extend", str(surveyed), "-o", str(tmp_path / "out.yaml")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pirate-bt: --extend: "), done.stderr
    assert "tee-1's branch leaves at roll -45.0 deg" in lines[0]


@pytest.mark.parametrize(("roll", "side"), [("-90 deg", "left"), ("93 deg", "right")])
def test_a_stub_at_a_roll_near_one_of_the_four_names_that_side(
    tmp_path: Path, roll: str, side: str
) -> None:
    from pirate_bt.task.explore_extend import load_extension

    surveyed = tmp_path / "surveyed.yaml"
    surveyed.write_text(STUB_AT_A_ROLL.format(roll=roll))
    assert load_extension(surveyed).sides == [side]
