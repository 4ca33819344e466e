"""Probe 14: a run that fails in a riser hands the robot back on both halves.

A bend PAB stopped half-way (the top of a riser turns another way than drawn) leaves
its rear half steered, free, while the front half alone holds the robot up. The
mission, a navigation and the CLI then clamp that half (a deliberate, checked
command) and say so; the first cause stays the result's ``why``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt import Step
from pirate_bt.cli import main
from pirate_bt.pipes import Network, network_from_data
from pirate_bt.robot import Half
from pirate_bt.sim import model as sim_model
from pirate_bt.task.route import parse_route

ROUTE = "at the bend turn up\nat the bend turn left\nforward 0.5 m\n"
NETWORK = """schema_version: 1
name: {name}
diameter: 63 mm
segments:
  - {{id: level, type: straight, length: 1.5 m}}
  - {{id: foot, type: bend, direction: up}}
  - {{id: riser, type: straight, length: 1.5 m}}
  - {{id: top, type: bend, direction: {top}}}
  - {{id: run, type: straight, length: 1.5 m}}
"""


def _riser(top: str) -> Network:
    segments: list[dict[str, Any]] = [
        {"id": "level", "type": "straight", "length": "1.5 m"},
        {"id": "foot", "type": "bend", "direction": "up"},
        {"id": "riser", "type": "straight", "length": "1.5 m"},
        {"id": "top", "type": "bend", "direction": top},
        {"id": "run", "type": "straight", "length": "1.5 m"},
    ]
    return network_from_data({"name": "riser", "diameter": "63 mm", "segments": segments})


@pytest.fixture
def models(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every simulator model made, to read the truth at the end of a run."""
    made: list[Any] = []
    init = sim_model.PipeRobotModel.__init__

    def keep(self: Any, *args: Any, **kwargs: Any) -> None:
        init(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(sim_model.PipeRobotModel, "__init__", keep)
    return made


def _held_on_both_halves(model: Any) -> None:
    truth = model.truth()
    assert abs(truth.slope_rad) > 1.5  # in the riser
    assert truth.halves[Half.FRONT].clamped and truth.halves[Half.REAR].clamped
    assert truth.velocity_mps == 0 and not truth.sliding
    assert model.counters().violation_count == 0 and model.counters().damage_count == 0


def test_a_mission_stopped_at_a_riser_top_leaves_both_halves_clamped(models: list[Any]) -> None:
    route = parse_route(ROUTE, "riser.route")
    result = pirate_bt.simulate_mission(route, network=_riser("left"), truth=_riser("right"))
    assert result.status == "failure" and result.safe_state
    assert result.why.startswith("map disagreement at 3.14 m")  # the first cause, still
    assert "bend 'top'" in result.why
    # was: the rear half left steered and free, the front half alone holding the robot
    _held_on_both_halves(models[-1])
    assert result.replans == [
        "after the stop, the rear half, left free in a steep pipe (pitch 90°), was clamped:"
        " both halves hold"
    ]


def test_a_navigation_stopped_at_a_riser_top_leaves_both_halves_clamped(
    models: list[Any],
) -> None:
    class Steps:
        def __init__(self) -> None:
            self.steps = [Step("bend", direction="up"), Step("bend", direction="left")]

        def next_step(self, obs: pirate_bt.Observation) -> Step | None:
            if obs.last is not None and obs.last.outcome != "success":
                return None
            return self.steps.pop(0) if self.steps else None

    result = pirate_bt.navigate(Steps(), sim=_riser("right"), map=_riser("left"))
    assert result.status == "failure"
    assert result.why.startswith("map disagreement at 3.14 m")
    _held_on_both_halves(models[-1])
    assert result.notes and "the rear half, left free" in result.notes[0]


def test_the_cli_and_the_report_say_what_was_done_after_the_stop(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], models: list[Any]
) -> None:
    (tmp_path / "map.yaml").write_text(NETWORK.format(name="map", top="left"), encoding="utf-8")
    truth = tmp_path / "truth.yaml"
    truth.write_text(NETWORK.format(name="truth", top="right"), encoding="utf-8")
    route = tmp_path / "r.route"
    route.write_text("network map.yaml\n" + ROUTE, encoding="utf-8")
    out = tmp_path / "out"
    code = main(["mission", str(route), "--sim", str(truth), "-q", "--output", str(out)])
    assert code == 1
    err = capsys.readouterr().err
    assert "pirate-bt: after the stop, the rear half, left free in a steep pipe" in err
    assert "FAILED - map disagreement at 3.14 m" in err
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "- **After the stop:** the rear half, left free in a steep pipe" in report
    assert "**Re-planned:**" not in report
    _held_on_both_halves(models[-1])


def test_a_half_that_cannot_clamp_after_the_stop_is_named_with_its_cause(
    models: list[Any],
) -> None:
    wide = network_from_data(
        {
            "name": "wide",
            "diameter": "63 mm",
            "segments": [
                {"id": "level", "type": "straight", "length": "1.5 m"},
                {"id": "foot", "type": "bend", "direction": "up"},
                {"id": "riser", "type": "straight", "length": "1.5 m", "diameter": "150 mm"},
            ],
        }
    )
    route = parse_route("at the bend turn up\nforward 0.5 m\n", "wide.route")
    result = pirate_bt.simulate_mission(route, network=_riser("left"), truth=wide)
    assert result.why.startswith("no wall: bend_1 swung to 110.0°")
    # the rear half still holds; the front half finds no wall in the 150 mm pipe
    assert result.replans == [
        "after the stop, the front half, left free in a steep pipe (pitch 24°), could not be"
        " clamped: no wall: bend_1 swung to 110.0°, past every wall-contact angle (the front"
        " half is over an opening, or the pipe is wider than its clamp.contact_angles?)"
    ]  # was 'could not be clamped: tree failed after 5 ticks'
    truth = models[-1].truth()
    assert truth.halves[Half.REAR].clamped and not truth.sliding
    assert models[-1].counters().violation_count == 0
