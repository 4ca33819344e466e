"""A bend of less than 90 degrees is surveyed with the turn the IMU measured, and the
straight after it with its length.

- Up or down: the pitch either side of the bend.
- Left or right: was written as 90 (the observation had the IMU's pitch but no heading),
  and the straight after it came out short by the arcs' difference (0.951 m for 1 m at
  60 degrees); now the heading and pitch either side of the bend, to 1 degree.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

import pirate_bt

DATA = Path(__file__).parent / "data" / "networks"


def _far_end(network: pirate_bt.Network) -> tuple[float, float, float]:
    path = network.path({})
    x, y, z = path.position_at(path.length_m)
    return float(x), float(y), float(z)


@pytest.mark.parametrize(
    ("name", "direction", "degrees", "after_m", "exit_codes"),
    [
        ("survey-bend-45-up", "up", 45.0, 1.2, (0,)),
        ("survey-bend-30-down", "down", 30.0, 1.2, (0,)),
        # left and right: was 0.951 m after a 60-degree bend written as 90; the line's
        # end after it may be a note (exit 1)
        ("survey-bend-60-right", "right", 60.0, 1.0, (0, 1)),
        ("survey-bend-45-left", "left", 45.0, 1.0, (0, 1)),
    ],
)
def test_a_bend_of_less_than_90_degrees_is_written_with_the_turn_measured(
    tmp_path: Path,
    name: str,
    direction: str,
    degrees: float,
    after_m: float,
    exit_codes: tuple[int, ...],
) -> None:
    truth_file = DATA / f"{name}.yaml"
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=truth_file, output=out)
    assert result.exit_code in exit_codes, result.why
    written = pirate_bt.load_network(out)
    bends = [s for s in written.spec.segments if s.type == "bend"]
    assert len(bends) == 1 and bends[0].direction == direction
    assert math.degrees(bends[0].angle) == pytest.approx(degrees, abs=1.0)
    # no slope written on the straight after: the bend carries it in
    after = written.spec.segments[-1]
    assert after.type == "straight" and after.slope is None
    assert after.length == pytest.approx(after_m, abs=0.02)
    truth = pirate_bt.load_network(truth_file)
    assert math.dist(_far_end(written), _far_end(truth)) < 0.03


@pytest.mark.parametrize("network", ["bend-right", "bend-left"])
def test_a_90_degree_bend_is_written_as_before(tmp_path: Path, network: str) -> None:
    out = tmp_path / "surveyed.yaml"
    assert pirate_bt.survey(sim=network, output=out).succeeded
    segments = yaml.safe_load(out.read_text())["segments"]
    bends = [s for s in segments if s["type"] == "bend"]
    assert len(bends) == 1 and "angle" not in bends[0]


def test_the_survey_backs_through_a_45_degree_bend_up_to_a_tee_branch(tmp_path: Path) -> None:
    truth_file = DATA / "survey-tee-bend-45-up.yaml"
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=truth_file, output=out)
    assert result.succeeded, result.why
    segments = yaml.safe_load(out.read_text())["segments"]
    assert [s["type"] for s in segments] == ["straight", "tee", "straight", "bend", "straight"]
    assert segments[3]["angle"].startswith("45")
    truth, written = pirate_bt.load_network(truth_file), pirate_bt.load_network(out)
    for way in ({}, {"t1": "branch"}):
        found_way = {"tee-1": "branch"} if way else {}
        t, f = truth.path(way), written.path(found_way)  # type: ignore[arg-type]
        assert math.dist(t.position_at(t.length_m), f.position_at(f.length_m)) < 0.03
