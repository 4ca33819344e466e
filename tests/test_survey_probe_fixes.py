"""Survey fixes from a probe of the survey mode: what a user sees (exit code, why, the
file written), each on a small network."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt import Step
from pirate_bt.errors import LinkError

DATA = Path(__file__).parent / "data" / "networks"


class _Straight:
    def next_step(self, obs: pirate_bt.Observation) -> Step | None:
        return Step("straight", distance="1 m") if obs.step < 3 else None


# -- F6: a lost link in a navigation with no map is a link error (exit 3)


def test_a_lost_link_without_a_map_is_a_link_error() -> None:
    result = pirate_bt.navigate(_Straight(), sim="straight", faults="link_loss@5s")
    assert not result.succeeded and result.safe_state
    assert isinstance(result.error, LinkError), result.why
    assert result.exit_code == 3 and "link" in result.why


def test_a_survey_that_loses_the_link_exits_3(tmp_path: Path) -> None:
    out = tmp_path / "s.yaml"
    result = pirate_bt.survey(sim="straight", output=out, faults="link_loss@5s")
    assert not result.succeeded and result.exit_code == 3, result.why
    assert isinstance(result.navigation.error, LinkError)
    # the survey's own result names it too, as every result does (it had no `error`)
    assert result.error is result.navigation.error
    assert result.close_error is result.navigation.close_error


# -- F8: a survey that stops names what it did not survey, in the result and the file


@pytest.fixture(scope="module")
def stopped(tmp_path_factory: pytest.TempPathFactory) -> tuple[pirate_bt.SurveyResult, Path]:
    """A survey of t-joint whose drive stalls in the main line after the tee (the tee's
    branch never entered), and the file it wrote: run once for the two tests that read
    it (the second extends a copy of the file)."""
    out = tmp_path_factory.mktemp("stopped") / "s.yaml"
    result = pirate_bt.survey(sim="t-joint", output=out, faults="motor_stall:bend_3_drive@60s+60s")
    return result, out


def test_a_stopped_survey_names_the_line_cut_short_and_the_branch_not_entered(
    stopped: tuple[pirate_bt.SurveyResult, Path],
) -> None:
    # a drive stalls in the main line after the tee: the tee's branch was never entered
    result, out = stopped
    assert not result.succeeded and result.exit_code == 1 and "stall" in result.why
    assert result.unexplored == [
        "the main line after tee-1: not surveyed to its end, the survey stopped in it",
        "tee-1's branch (left, 63 mm): not entered, the survey stopped first",
    ]
    text = out.read_text()
    header = "".join(line for line in text.splitlines() if line.startswith("#"))
    assert "Not surveyed: the main line after tee-1" in header
    assert "tee-1's branch (left, 63 mm): not entered" in header
    assert "to the end of every line" not in text
    assert "2 not surveyed" in result.summary()
    written = pirate_bt.load_network(out)
    assert "Not surveyed: the main line after tee-1" in written.spec.description


# -- F3: extending a stopped survey keeps what is still unsurveyed, and the stop


def test_extending_a_stopped_survey_keeps_the_line_cut_short(
    tmp_path: Path, stopped: tuple[pirate_bt.SurveyResult, Path]
) -> None:
    first, surveyed = stopped
    out = tmp_path / "s.yaml"
    out.write_bytes(surveyed.read_bytes())
    assert first.exit_code == 1 and len(first.unexplored) == 2
    second = pirate_bt.survey(sim="t-joint", output=out, extend=out)
    # tee-1's branch is surveyed now; the main line after tee-1 is not
    assert not second.succeeded and second.exit_code == 1, second.why
    assert second.unexplored == [
        "the main line after tee-1: not surveyed to its end, the survey stopped in it"
    ]
    assert "the main line after tee-1" in second.why
    text = out.read_text()
    assert "to the end of every line" not in text
    assert "an earlier insertion stopped: stall" in text
    assert "# Not surveyed: the main line after tee-1" in text
    branch = pirate_bt.load_network(out).spec.segments[1]
    assert branch.type == "tee" and [s.type for s in branch.branch.segments] == ["straight"]


# -- F9: a survey says it wrote a file only when it did


def test_a_survey_stopped_in_its_first_straight_writes_it_and_says_so(tmp_path: Path) -> None:
    # the widening is felt as an opening with no branch: the survey stops there, and
    # writes the straight up to it with the line named as not surveyed to its end
    out = tmp_path / "w.yaml"
    result = pirate_bt.survey(sim=str(DATA / "widen.yaml"), output=out)
    assert result.exit_code == 1 and "SurveyIncomplete" in result.why
    assert f"written to {out}" in result.why and result.output == out
    assert result.unexplored == [
        "the main line after run-1: not surveyed to its end, the survey stopped in it"
    ]
    assert "# Not surveyed: the main line after run-1" in out.read_text()
    assert result.counts()["straight"] == 1


def test_a_survey_that_wrote_nothing_does_not_say_it_did(tmp_path: Path) -> None:
    out = tmp_path / "n.yaml"
    explore = pirate_bt.ExploreNavigator(output=out)
    why = str(explore._incomplete("probe-turn ended without an answer"))
    assert not out.exists()
    assert "written to" not in why and "nothing was surveyed: no file is written" in why


def test_a_survey_stopped_inside_its_first_step_says_it_wrote_nothing(tmp_path: Path) -> None:
    # a failed step (here the time limit in the first straight) ends the navigation
    # before the navigator is asked again: it said only the step's failure
    out = tmp_path / "n.yaml"
    result = pirate_bt.survey(sim="straight", output=out, max_time="5 s")
    assert result.exit_code == 1 and not out.exists() and result.output is None
    assert result.why.startswith("navigation time limit reached (5 s) in step 1")
    assert result.why.endswith("; nothing was surveyed: no file is written"), result.why
    assert result.why in result.summary()


# -- F7: a survey never writes a network that does not validate


def test_a_survey_never_writes_a_network_that_does_not_validate(tmp_path: Path) -> None:
    # a straight at 45 degrees after a bend up written as 90: no such pipe
    out = tmp_path / "bad.yaml"
    explore = pirate_bt.ExploreNavigator(output=out)
    explore.segments.extend(
        [
            {"id": "run-1", "type": "straight", "length": "1.000 m"},
            {"id": "bend-1", "type": "bend", "direction": "up"},
            {"id": "run-2", "type": "straight", "length": "1.000 m", "slope": "45.0 deg"},
        ]
    )
    why = str(explore._incomplete("the end", cut=False))
    assert not out.exists() and explore.network is None
    assert "written to" not in why
    assert "does not validate" in why and "run-2" in why and "nothing is written" in why


def test_a_bend_of_45_degrees_up_is_no_traceback_and_no_invalid_file(tmp_path: Path) -> None:
    out = tmp_path / "b.yaml"
    result = pirate_bt.survey(sim=str(DATA / "bend45up.yaml"), output=out)
    assert result.exit_code in (0, 1), result.why
    if out.exists():
        pirate_bt.load_network(out)  # validates
    else:
        assert result.exit_code == 1 and "nothing is written" in result.why


# -- F1: a line's end may be a bend at a roll the survey does not try; it says so


def test_a_line_end_is_written_as_a_cap_or_a_bend_at_a_roll_not_tried(tmp_path: Path) -> None:
    out = tmp_path / "r.yaml"
    result = pirate_bt.survey(sim=str(DATA / "bendroll45.yaml"), output=out)
    assert result.exit_code in (0, 1), result.why
    note = "the line ends here, or turns at a roll the survey does not try"
    assert note in result.why and "the main line after run-1" in result.why
    text = out.read_text()
    assert "to the end of every line" not in text
    assert note in text and "only up, down, left and right" in text


# -- F4: a plumb drop after a sloped run is written plumb


def test_a_plumb_drop_after_a_sloped_run_is_written_plumb(tmp_path: Path) -> None:
    import math

    out = tmp_path / "d.yaml"
    result = pirate_bt.survey(sim=str(DATA / "drop-after-slope.yaml"), output=out)
    assert result.exit_code == 0, result.why
    pieces = pirate_bt.load_network(out).path({}).pieces
    assert [p.kind.value for p in pieces] == ["straight", "bend", "straight"]
    slope = [math.degrees(math.asin(max(-1.0, min(1.0, p.tangent[2])))) for p in pieces]
    assert abs(slope[0] + 2.8) <= 0.2 and abs(slope[2] + 90.0) <= 0.2, slope
    # and pointing on, not back: the drop's horizontal heading is the run's
    run, drop = pieces[0].tangent, pieces[2].tangent
    assert run[0] * drop[0] + run[1] * drop[1] >= -1e-3
