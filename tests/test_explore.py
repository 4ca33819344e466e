"""The ``explore`` navigator: a survey with no map, written as a network file."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt import Step
from pirate_bt.cli import main
from pirate_bt.pipes import PieceKind

ROOT = Path(__file__).resolve().parents[1]


def _pieces(network: pirate_bt.Network) -> list[tuple[str, float, float]]:
    """(kind, length, roll) of every piece along the main line."""
    return [(p.kind.value, p.length_m, p.roll_rad) for p in network.path({}).pieces]


Survey = Callable[[str], tuple[pirate_bt.NavigationResult, Path]]


@pytest.fixture(scope="module")
def explored(tmp_path_factory: pytest.TempPathFactory) -> Survey:
    """``navigate("explore")`` on a bundled network and the file it wrote, run once per
    network for every test here that reads it (nothing changes either)."""
    done: dict[str, tuple[pirate_bt.NavigationResult, Path]] = {}

    def survey(name: str) -> tuple[pirate_bt.NavigationResult, Path]:
        if name not in done:
            out = tmp_path_factory.mktemp(f"explored-{name}") / "surveyed.yaml"
            result = pirate_bt.navigate("explore", sim=name, params={"output": str(out)})
            done[name] = (result, out)
        return done[name]

    return survey


@pytest.mark.parametrize("name", ["bend-right", "riser"])
def test_a_survey_finds_the_pipe_as_it_is(name: str, explored: Survey) -> None:
    result, out = explored(name)
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


def test_a_route_planned_on_the_surveyed_network_runs_on_the_real_one(
    tmp_path: Path, explored: Survey
) -> None:
    result, surveyed = explored("bend-right")
    assert result.succeeded, result.why
    (tmp_path / "surveyed.yaml").write_bytes(surveyed.read_bytes())
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


def _shape(segments: list[Any]) -> list[Any]:
    """A network's lines as nested ``(kind, length or way, [branch])`` tuples."""
    out: list[Any] = []
    for seg in segments:
        if seg.type == "straight":
            out.append(("straight", seg.length))
        elif seg.type == "bend":
            out.append(("bend", seg.direction))
        elif seg.type == "tee":
            out.append(("tee", seg.branch.direction, _shape(seg.branch.segments)))
        else:
            out.append((seg.type,))
    return out


def _same_network(found: list[Any], truth: list[Any]) -> None:
    """Every segment and tee found, none invented; lengths within 2 % or 5 cm."""
    assert [s[0] for s in found] == [s[0] for s in truth], (found, truth)
    for got, real in zip(found, truth, strict=True):
        if got[0] == "straight":
            assert abs(got[1] - real[1]) <= max(0.02 * real[1], 0.05), (got, real)
        elif got[0] == "bend":
            assert got[1] == real[1]
        elif got[0] == "tee":
            assert got[1] == real[1], (got, real)
            _same_network(got[2], real[2])


CHANGES = """\
schema_version: 1
name: changes
diameter: 63 mm
segments:
  - {id: level, type: straight, length: 1.5 m}
  - {id: climb, type: straight, length: 1.6 m, slope: 4 deg}
  - {id: cone, type: reducer, diameter: 55 mm, length: 50 mm}
  - {id: narrow, type: straight, length: 1.4 m, slope: 3.7 deg}
  - {id: narrow-on, type: straight, length: 1.2 m, slope: 3.7 deg}
"""
"""A slope change, a reducer, and a joint of two straights with the same slope (no
change: one straight) inside one run."""


def test_a_survey_ends_straights_where_the_slope_or_the_diameter_changes(
    tmp_path: Path,
) -> None:
    network = tmp_path / "changes.yaml"
    network.write_text(CHANGES)
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim=str(network), output=out)
    assert result.succeeded, result.why
    assert result.navigation.counters.violations == 0
    found = pirate_bt.load_network(out).spec.segments
    truth = pirate_bt.load_network(network).spec.segments
    merged = [*_shape(truth)[:3], ("straight", 2.6)]  # the last two are one straight
    _same_network(_shape(found), merged)
    level, climb, cone, narrow = found
    assert abs(math.degrees(climb.slope - (level.slope or 0.0)) - 4.0) < 0.2
    assert abs(math.degrees(narrow.slope) - 3.7) < 0.2  # written: 0.3 deg off the climb
    assert cone.diameter == pytest.approx(0.055, abs=0.001)
    assert pirate_bt.load_network(out).spec.diameter == pytest.approx(0.063, abs=0.001)


SMALL_TEES = (ROOT / "scenarios" / "service-tees.yaml").read_text()
"""Two 51 mm tees the robot can back out of, one branch with a bend (bundled)."""


def test_a_survey_goes_straight_through_a_tee_then_back_and_into_its_branch(
    tmp_path: Path,
) -> None:
    # the bundled tee is 63 mm: its branch cannot be left backwards, so the survey
    # enters it last, after the main line, and the network is whole
    out = tmp_path / "surveyed.yaml"
    explore = pirate_bt.ExploreNavigator(output=out)
    result = pirate_bt.navigate(explore, sim="t-joint")
    assert result.succeeded, result.why
    assert result.counters.violations == 0 and result.sim.get("damage", 0) == 0
    truth = pirate_bt.load_network("t-joint").spec.segments
    _same_network(_shape(pirate_bt.load_network(out).spec.segments), _shape(truth))
    steps = [d.step.pab for d in result.decisions if d.step is not None]
    assert steps.index("probe-tee") < steps.index("t-joint-back") < len(steps) - 1
    assert explore.unexplored == []


