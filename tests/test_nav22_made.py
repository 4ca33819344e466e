"""Session 22: a navigator that refuses its parameters as it is made (an InputError: a
route file not found, a segment given empty) is a refusal of those parameters, one line
naming the parameter and the file, exit 2, at the command line, in Python and in a
campaign; not "navigator 'route' raised ValidationFailed as it was made: ... (at
pirate_bt/task/route.py:545)", the words for a navigator's own bug (docs/navigators.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import InputError, LocatedError, SourceLocation, ValidationFailed
from pirate_bt.task import navigators


def test_a_route_file_not_found_is_a_refusal_of_the_route_parameter(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    command = ["navigate", "route", "--map", "lab", "--sim", "lab", "--param"]
    assert main([*command, "route=missing.route"]) == 2
    assert capsys.readouterr().err == (
        "pirate-bt: navigator 'route', parameter 'route': missing.route:1:1: no such file\n"
    )


def test_a_campaign_s_route_file_not_found_is_said_at_its_parameter(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    spec = tmp_path / "m.campaign.yaml"
    spec.write_text(
        "name: m\nruns:\n"
        "  - {name: r, navigator: route, network: lab, params: {route: missing.route}}\n"
    )
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.endswith(
        "run 'r': navigator 'route', parameter 'route': missing.route:1:1: no such file\n"
    )
    assert "raised" not in err


def test_a_route_file_s_problems_are_one_line_naming_the_parameter(tmp_path: Path) -> None:
    route = tmp_path / "bad.route"
    route.write_text("network lab\nforwrd 1 m\nfoo\n")
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("route", params={"route": str(route)}, map="lab")
    assert str(caught.value) == (
        f"navigator 'route', parameter 'route': {route}:2:1: unknown command 'forwrd';"
        " did you mean 'forward'? (and 1 more problem there)"
    )


class _Picky:
    """A plug-in that refuses its parameter as docs/navigators.md says to: an InputError."""

    def __init__(self, speed: str, spare: str = "") -> None:
        if speed == "fast":
            raise InputError(f"speed: {speed!r} is too fast; give 'slow'")
        raise ValidationFailed(
            [
                LocatedError("not a number", SourceLocation("<params>", 1, 1)),
                LocatedError("not slow", SourceLocation("<params>", 1, 5)),
            ]
        )

    def next_step(self, obs: object) -> None:  # pragma: no cover - never made
        return None


@pytest.mark.parametrize(
    ("params", "said"),
    [
        (
            {"speed": "fast"},
            "navigator 'picky', parameter 'speed': 'fast' is too fast; give 'slow'",
        ),
        (
            {"speed": "s7"},
            "navigator 'picky', parameter 'speed': <params>:1:1: not a number"
            " (and 1 more problem there)",
        ),
        (
            {"speed": "s7", "spare": "q9"},
            "navigator 'picky': <params>:1:1: not a number (and 1 more problem there)",
        ),
    ],
    ids=["its-words-name-it", "only-one-given", "cannot-be-told"],
)
def test_a_plug_in_s_input_error_as_it_is_made_is_a_refusal_of_its_parameters(
    monkeypatch: pytest.MonkeyPatch, params: dict[str, str], said: str
) -> None:
    monkeypatch.setitem(navigators._BUILT_IN, "picky", _Picky)
    with pytest.raises(InputError) as caught:
        pirate_bt.navigate("picky", params=params, sim="straight")
    assert str(caught.value) == said


def test_a_refusal_that_names_its_navigator_and_parameter_says_each_once() -> None:
    with pytest.raises(InputError) as caught:
        pirate_bt.load_navigator("explore", {"search": "-1 m"})
    assert str(caught.value) == (
        "navigator 'explore', parameter 'search': search must be positive and at most 1000 m,"
        " not '-1 m'"
    )
