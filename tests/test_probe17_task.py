"""The seventeenth probe of missions, navigation and surveys (docs/missions.md,
docs/navigators.md), each test written from what a user saw.

A navigation whose map put the robot in across a bend or a T-joint connected, and its
first step was refused (exit 1), where a mission with that start is refused at
planning (exit 2) with nothing connected.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.pipes import Network, network_from_data

SHORT_BEFORE_BEND = Path(__file__).parent / "data" / "networks" / "short-before-bend.yaml"


def _net(*segments: dict[str, Any]) -> Network:
    return network_from_data({"name": "short", "diameter": "63 mm", "segments": list(segments)})


SHORT_THEN_BEND = _net(
    {"id": "a", "type": "straight", "length": "0.3 m"},
    {"id": "b", "type": "bend", "direction": "right"},
    {"id": "c", "type": "straight", "length": "2 m"},
)
TEE_FIRST = _net(
    {"id": "t", "type": "tee", "branch": {"direction": "left", "segments": []}},
    {"id": "c", "type": "straight", "length": "2 m"},
)


@pytest.mark.parametrize(
    ("network", "across"),
    [(SHORT_THEN_BEND, "across the bend 'b' (0.30-0.44 m)"), (TEE_FIRST, "the T-joint 't'")],
)
def test_a_navigation_put_in_across_a_feature_is_refused_before_connecting(
    network: Network, across: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pirate_bt.api.navigation as navigation

    def no_connect(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("connected")

    monkeypatch.setattr(navigation, "connect", no_connect)
    with pytest.raises(InputError) as refused:  # was: a failure after connecting
        pirate_bt.navigate(pirate_bt.GoalNavigator("c"), sim=network, map=network)
    message = str(refused.value)
    assert message.startswith("navigator 'goal' cannot start on the map 'short':")
    assert across in message and "must be put in on straight pipe" in message


def test_the_cli_navigate_exits_2_on_such_a_map(capsys: pytest.CaptureFixture[str]) -> None:
    net = SHORT_BEFORE_BEND
    argv = ["navigate", "goal", "--sim", str(net), "--map", str(net), "--param", "segment=c"]
    assert main(argv) == 2  # was 1, after connecting and a refused first step
    err = capsys.readouterr().err
    assert "across the bend 'b'" in err and len(err.strip().splitlines()) == 1


def test_a_map_with_room_for_the_robot_still_navigates() -> None:
    network = _net(
        {"id": "a", "type": "straight", "length": "1 m"},
        {"id": "b", "type": "bend", "direction": "right"},
        {"id": "c", "type": "straight", "length": "2 m"},
    )
    result = pirate_bt.navigate(pirate_bt.GoalNavigator("c"), sim=network, map=network)
    assert result.status == "success", result.why


def test_a_survey_of_a_drop_writes_its_first_straight_at_its_length(tmp_path: Path) -> None:
    # was 1.813 m for 2 m: the robot slid 0.19 m down the drop as it was put in,
    # before its first clamp, and the odometry never saw it
    network = network_from_data(
        {
            "name": "drop",
            "diameter": "63 mm",
            "slope": "-60 deg",
            "segments": [
                {"id": "a", "type": "straight", "length": "2 m"},
                {"id": "b", "type": "bend", "direction": "right"},
                {"id": "c", "type": "straight", "length": "1 m"},
            ],
        }
    )
    result = pirate_bt.survey(sim=network, output=tmp_path / "drop.yaml")
    assert result.network is not None
    first = result.network.spec.segments[0]
    assert first.type == "straight" and first.length == pytest.approx(2.0, abs=0.02)
    assert result.navigation.counters is not None
    assert not result.navigation.counters.violations


class _Steps:
    def __init__(self, *steps: pirate_bt.Step) -> None:
        self.steps = list(steps)

    def next_step(self, obs: pirate_bt.Observation) -> pirate_bt.Step | None:
        return self.steps.pop(0) if self.steps else None


@pytest.mark.parametrize(
    "step",
    [pirate_bt.Step("straight", distance=4e-5), pirate_bt.Step("wait", time=1e-5)],
)
def test_a_tiny_step_on_a_map_is_not_refused_as_zero(step: pirate_bt.Step) -> None:
    result = pirate_bt.navigate(_Steps(step), sim="straight", map="straight")
    # was: invalid step ... <navigator _Steps>:1:9: forward: '0.0000 m' must be more
    # than zero (a line the navigator never wrote, rounded), though it runs with no map
    assert "must be more than zero" not in result.why
    assert result.status == "success", result.why


def test_a_route_that_never_leaves_the_start_is_refused_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = tmp_path / "home.route"
    route.write_text("network straight\nreturn to start\n", encoding="utf-8")
    assert main(["mission", str(route), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    # was: '<dict>:1:1: needs a list of children' (the empty mission tree), no file named
    assert "<dict>" not in err and len(err.splitlines()) == 1
    assert f"{route}:2:1: 'return to start' plans nothing to do" in err


def test_the_route_navigator_refuses_return_to_start_before_connecting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = tmp_path / "back.route"
    route.write_text("network straight\nforward 1 m\nreturn to start\n", encoding="utf-8")
    argv = ["navigate", "route", "--sim", "straight", "--map", "straight"]
    assert main([*argv, "--param", f"route={route}", "--quiet"]) == 2  # was 1, after 1 m
    err = capsys.readouterr().err.strip()
    assert f"{route}:3:1: 'return to start' is not supported by the route navigator" in err
    assert len(err.splitlines()) == 1
