"""What a survey writes of bends it cannot simply call 90 degrees up or down.

- A bend left or right of less than 90 degrees was written as 90 (the observation had
  the IMU's pitch but no heading), and the straight after it came out short by the
  arcs' difference; it is written with the turn the IMU measured (its heading and
  pitch either side of the bend, to 1 degree), and the straight with its length.
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


# -- bends left and right of less than 90 degrees ----------------------------------------


@pytest.mark.parametrize(
    ("name", "direction", "degrees"),
    [("survey-bend-60-right", "right", 60.0), ("survey-bend-45-left", "left", 45.0)],
)
def test_a_bend_left_or_right_of_less_than_90_degrees_is_written_as_measured(
    tmp_path: Path, name: str, direction: str, degrees: float
) -> None:
    truth_file = DATA / f"{name}.yaml"
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=truth_file, output=out)
    assert result.exit_code in (0, 1), result.why  # the line's end: see the next part
    written = pirate_bt.load_network(out)
    bends = [s for s in written.spec.segments if s.type == "bend"]
    assert len(bends) == 1 and bends[0].direction == direction
    assert math.degrees(bends[0].angle) == pytest.approx(degrees, abs=1.0)
    after = written.spec.segments[-1]
    assert after.type == "straight" and after.slope is None
    assert after.length == pytest.approx(1.0, abs=0.02)  # was 0.951 m at 60 degrees
    truth = pirate_bt.load_network(truth_file)
    assert math.dist(_far_end(written), _far_end(truth)) < 0.03


def test_a_90_degree_bend_left_or_right_is_written_as_before(tmp_path: Path) -> None:
    out = tmp_path / "surveyed.yaml"
    assert pirate_bt.survey(sim="bend-left", output=out).succeeded
    segments = yaml.safe_load(out.read_text())["segments"]
    bends = [s for s in segments if s["type"] == "bend"]
    assert len(bends) == 1 and "angle" not in bends[0]
