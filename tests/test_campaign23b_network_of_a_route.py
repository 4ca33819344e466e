"""Session 23: ``pirate-bt network perturb|remove|add-tee`` given a route says so.

``pirate-bt network perturb lab.route --seed 0`` said *lab.route:6:1: YAML syntax
error: did not find expected <document start>*: the route was read as a network
file. It now says the file is a route, not a pipe network, and which network to give
instead: the one its ``network`` line names. A route whose name does not end in
``.route`` is told by its words, as is one that names no network.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

ROUTE = "# a route\nnetwork bend-right\n\nforward 1 m\nat the bend turn right\n"


def _said(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip().removeprefix("pirate-bt: ")


@pytest.mark.parametrize(
    "action",
    [["perturb", "--seed", "0"], ["remove", "bend"], ["add-tee", "before", "1 m"]],
    ids=["perturb", "remove", "add-tee"],
)
def test_a_route_given_as_the_network_is_named_a_route(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], action: list[str]
) -> None:
    route = tmp_path / "mine.route"
    route.write_text(ROUTE, encoding="utf-8")
    out = tmp_path / "out.yaml"
    said = _said(capsys, ["network", action[0], str(route), *action[1:], "-o", str(out)])
    assert said == (
        f"{route}: a route, not a pipe network: give the network it is written for,"
        " 'bend-right' (its 'network' line), or another network file (.yaml) or bundled name"
    )
    assert not out.exists()


def test_the_bundled_route_is_named_a_route(capsys: pytest.CaptureFixture[str]) -> None:
    said = _said(capsys, ["network", "perturb", "lab.route", "--seed", "0"])
    assert "YAML syntax error" not in said
    assert said.startswith("lab.route: a route, not a pipe network: give the network it is")
    assert "'lab' (its 'network' line)" in said


def test_a_route_of_another_suffix_is_told_by_its_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = tmp_path / "mine.txt"
    route.write_text("forward 1 m\nat the bend turn right\ninspect to the end\n")
    said = _said(capsys, ["network", "perturb", str(route), "--seed", "0"])
    assert said == (
        f"{route}: a route, not a pipe network: give a network file (.yaml) or a bundled"
        " network's name"
    )


def test_a_network_that_is_not_yaml_nor_a_route_is_still_a_syntax_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("segments: [\n")
    assert "YAML syntax error" in _said(capsys, ["network", "perturb", str(bad), "--seed", "0"])
