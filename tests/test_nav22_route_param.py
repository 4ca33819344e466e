"""Session 22: the ``route`` navigator's ``route`` parameter finds a route as
``simulate_mission`` and ``plan_route`` do: ``"bend-right"`` is the bundled
``scenarios/bend-right.route``, not the network ``bend-right.yaml`` beside it (it was
refused, *a YAML file, not a route*) (docs/navigators.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.errors import InputError


@pytest.mark.parametrize("name", ["bend-right", "lab", "lab.route", "t-joint"])
def test_the_route_parameter_names_the_route_simulate_mission_would_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str
) -> None:
    monkeypatch.chdir(tmp_path)  # nothing of that name here: the bundled one
    navigator = pirate_bt.load_navigator("route", {"route": name})
    assert navigator.route == pirate_bt.load_route(name)  # type: ignore[attr-defined]
    assert navigator.route.source.endswith(".route")  # type: ignore[attr-defined]


def test_a_route_of_a_bundled_name_runs_on_its_map(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    result = pirate_bt.navigate("route", params={"route": "bend-right"}, map="bend-right")
    assert result.succeeded, result.why
    assert result.steps == len(pirate_bt.load_route("bend-right").steps)  # one each


def test_a_file_of_that_name_here_is_the_one_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bend-right").write_text("network straight\nforward 1 m\n")
    navigator = pirate_bt.load_navigator("route", {"route": "bend-right"})
    assert navigator.route.network == "straight"  # type: ignore[attr-defined]
    with pytest.raises(InputError, match="a YAML file, not a route"):
        pirate_bt.load_navigator("route", {"route": "bend-right.yaml"})
