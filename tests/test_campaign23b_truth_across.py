"""Session 23: a simulated truth that puts the robot in across a bend or tee is refused.

The map side refuses a map whose first straight is shorter than the robot (*'forward
1 m' cannot be planned: the robot (0.52 m long) is put in ... across the bend ...*),
but a *truth* of that shape (``mission ROUTE --sim TRUTH --network MAP``, a campaign's
``maps``) was taken: the robot was put in across the bend and the run failed with *belief
and map disagree: the pipe blocked the robot at 0.59 m ...*, a reason about the map,
not the truth. The simulator now refuses such a network up front, in one line naming
it and the straight it needs; a start position given by the caller (``start_m``) is
the caller's to choose, as before.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import ConfigurationError
from pirate_bt.pipes import load_network
from pirate_bt.sim.simulator import Simulator

SHORT = (
    "schema_version: 1\nname: short-truth\ndiameter: 63 mm\nsegments:\n"
    "  - {id: before, type: straight, length: 0.3 m}\n"
    "  - {id: bend, type: bend, direction: right, radius: 90 mm}\n"
    "  - {id: after, type: straight, length: 2 m}\n"
)
TEE_FIRST = (
    "schema_version: 1\nname: tee-truth\ndiameter: 63 mm\nsegments:\n"
    "  - {id: t, type: tee, branch: {direction: left, segments: []}}\n"
    "  - {id: after, type: straight, length: 2 m}\n"
)


def test_a_truth_across_a_bend_is_refused_naming_it_and_the_length_needed(
    tmp_path: Path,
) -> None:
    truth = tmp_path / "truth.yaml"
    truth.write_text(SHORT, encoding="utf-8")
    with pytest.raises(ConfigurationError) as refused:
        Simulator(truth)
    said = str(refused.value)
    assert "\n" not in said
    assert said.startswith(f"network 'short-truth' ({truth}): the robot (0.52 m long) is put in")
    assert "across the bend 'bend' (0.30-0.44 m)" in said
    assert "a straight at least 0.52 m long before its first bend or T-joint" in said


def test_a_truth_beginning_with_a_tee_is_refused(tmp_path: Path) -> None:
    truth = tmp_path / "tee.yaml"
    truth.write_text(TEE_FIRST, encoding="utf-8")
    with pytest.raises(ConfigurationError, match=r"across the T-joint 't'"):
        Simulator(truth)


def test_a_mission_on_a_good_map_in_such_a_truth_exits_2_before_it_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    truth = tmp_path / "truth.yaml"
    truth.write_text(SHORT, encoding="utf-8")
    argv = ["mission", "bend-right.route", "--sim", str(truth), "--quiet"]
    assert main(argv) == 2  # it ran, and failed on 'belief and map disagree' (exit 1)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "network 'short-truth'" in err and "across the bend 'bend'" in err
    assert "belief and map disagree" not in err


def test_a_start_the_caller_gives_and_a_straight_long_enough_are_taken(tmp_path: Path) -> None:
    truth = tmp_path / "truth.yaml"
    truth.write_text(SHORT, encoding="utf-8")
    with Simulator(truth, start_m=1.5) as sim:  # the whole robot past the bend
        assert sim.truth() is not None
    with Simulator(load_network("bend-right")) as sim:
        assert sim.network.name == "bend-right"
    assert pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}).succeeded


def test_a_campaign_s_truth_across_a_bend_is_refused_at_its_maps_entry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "truth.yaml").write_text(SHORT, encoding="utf-8")
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text(
        "name: c\nruns:\n  - {route: bend-right.route}\nmaps:\n  - null\n  - truth.yaml\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    # each case was a row failed on 'belief and map disagree'; now no case runs
    assert main(["campaign", str(spec), "--quiet", "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"pirate-bt: {spec}:6:5: run 'bend-right': network 'short-truth' (")
    assert "across the bend 'bend'" in err
    assert not out.exists()
