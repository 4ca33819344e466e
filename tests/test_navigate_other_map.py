"""The route navigator given a map its route was not written for.

The map stands in for the route's ``network`` line, as ``pirate-bt mission ROUTE
--network MAP`` lets it; a route of another network (or of none) is planned whole
on the map before anything connects. Before, ``pirate-bt navigate route --map
straight --param route=scenarios/bend-right.route`` started the simulator, drove
the first leg and failed at the bend (exit 1).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.api import navigation
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.task.navigators import RouteNavigator

ROOT = Path(__file__).resolve().parents[1]
BEND_RIGHT = ROOT / "scenarios" / "bend-right.route"
REFUSED = (
    f"navigator 'route': {BEND_RIGHT}:5:1: 'at the bend turn right' does not fit the"
    " network: there is no bend ahead on 'run'; the route is written for the network"
    " 'bend-right', and the map is 'straight'"
)


@pytest.fixture
def connects(monkeypatch: pytest.MonkeyPatch) -> list[object]:
    """Every connection navigate() makes (none, for a navigation refused as input)."""
    made: list[object] = []
    real = navigation.connect

    def counted(target: Any, **kwargs: Any) -> Any:
        made.append(target)
        return real(target, **kwargs)

    monkeypatch.setattr(navigation, "connect", counted)
    return made


def test_the_command_refuses_a_route_of_another_network_before_connecting(
    connects: list[object], capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["navigate", "route", "--map", "straight", "--param", f"route={BEND_RIGHT}"]
    assert main([*args, "-q"]) == 2  # was 1, after the first leg had run
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == f"pirate-bt: {REFUSED}\n"
    assert connects == []


def test_the_api_refuses_it_by_name_and_as_an_instance(connects: list[object]) -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("route", map="straight", params={"route": str(BEND_RIGHT)})
    assert str(caught.value) == REFUSED
    assert caught.value.exit_code == 2
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate(RouteNavigator(BEND_RIGHT), map="straight", sim="bend-right")
    assert str(caught.value) == REFUSED
    assert connects == []


def test_a_route_that_names_no_network_is_planned_on_the_map(
    tmp_path: Path, connects: list[object]
) -> None:
    route = tmp_path / "mine.route"
    route.write_text("forward 1 m\nat the bend turn left\n", encoding="utf-8")
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("route", map="bend-right", params={"route": str(route)})
    assert str(caught.value) == (
        f"navigator 'route': {route}:2:1: 'at the bend turn left' does not fit the network:"
        " the next bend, 'bend', turns right, not left; the route names no network, and"
        " the map is 'bend-right'"
    )
    assert connects == []


def test_a_route_of_another_network_that_fits_the_map_runs(tmp_path: Path) -> None:
    route = tmp_path / "short.route"
    route.write_text("network straight\nforward 0.5 m\n", encoding="utf-8")
    result = pirate_bt.navigate("route", map="bend-right", params={"route": str(route)})
    assert result.status == "success", result.why
    assert result.steps == 1


def test_on_its_own_map_a_leg_is_still_fitted_to_the_turn_as_it_runs(tmp_path: Path) -> None:
    # a mission refuses 'forward 1.3 m' (the bend's approach is at 1.23 m); the route
    # navigator on the route's own map shortens the leg to the approach, as before
    route = tmp_path / "long.route"
    route.write_text(
        "network bend-right\nforward 1.3 m\nat the bend turn right\n", encoding="utf-8"
    )
    result = pirate_bt.navigate(
        "route", map=ROOT / "scenarios" / "bend-right.yaml", params={"route": str(route)}
    )
    assert result.status == "success", result.why


def test_a_route_in_a_deep_folder_keeps_the_map_in_its_line(
    tmp_path: Path, connects: list[object]
) -> None:
    folder = tmp_path / ("deep" * 30)
    folder.mkdir()
    route = folder / "bend-right.route"
    route.write_bytes(BEND_RIGHT.read_bytes())
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("route", map="straight", params={"route": str(route)})
    # was cut at 300 characters: "..., and the map is" and no map
    assert str(caught.value) == REFUSED.replace(str(BEND_RIGHT), str(route))
    assert connects == []
