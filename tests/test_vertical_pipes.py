"""Vertical pipes (slopes of ±90°), pipes shorter than the map says, pipes too wide.

In a riser only the clamps hold the robot up: the supervisor never lets the last
clamped half go there, every stop keeps the clamps, the simulator's falling rule
fires the moment both halves are free (tried by going around the supervisor), and a
mission up a riser that ends sooner than drawn stops safe naming the difference.
A network the robot cannot clamp in, or cannot start in, is refused with one line.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import ConfigurationError, ValidationFailed
from pirate_bt.pipes import Network, load_network, network_from_data
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.safety import Clamp, Drive, MoveFrontClear, Supervisor, Unclamp
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.sim import PipeRobotModel
from pirate_bt.task.route import parse_route

ROBOT = load_robot()
TICK_S = 0.1


def _net(name: str, segments: list[dict[str, Any]], **top: Any) -> Network:
    return network_from_data({"name": name, "diameter": "63 mm", "segments": segments, **top})


def _straight(segment: str, length: str) -> dict[str, Any]:
    return {"id": segment, "type": "straight", "length": length}


def _bend(segment: str, direction: str) -> dict[str, Any]:
    return {"id": segment, "type": "bend", "direction": direction}


def _riser(length: str) -> Network:
    return _net(
        "riser", [_straight("level", "1.5 m"), _bend("foot", "up"), _straight("riser", length)]
    )


# -- a mission up a riser that ends sooner than the map has it ---------------------------


def test_a_riser_capped_sooner_than_drawn_stops_the_mission_naming_it() -> None:
    route = parse_route("at the bend turn up\nforward 1.8 m\n", "capped")
    result = pirate_bt.simulate_mission(route, network=_riser("3 m"), truth=_riser("1.2 m"))
    # was: success ("mission completed: 3 PABs"): the last leg stopped blocked at the cap
    # 0.9 m short, and only a leg followed by another was checked for that
    assert result.status == "failure"
    assert result.why.startswith("belief and map disagree: the pipe blocked the robot at 2.")
    assert "where the map has no turn and no end within" in result.why
    assert result.pabs[-1].outcome == "stopped" and result.pabs[-1].why == result.why
    assert result.safe_state
    assert result.counters.violations == 0 and result.counters.damage == 0


def test_a_level_pipe_that_ends_sooner_than_drawn_is_no_success() -> None:
    drawn, built = (_net("p", [_straight("a", length)]) for length in ("3 m", "1.6 m"))
    route = parse_route("forward to the end\n", "end")
    result = pirate_bt.simulate_mission(route, network=drawn, truth=built)
    assert result.status == "failure" and "the pipe blocked the robot at 1.6" in result.why
    assert result.safe_state


# -- the network file -------------------------------------------------------------------


def test_a_start_beyond_the_end_of_the_main_line_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "beyond.yaml"
    path.write_text(
        "schema_version: 1\nname: beyond\ndiameter: 63 mm\nstart: {position: 100 m}\n"
        "segments:\n  - {type: straight, length: 1 m}\n  - {type: bend, direction: up}\n",
        encoding="utf-8",
    )
    # was: valid, and the simulator put the robot at the end of the pipe without a word
    with pytest.raises(ValidationFailed) as info:
        load_network(path)
    assert str(info.value) == (
        f"{path}:4:9: the start position 100 m is beyond the end of the main line (1.141 m)"
    )


def test_a_pipe_the_robot_does_not_fit_is_refused_by_the_simulator() -> None:
    # was: the wall-contact angle was held at the table's ends, and the straight PAB
    # (and a whole mission) succeeded in a 40 mm pipe
    tee = {
        "id": "tee",
        "type": "tee",
        "branch": {
            "direction": "left",
            "segments": [{"id": "service", "type": "reducer", "diameter": "45 mm"}],
        },
    }
    for network, words in (
        (_net("narrow", [_straight("a", "2 m")], diameter="45 mm"), "the start of its main"),
        (_net("narrow-branch", [_straight("a", "1 m"), tee]), "segment 'service' is 45 mm wide"),
    ):
        with pytest.raises(ConfigurationError, match=words + ".* fits only in pipes of 51 mm"):
            PipeRobotModel(ROBOT, network)


def test_in_a_pipe_wider_than_the_robot_clamps_in_a_clamp_finds_no_wall(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was: the contact angle was held at 120 mm's, so the robot clamped (and a whole
    # mission succeeded) in a 200 mm main; now the wheels never reach the wall there
    path = tmp_path / "wide.yaml"
    path.write_text(
        "schema_version: 1\nname: wide\ndiameter: 63 mm\nstart: {position: 1.9 m}\n"
        "segments:\n"
        "  - {id: a, type: straight, length: 1 m}\n"
        "  - {id: b, type: straight, length: 2 m, diameter: 150 mm}\n",
        encoding="utf-8",
    )
    argv = ["run", "straight", "--param", "distance=0.2 m", "--sim", str(path), "--quiet"]
    assert main(argv) == 1  # the PAB failed, the robot in its safe state
    err = capsys.readouterr().err
    assert "straight: FAILURE - no wall: bend_" in err
    assert "past every wall-contact angle" in err and "wider than its clamp.contact_angles" in err


# -- the guards and the falling rule in a vertical pipe ----------------------------------


def _tick(sup: Supervisor, clock: SimClock, seconds: float) -> None:
    for _ in range(round(seconds / TICK_S)):
        clock.advance(TICK_S)
        sup.tick()


def _clamped_in(network: Network) -> tuple[Supervisor, SimClock]:
    """The robot 1.5 m up (or down) a vertical pipe, both halves clamped, rear first."""
    clock = SimClock()
    sup = open_supervisor(ROBOT, clock=clock, network=network)
    assert sup.command(Clamp(Half.REAR, 0.7)).ok
    _tick(sup, clock, 1.5)
    for _ in range(30):  # re-sent every tick, as a primitive does
        assert sup.command(MoveFrontClear(1)).ok
        _tick(sup, clock, TICK_S)
    assert sup.command(Clamp(Half.FRONT, 0.7)).ok
    _tick(sup, clock, 1.5)
    assert {s.value for s in sup.half_states().values()} == {"clamped"}
    return sup, clock


def _shaft(slope: str) -> Network:
    return _net("shaft", [_straight("shaft", "3 m")], slope=slope, start={"position": "1.5 m"})


def _violations(sup: Supervisor) -> tuple[int, int]:
    """Slides and other violations the simulator judged so far."""
    assert sup.simulator is not None
    kinds = dict(sup.simulator.model.counters().violations)
    slides = kinds.pop("sliding", 0)
    return slides, sum(kinds.values())


@pytest.mark.parametrize(("slope", "way"), [("90 deg", -1.0), ("-90 deg", 1.0)])
def test_the_last_clamped_half_is_never_released_and_the_fall_is_judged(
    slope: str, way: float
) -> None:
    sup, clock = _clamped_in(_shaft(slope))
    try:
        assert sup.simulator is not None
        model = sup.simulator.model
        assert math.degrees(abs(model.truth().slope_rad)) == pytest.approx(90.0)
        # Put in free, the robot slid while its rear half clamped: from here, no more.
        before, others = _violations(sup)
        assert others == 0
        assert sup.command(Unclamp(Half.REAR)).ok  # the front half holds
        _tick(sup, clock, 1.5)
        verdict = sup.command(Unclamp(Half.FRONT))
        assert not verdict.ok and "would leave no half clamped in a steep pipe" in verdict.detail
        assert not sup.command(Drive(0.05)).ok or model.truth().halves[Half.FRONT].clamped
        # Every stop keeps the clamps: silence past the bridge's watchdog, then e-stop.
        clock.advance(3 * ROBOT.bridge.watchdog)
        sup.simulator.advance_to(clock.now())  # the bridge runs, the host says nothing
        assert sup.simulator.bridge.watchdog_tripped
        assert model.truth().halves[Half.FRONT].clamped
        sup.estop("test")
        _tick(sup, clock, 1.0)
        assert sup.simulator.bridge.estopped
        assert model.truth().halves[Half.FRONT].clamped
        assert _violations(sup) == (before, 0)
        # Around the supervisor (what it refused): the front joints let go, and the
        # simulator judges the fall at once.
        at = model.truth().front_m
        for module in ROBOT.bend_modules(Half.FRONT):
            motor = ROBOT.joint_motor(module.name).name
            model.command(MotorCommand(motor, ControlMode.POSITION, 0.0))
        model.step(1.0)
        assert _violations(sup) == (before + 1, 0)
        assert (model.truth().front_m - at) * way > 0.05  # it slid down the pipe
    finally:
        sup.close()


def test_a_mission_up_a_riser_and_down_a_drop_never_lets_go() -> None:
    network = _net(
        "up-and-down",
        [
            _straight("level", "1.5 m"),
            _bend("foot", "up"),
            _straight("riser", "1.2 m"),
            _bend("top", "down"),
            _straight("crest", "1.2 m"),
            _bend("lip", "down"),
            _straight("drop", "1.5 m"),
        ],
    )
    route = "at the bend turn up\nat the bend turn down\nat the bend turn down\nforward 0.3 m\n"
    result = pirate_bt.simulate_mission(parse_route(route, "up-and-down"), network=network)
    assert result.status == "success", result.why
    assert result.counters.violations == 0 and result.counters.damage == 0
    assert result.counters.refusals == 0


@pytest.mark.parametrize(
    ("segment", "where", "words"),
    [
        # a bend tighter than the pipe itself: the robot passed it as any other
        ("{type: bend, direction: up, radius: 20 mm}", "7:33", "a turn of radius 20 mm in a 63"),
        (
            "{type: tee, branch: {direction: left, radius: 10 mm}}",
            "7:43",
            "a turn of radius 10 mm in a 63",
        ),
        # was placed at the 'segments' key (4:1), not at the slope
        ("{type: straight, length: 1 m, slope: 10 deg}", "7:35", "cannot set a slope on a"),
    ],
)
def test_impossible_geometry_is_placed_at_its_key(
    tmp_path: Path, segment: str, where: str, words: str
) -> None:
    path = tmp_path / "g.yaml"
    path.write_text(
        "schema_version: 1\nname: g\ndiameter: 63 mm\nsegments:\n"
        "  - {type: straight, length: 1 m}\n  - {type: bend, direction: up}\n"
        f"  - {segment}\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as info:
        load_network(path)
    assert str(info.value).startswith(f"{path}:{where}: segment 'main-3': {words}")


def test_network_commands_refuse_an_output_they_cannot_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "blocker"
    blocker.write_text("mine\n", encoding="utf-8")
    # were internal errors (exit 1): IsADirectoryError, FileExistsError
    # (since 2026-11-30 -o is checked as every command's output is, before the work)
    for output, words in (
        (tmp_path, f"'{tmp_path}' is a folder; name a file"),
        (blocker / "x.yaml", f"'{blocker}' is not a folder (on the way to 'x.yaml')"),
    ):
        assert main(["network", "perturb", "riser", "--seed", "1", "-o", str(output)]) == 2
        err = capsys.readouterr().err
        assert err == f"pirate-bt: -o: {words}\n"
    assert blocker.read_text(encoding="utf-8") == "mine\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]
    # a scale of 1e308 wrote a variant with slopes of ±inf deg
    argv = ["network", "perturb", "riser", "--seed", "1", "--scale", "1e308"]
    assert main([*argv, "-o", str(tmp_path / "v.yaml")]) == 2
    assert capsys.readouterr().err == "pirate-bt: --scale must be a positive number, at most 10\n"


def test_an_id_that_is_another_segments_generated_name_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "names.yaml"
    path.write_text(
        "schema_version: 1\nname: names\ndiameter: 63 mm\nsegments:\n"
        "  - {id: main-2, type: straight, length: 1 m}\n"
        "  - {type: straight, length: 1 m}\n",
        encoding="utf-8",
    )
    # was valid: two segments named 'main-2', one of them unreachable by its name
    with pytest.raises(ValidationFailed) as info:
        load_network(path)
    assert str(info.value) == (
        f"{path}:5:6: segment id 'main-2' is also the name of a segment without an id"
        " (segments[1]): give that one an id, or this one another"
    )
