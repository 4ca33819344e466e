"""A route into pipe wider than the robot clamps in (its ``clamp.contact_angles`` reach
120 mm on the bundled robot): its wheels never reach the wall there, so no half can
hold or drive it. Until the twenty-second session the plan was made, the leg's drive
stopped as the front joints swung past every wall-contact angle (as over an opening),
and the mission said it had completed: 'forward to the end' into a 130 mm straight
stopped 1.3 m short of the end, exit 0.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import InputError

WIDE = """schema_version: 1
name: wide
diameter: 63 mm
segments:
  - {{id: level, type: straight, length: 1 m}}
  - {{id: w, type: straight, length: 1.5 m, diameter: {wide}, slope: 30 deg}}
"""


def _route(tmp_path: Path, wide: str, *lines: str) -> Path:
    (tmp_path / "wide.yaml").write_text(WIDE.format(wide=wide), encoding="utf-8")
    route = tmp_path / "wide.route"
    route.write_text("network wide.yaml\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return route


def test_a_leg_into_pipe_wider_than_the_robot_clamps_is_refused_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = _route(tmp_path, "130 mm", "forward 0.2 m", "forward to the end")
    with pytest.raises(InputError) as refused:
        pirate_bt.plan_route(route)
    said = str(refused.value)
    assert said.startswith(f"{route}:3:1: 'forward to the end' cannot be planned: 'w'"), said
    assert "is 130 mm wide where the robot would be" in said
    assert "clamps in pipes of at most 120 mm (its clamp.contact_angles)" in said
    assert main(["mission", str(route), "--quiet"]) == 2  # nothing run
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "cannot be planned" in err, err


def test_a_leg_short_of_the_wide_pipe_and_a_pipe_the_robot_clamps_in_are_planned(
    tmp_path: Path,
) -> None:
    plan = pirate_bt.plan_route(_route(tmp_path, "130 mm", "forward 0.2 m"))
    assert len(plan.pabs) == 1
    plan = pirate_bt.plan_route(_route(tmp_path, "120 mm", "forward to the end"))
    assert len(plan.pabs) == 1
