"""A second insertion: ``survey(extend=...)`` surveys a branch the first survey left as a stub."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import InputError
from tests.test_explore import SMALL_TEES, _same_network, _shape

BIG_TEES = SMALL_TEES.replace("51 mm", "63 mm")
"""Two 63 mm tees: one insertion enters only one branch (it cannot back out of them)."""


@pytest.fixture(scope="module")
def first(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The network as built, and a first survey of it with one branch left as a stub."""
    folder = tmp_path_factory.mktemp("big-tees")
    network = folder / "big-tees.yaml"
    network.write_text(BIG_TEES)
    out = folder / "surveyed.yaml"
    result = pirate_bt.survey(sim=str(network), output=out)
    assert not result.succeeded and len(result.unexplored) == 1, result.why
    assert "tee-1's branch (right, 63 mm)" in result.unexplored[0]
    return network, out


def test_a_second_insertion_surveys_the_stub_and_the_network_is_whole(
    first: tuple[Path, Path], tmp_path: Path
) -> None:
    network, surveyed = first
    out = tmp_path / "whole.yaml"
    result = pirate_bt.survey(sim=str(network), extend=surveyed, output=out)
    assert result.succeeded and result.exit_code == 0, result.why
    assert result.unexplored == []
    assert result.navigation.counters.violations == 0 and result.navigation.sim["damage"] == 0
    found = pirate_bt.load_network(out)
    _same_network(
        _shape(found.spec.segments), _shape(pirate_bt.load_network(network).spec.segments)
    )
    assert "tee-1's branch by a second insertion" in found.spec.description
    # the first survey's segments are kept as they were; new ids follow on from its own
    before = pirate_bt.load_network(surveyed).spec.segments
    assert [s.id for s in found.spec.segments] == [s.id for s in before]
    ids = [s.id for s in found.spec.segments[1].branch.segments]
    assert ids and not set(ids) & {s.id for s in before}
    # it went straight into the stub's branch: tee-2 and its branch were not driven again
    steps = [d.step.pab for d in result.navigation.decisions if d.step is not None]
    assert "t-joint-back" not in steps and steps.count("probe-tee") == 1


def test_the_same_file_may_be_extended_in_place(first: tuple[Path, Path], tmp_path: Path) -> None:
    network, surveyed = first
    copy = tmp_path / "surveyed.yaml"
    copy.write_text(surveyed.read_text())
    cmd = [sys.executable, "-m", "pirate_bt", "survey", "--sim", str(network), "--quiet"]
    done = subprocess.run(
        [*cmd, "--extend", str(copy), "-o", str(copy)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "survey: SUCCESS" in done.stdout
    assert pirate_bt.load_network(copy).spec.segments[1].branch.segments


def test_a_pipe_that_is_not_as_surveyed_stops_the_second_insertion_at_the_tee(
    first: tuple[Path, Path], tmp_path: Path
) -> None:
    network, surveyed = first
    wrong = tmp_path / "wrong.yaml"
    text = surveyed.read_text()
    assert "direction: right" in text
    wrong.write_text(text.replace("direction: right", "direction: up", 1))
    result = pirate_bt.survey(sim=str(network), extend=wrong, output=wrong)
    assert not result.succeeded and result.navigation.safe_state
    assert "the pipe is not as surveyed" in result.why and "leaves right" in result.why
    assert "the survey has up" in result.why
    # nothing surveyed is lost: the file still holds the first survey
    assert len(pirate_bt.load_network(wrong).spec.segments) == len(
        pirate_bt.load_network(surveyed).spec.segments
    )


def test_a_network_with_no_stub_has_nothing_to_extend(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="nothing to extend"):
        pirate_bt.survey(sim="straight", extend="straight", output=tmp_path / "s.yaml")


def test_a_survey_out_of_time_stops_safe_and_keeps_what_it_surveyed(tmp_path: Path) -> None:
    out = tmp_path / "s.yaml"
    result = pirate_bt.survey(sim="lab", output=out, max_time="150 s")
    assert not result.succeeded and result.navigation.safe_state
    assert result.why.startswith("navigation time limit reached (150 s) in step"), result.why
    assert result.exit_code == 1
    written = pirate_bt.load_network(out)
    assert written.spec.segments[0].type == "straight"  # the entry run, surveyed in time
    assert "stopped:" in written.spec.description


def test_a_second_insertion_turns_into_a_branch_written_as_a_roll(tmp_path: Path) -> None:
    """The first survey of an as-built lab (``network perturb lab --seed 2 --scale 2``,
    surveyed with seed 2) wrote tee-1's branch as a roll (the frame twisted by more than
    5°), not a direction. The second insertion then asked for ``Step('t-joint',
    direction='None')`` and was refused: the tee on the way forgot the side the IMU
    found (found by a survey sweep, probe 10)."""
    data = Path(__file__).parent / "data" / "networks" / "twisted-tee"
    first = data / "lab-s2-x2-first-survey.yaml"
    branch = pirate_bt.load_network(first).spec.segments
    assert any(getattr(s, "branch", None) and s.branch.direction is None for s in branch)
    out = tmp_path / "whole.yaml"
    result = pirate_bt.survey(sim=str(data / "lab-s2-x2.yaml"), seed=2, extend=first, output=out)
    assert result.succeeded and result.exit_code == 0, result.why
    assert result.unexplored == []
    assert result.navigation.counters.violations == 0
    assert "tee-1's branch by a second insertion" in pirate_bt.load_network(out).spec.description
