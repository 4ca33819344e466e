"""The twentieth probe of the world the simulator runs (docs/simulator.md,
docs/networks.md): vertical pipes, falls, and a world that differs from the map, each
test written from what a user saw.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.pipes import load_network
from pirate_bt.sim import Simulator
from pirate_bt.sim.script import ModelSink, ScriptedDrive

NARROW = """name: narrow
diameter: 63 mm
segments:
  - {id: a, type: straight, length: 2 m}
  - {id: b, type: bend, direction: up}
  - {id: c, type: straight, length: 1 m}
  - {id: r, type: reducer, diameter: 45 mm}
  - {id: e, type: straight, length: 1.5 m}
"""

NARROW_BRANCH = """name: narrow-branch
diameter: 63 mm
segments:
  - {id: a, type: straight, length: 2 m}
  - type: tee
    branch:
      direction: left
      segments:
        - {type: straight, length: 1 m}
        - {type: reducer, diameter: 50 mm}
  - {id: e, type: straight, length: 1.5 m}
"""


def test_a_pipe_too_narrow_for_the_robot_is_refused_at_its_diameter_in_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was: "pipe network 'narrow': segment 'r' is 45 mm wide, ..." with no file, line
    # or column, from the simulator, `pirate-bt sim` and `pirate-bt mission --sim`
    narrow = tmp_path / "narrow.yaml"
    narrow.write_text(NARROW, encoding="utf-8")
    with pytest.raises(ConfigurationError) as refused:
        Simulator(narrow)
    assert str(refused.value) == (
        f"{narrow}:7:28: pipe network 'narrow': segment 'r' is 45 mm wide, but the robot"
        " fits only in pipes of 51 mm and more (its clamp.contact_angles)"
    )
    branch = tmp_path / "branch.yaml"
    branch.write_text(NARROW_BRANCH, encoding="utf-8")
    assert main(["sim", str(branch), "--duration", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        f"{branch}:10:27: pipe network 'narrow-branch': segment 'main-2-b-2' is 50 mm wide,"
        " but the robot fits only in pipes of 51 mm and more (its clamp.contact_angles)"
    ), err
    assert len(err.splitlines()) == 1
    start = tmp_path / "start.yaml"
    start.write_text(NARROW.replace("63 mm", "45 mm"), encoding="utf-8")
    with pytest.raises(ConfigurationError, match=rf"^{start}:2:1: pipe network 'narrow': the"):
        Simulator(start)


STEEP = """name: steep
diameter: 63 mm
segments:
  - {id: a, type: straight, length: 2 m}
  - {id: c, type: straight, length: 2 m, slope: 88 deg}
  - {id: e, type: straight, length: 1 m}
"""


def test_every_variant_of_a_run_just_short_of_plumb_is_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was: seed 2 laid 'c' at 90 deg (88 deg tilted past plumb, held there), and 'e',
    # which keeps 88 deg, was a slope set on a vertical run: exit 2, "segment 'e':
    # cannot set a slope on a vertical run; use a bend", a segment nobody had sloped
    drawn = tmp_path / "steep.yaml"
    drawn.write_text(STEEP, encoding="utf-8")
    for seed in range(8):
        out = tmp_path / f"v{seed}.yaml"
        assert main(["network", "perturb", str(drawn), "--seed", str(seed), "-o", str(out)]) == 0
        capsys.readouterr()
        variant = load_network(out).main_path()
        for segment in ("c", "e"):
            piece = next(p for p in variant.pieces if p.segment == segment)
            slope = math.degrees(variant.slope_at((piece.start_m + piece.end_m) / 2))
            assert 85.0 - 1e-6 <= slope < 90.0, (seed, segment, slope)  # never past plumb


@pytest.mark.parametrize(
    ("kwargs", "said"),
    [
        ({"stop_before_end_m": "0.1 m"}, "stop_before_end_m: give a number of metres, not"),
        ({"stop_before_end_m": math.nan}, "stop_before_end_m: nan is not a finite number"),
        ({"stop_before_end_m": -1.0}, "stop_before_end_m: -1.0 is not a number of metres of"),
        ({"progress": "log"}, "progress: give a function of a segment's name, or None, not"),
    ],
)
def test_a_scripted_drive_refuses_a_bad_run_path_argument_before_anything_moves(
    kwargs: dict[str, object], said: str
) -> None:
    # was: "0.1 m" drove the whole riser, then raised TypeError 'unsupported operand';
    # nan was refused as front_m after the drive; progress="log" raised "'str' object
    # is not callable" at the foot of the riser, the robot in its bend
    with Simulator("riser") as sim:
        drive = ScriptedDrive(sim, ModelSink(sim))
        with pytest.raises(InputError) as refused:
            drive.run_path(**kwargs)  # type: ignore[arg-type]
        assert str(refused.value).startswith(said), str(refused.value)
        assert sim.counters().distance_m == 0.0 and sim.counters().commands_executed == 0


RISER_TOP = """name: rb
diameter: 63 mm
segments:
  - {id: a, type: straight, length: 2 m}
  - {id: b, type: bend, direction: up}
  - {id: c, type: straight, length: 2 m}
  - {id: e, type: bend, direction: left}
  - {id: f, type: straight, length: 2 m, slope: 5 deg}
"""


def test_removing_a_riser_s_top_bend_says_which_edit_cannot_be_built(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was: "pirate-bt: segment 'f': cannot set a slope on a vertical run; use a bend",
    # naming a segment the command was not given and not the edit that made it so
    drawn = tmp_path / "rb.yaml"
    drawn.write_text(RISER_TOP, encoding="utf-8")
    out = tmp_path / "no-e.yaml"
    assert main(["network", "remove", str(drawn), "e", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "pirate-bt: the network without e cannot be built: segment 'f': cannot set a slope"
        " on a vertical run; use a bend"
    ), err
    assert not out.exists()
