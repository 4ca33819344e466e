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


S_BEND = """\
schema_version: 1
name: s-bend
diameter: 63 mm
segments:
- {id: before, type: straight, length: 1.5 m}
- {id: b1, type: bend, direction: left}
- {id: mid, type: straight, length: 0.5 m}
- {id: b2, type: bend, direction: right}
- {id: after, type: straight, length: 1.5 m}
"""


def test_a_second_bend_too_close_after_a_bend_is_named_where_the_robot_met_it(
    tmp_path: Path,
) -> None:
    """An S-bend 0.5 m apart stopped the survey with the bend PAB's own words, 'blocked:
    every drive draws stall current after 0.346 m (a turn the robot may not take, or the
    end of the pipe?)', which said neither where nor why the survey stopped."""
    network = tmp_path / "s-bend.yaml"
    network.write_text(S_BEND)
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=str(network), output=out)
    assert not result.succeeded and result.exit_code == 1 and result.navigation.safe_state
    assert result.why.startswith("the robot stopped in bend-1: its front half was blocked 0."), (
        result.why
    )
    where = float(result.why.split("blocked ")[1].split(" m after")[0])
    assert abs(where - 0.5) < 0.05  # the second bend, built 0.5 m after the first
    assert "(a second bend, or the pipe's end)" in result.why
    assert "the survey cannot pass a bend this close after a bend" in result.why
    assert result.unexplored == [
        f"the main line after bend-1: not surveyed past {where:.2f} m after bend-1, where the"
        " front half was blocked as the rear half turned through bend-1: left to a survey by hand"
    ]
    written = pirate_bt.load_network(out)
    assert [(s.id, s.type) for s in written.spec.segments] == [
        ("run-1", "straight"),
        ("bend-1", "bend"),
    ]
    assert "the robot stopped in bend-1" in written.spec.description
