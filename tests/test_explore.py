"""The ``explore`` navigator: a survey with no map, written as a network file."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import pirate_bt
from pirate_bt import Step
from pirate_bt.pipes import PieceKind

ROOT = Path(__file__).resolve().parents[1]


def _pieces(network: pirate_bt.Network) -> list[tuple[str, float, float]]:
    """(kind, length, roll) of every piece along the main line."""
    return [(p.kind.value, p.length_m, p.roll_rad) for p in network.path({}).pieces]


@pytest.mark.parametrize("name", ["bend-right", "riser"])
def test_a_survey_finds_the_pipe_as_it_is(name: str, tmp_path: Path) -> None:
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.navigate("explore", sim=name, params={"output": str(out)})
    assert result.succeeded, result.why
    assert result.counters.violations == 0 and result.sim.get("damage", 0) == 0
    surveyed = pirate_bt.load_network(out)
    truth = pirate_bt.load_network(name)
    found, real = _pieces(surveyed), _pieces(truth)
    assert [k for k, _, _ in found] == [k for k, _, _ in real]
    for (kind, length, roll), (_, true_length, true_roll) in zip(found, real, strict=True):
        if kind == PieceKind.BEND.value:
            assert math.isclose(roll, true_roll, abs_tol=1e-6)  # the direction found
        assert abs(length - true_length) <= max(0.02 * true_length, 0.05), (kind, length)
    assert surveyed.spec.diameter == pytest.approx(truth.spec.diameter, abs=0.001)


def test_a_route_planned_on_the_surveyed_network_runs_on_the_real_one(tmp_path: Path) -> None:
    out = tmp_path / "surveyed.yaml"
    assert pirate_bt.navigate("explore", sim="bend-right", params={"output": str(out)}).succeeded
    route = tmp_path / "bend.route"
    text = (ROOT / "scenarios" / "bend-right.route").read_text()
    route.write_text(text.replace("network bend-right", "network surveyed.yaml"))
    mission = pirate_bt.simulate_mission(route, truth="bend-right")
    assert mission.succeeded, mission.why


def test_the_end_of_a_straight_pipe_ends_the_survey() -> None:
    result = pirate_bt.navigate("explore", sim="straight")
    assert result.succeeded, result.why
    felt = [f.kind for d in result.decisions for f in d.observation.felt]
    assert felt[-1] == "end"


def test_a_tee_stops_the_survey_safe_with_what_was_surveyed(tmp_path: Path) -> None:
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.navigate("explore", sim="t-joint", params={"output": str(out)})
    assert not result.succeeded and result.safe_state
    assert "navigator 'explore'" in result.why and "T-joint" in result.why
    surveyed = pirate_bt.load_network(out)  # the straight before the tee, as far as felt
    (piece,) = surveyed.path({}).pieces
    assert piece.kind is PieceKind.STRAIGHT and 1.9 < piece.length_m < 2.3
    assert "opening" in surveyed.spec.description


def test_explore_is_for_a_pipe_with_no_map() -> None:
    result = pirate_bt.navigate("explore", sim="straight", map="straight")
    assert not result.succeeded and result.steps == 0
    assert "no map" in result.why


def test_a_probe_with_a_map_is_refused_before_anything_moves() -> None:
    class Probes:
        def next_step(self, obs: pirate_bt.Observation) -> Step | None:
            return Step("probe-turn") if obs.step == 0 else None

    result = pirate_bt.navigate(Probes(), sim="bend-right", map="bend-right")
    assert not result.succeeded and result.steps == 0
    assert "probe-turn is for navigating without one" in result.why


def test_explore_parameters_are_checked() -> None:
    with pytest.raises(pirate_bt.InputError, match="search must be positive"):
        pirate_bt.navigate("explore", sim="straight", params={"search": "-1 m"})
    with pytest.raises(pirate_bt.InputError, match=r"has no|unexpected keyword"):
        pirate_bt.navigate("explore", sim="straight", params={"speed": "1 m/s"})
