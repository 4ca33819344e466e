"""Probe 19 of the survey mode: networks written from docs/networks.md, surveyed with
``pirate_bt.survey``; what a user sees (the file written, its numbers, the why)."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.pipes import load_network


def _network(tmp_path: Path, name: str, diameter: str, segments: str) -> Path:
    path = tmp_path / f"{name}.yaml"
    path.write_text(
        f"schema_version: 1\nname: {name}\ndiameter: {diameter}\nsegments:\n{segments}",
        encoding="utf-8",
    )
    return path


@pytest.mark.parametrize(("before", "after"), [("55 mm", "70 mm"), ("70 mm", "55 mm")])
def test_a_reducer_in_the_first_straight_keeps_the_pipes_own_diameter(
    tmp_path: Path, before: str, after: str
) -> None:
    # the network's diameter was written as 63 mm (a default) whatever the pipe, when
    # the first straight ended at a cone: a map 8 mm off what the robot clamps in
    truth = _network(
        tmp_path,
        "cone",
        before,
        "  - {id: a, type: straight, length: 1.5 m}\n"
        f"  - {{id: r, type: reducer, diameter: {after}}}\n"
        "  - {id: d, type: straight, length: 1.5 m}\n",
    )
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=str(truth), output=out)
    assert result.succeeded, result.why
    surveyed = load_network(out)
    assert abs(surveyed.main_path().diameter_at(0.1) * 1000 - float(before.split()[0])) < 0.5
    kinds = [s.type for s in surveyed.spec.segments]
    assert kinds == ["straight", "reducer", "straight"]
    assert abs(surveyed.main_path().length_m - 3.05) < 0.05


def test_a_tee_whose_branch_side_cannot_be_told_keeps_the_straight_up_to_it(
    tmp_path: Path,
) -> None:
    # a branch capped 10 cm in: probe-tee fails; the 1.5 m driven up to the tee was
    # surveyed, but the survey said "nothing was surveyed: no file is written"
    truth = _network(
        tmp_path,
        "short-branch",
        "51 mm",
        "  - {id: a, type: straight, length: 1.5 m}\n"
        "  - {id: t, type: tee, branch: {direction: left, segments:"
        " [{type: straight, length: 0.1 m}]}}\n"
        "  - {id: d, type: straight, length: 1 m}\n",
    )
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=str(truth), output=out)
    assert not result.succeeded and result.exit_code == 1 and result.safe_state
    assert "probe-tee" in result.why and "nothing was surveyed" not in result.why
    assert result.unexplored == [
        "the main line after run-1: not surveyed to its end, the survey stopped in it"
    ]
    surveyed = load_network(out)
    assert [s.type for s in surveyed.spec.segments] == ["straight"]
    assert abs(surveyed.main_path().length_m - 1.5) < 0.03


def test_a_tee_too_close_after_another_is_left_a_stub_and_the_other_branch_surveyed(
    tmp_path: Path,
) -> None:
    # two 51 mm tees 0.45 m apart: turning into the second's branch began with the rear
    # half over the first's opening; the survey stopped "no wall: bend_3 swung to 110"
    # and left the first tee's branch unsurveyed too
    truth = _network(
        tmp_path,
        "close-tees",
        "51 mm",
        "  - {id: a, type: straight, length: 1.5 m}\n"
        "  - {id: t1, type: tee, branch: {direction: left, segments:"
        " [{type: straight, length: 1 m}]}}\n"
        "  - {id: m, type: straight, length: 0.45 m}\n"
        "  - {id: t2, type: tee, branch: {direction: right, segments:"
        " [{type: straight, length: 1 m}]}}\n"
        "  - {id: d, type: straight, length: 1 m}\n",
    )
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=str(truth), output=out)
    assert not result.succeeded and result.exit_code == 1, result.why
    assert "no wall" not in result.why and result.counters.violations == 0
    assert result.unexplored == [
        "tee-2's branch (right, 51 mm): not entered, the tee starts 0.45 m after the tee"
        " before it, and a turn into its branch would start with the rear half over that"
        " tee's opening"
    ]
    surveyed = load_network(out)
    tees = [s for s in surveyed.spec.segments if s.type == "tee"]
    assert [len(t.branch.segments) for t in tees] == [1, 0]  # tee-1's branch surveyed
    assert abs(surveyed.path({"tee-1": "branch"}).length_m - 2.657) < 0.03


@pytest.mark.parametrize(
    ("segments", "start", "says"),
    [
        # 0.3 m, then a bend up: the survey wrote 'run-2, 275 mm at 23.9 deg', exit 0
        (
            "  - {id: a, type: straight, length: 0.3 m}\n"
            "  - {id: b, type: bend, direction: up}\n"
            "  - {id: c, type: straight, length: 1 m}\n",
            "",
            "puts it in across the bend 'b'",
        ),
        # 0.4 m of pipe: the survey wrote 515 mm, exit 0
        ("  - {id: a, type: straight, length: 0.4 m}\n", "", "main line of 0.40 m"),
        # put in 1.5 m deep in 3 m of pipe: the survey wrote 2.013 m, exit 0
        (
            "  - {id: a, type: straight, length: 3 m}\n",
            "start: {position: 1.5 m}\n",
            "front tip at 1.50 m (start.position)",
        ),
    ],
    ids=["across-a-bend", "shorter-than-the-robot", "put-in-deep"],
)
def test_a_simulated_pipe_the_robot_is_not_put_in_at_the_mouth_of_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], segments: str, start: str, says: str
) -> None:
    from pirate_bt.cli import main

    truth = tmp_path / "t.yaml"
    truth.write_text(
        f"schema_version: 1\nname: t\ndiameter: 63 mm\n{start}segments:\n{segments}",
        encoding="utf-8",
    )
    out = tmp_path / "surveyed.yaml"
    assert main(["survey", "--sim", str(truth), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pirate-bt: --sim: a survey measures its first straight") and says in err
    assert len(err.splitlines()) == 1 and not out.exists()