UP_AND_DOWN = (
    SMALL_TEES.replace("direction: right\n      segments:", "direction: up\n      segments:")
    .replace("direction: left\n", "direction: down\n")
    .replace("        - {id: stub-b-bend, type: bend, direction: right, radius: 90 mm}\n", "")
    .replace("        - {id: stub-b-on, type: straight, length: 0.8 m}\n", "")
)
"""The same tees with branches up and down (no bend in them: bends met on a vertical
run are not surveyed yet)."""


@pytest.mark.parametrize(
    ("text", "ways"),
    [
        (SMALL_TEES, ["straight", "left", "straight"]),
        (UP_AND_DOWN, ["straight", "down", "straight"]),
    ],
    ids=["left-right", "up-down"],
)
def test_a_survey_backs_out_of_every_branch_it_fits_and_surveys_them_all(
    tmp_path: Path, text: str, ways: list[str]
) -> None:
    network = tmp_path / "small-tees.yaml"
    network.write_text(text)
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.navigate("explore", sim=str(network), params={"output": str(out)})
    assert result.succeeded, result.why
    assert result.counters.violations == 0 and result.sim.get("damage", 0) == 0
    truth = pirate_bt.load_network(network).spec.segments
    _same_network(_shape(pirate_bt.load_network(out).spec.segments), _shape(truth))
    # tee-b's branch backed out of (tee-a's was pending), tee-a's entered last
    backs = [
        d.step.params.get("direction")
        for d in result.decisions
        if d.step is not None and d.step.pab == "t-joint-back"
    ]
    assert backs == ways


def test_a_branch_the_robot_could_not_leave_is_named_and_written_as_a_stub(
    tmp_path: Path,
) -> None:
    # two 63 mm tees: the robot can enter only one branch, as its last act
    text = SMALL_TEES.replace("51 mm", "63 mm")
    network = tmp_path / "big-tees.yaml"
    network.write_text(text)
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.navigate("explore", sim=str(network), params={"output": str(out)})
    assert not result.succeeded and result.safe_state
    assert "SurveyIncomplete" in result.why and "cannot back out" in result.why
    assert "tee-1's branch (right, 63 mm)" in result.why
    found = _shape(pirate_bt.load_network(out).spec.segments)
    truth = _shape(pirate_bt.load_network(network).spec.segments)
    # the stub stands for the branch not surveyed; everything else is as built
    assert found[1][:2] == ("tee", "right") and found[1][2] == []
    _same_network(found[:1] + found[2:], truth[:1] + truth[2:])
    assert result.counters.violations == 0 and result.sim.get("damage", 0) == 0


def test_explore_is_for_a_pipe_with_no_map() -> None:
    # refused before anything connects (its check_map), exit 2: it connected, and its
    # first decision raised (exit 1)
    with pytest.raises(pirate_bt.InputError, match="explore surveys a pipe with no map"):
        pirate_bt.navigate("explore", sim="straight", map="straight")


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
    with pytest.raises(pirate_bt.InputError, match=r"takes no parameter .speed."):
        pirate_bt.navigate("explore", sim="straight", params={"speed": "1 m/s"})


def test_survey_writes_the_network_and_plans_on_it(tmp_path: Path) -> None:
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(sim="bend-right", output=out, name="found")
    assert result.succeeded and result.exit_code == 0, result.why
    assert result.counts() == {"straight": 2, "bend": 1, "tee": 0, "reducer": 0}
    assert result.output == out and result.unexplored == []
    assert result.network is not None and result.network.name == "found"
    assert "survey: SUCCESS" in result.summary() and "1 bend," in result.summary()
    assert "navigator 'explore'" in result.why  # a built-in given as an object keeps its name
    assert pirate_bt.load_network(out).name == "found"


def test_the_survey_command_writes_the_file_or_says_why_not(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s.yaml"
    cmd = ["survey", "--sim", "straight", "--quiet"]
    assert main([*cmd, "-o", str(out)]) == 0
    done = capsys.readouterr()
    assert "survey: SUCCESS" in done.out and "1 straight," in done.out, done.err
    assert pirate_bt.load_network(out).path({}).pieces[0].length_m > 1.0
    assert main([*cmd, "-o", str(out), "--search", "-1 m"]) == 2
    assert "search must be positive" in capsys.readouterr().err


def test_a_survey_stopped_by_a_failed_step_keeps_what_it_surveyed(tmp_path: Path) -> None:
    # a drive motor stalls in the straight after the bend: the step fails, the robot
    # stops safe, and the straight and the bend before it are written all the same
    out = tmp_path / "surveyed.yaml"
    result = pirate_bt.survey(
        sim="bend-right", output=out, faults="motor_stall:bend_3_drive@60s+60s"
    )
    assert not result.succeeded and result.navigation.safe_state
    assert "stall" in result.why and result.exit_code == 1
    written = pirate_bt.load_network(out)
    kinds = [p.kind.value for p in written.path({}).pieces]
    assert kinds[:2] == ["straight", "bend"]
    assert "stopped:" in written.spec.description
