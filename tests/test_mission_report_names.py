"""A mission's report draws its route's name as written: a '$' in a route file's name
made matplotlib read it as a formula (a stray '\\frac' ended the run with an internal
error while the report was half written)."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


def test_a_route_named_like_a_formula_gets_its_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    route = tmp_path / "a $\\frac{$ b.route"
    route.write_text("network straight\nforward 0.3 m\n", encoding="utf-8")
    out = tmp_path / "out"
    code = main(["mission", str(route), "--sim", "straight", "--quiet", "--output", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    assert (out / "belief.png").stat().st_size > 0
    assert "$\\frac{$" in (out / "report.md").read_text(encoding="utf-8")


def test_a_network_given_as_a_route_is_named_so_in_one_line(
    capsys: pytest.CaptureFixture[str],
) -> None:
    lab = Path(__file__).resolve().parents[1] / "scenarios" / "lab.yaml"
    assert main(["mission", str(lab), "--sim", "lab"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        f"{lab}:1:1: a YAML file, not a route: a route is lines of steps"
        " ('network lab', then 'forward 1 m', ...; docs/routes.md); a network"
        " file goes to --network or --sim (navigate: --map)"
    )
    assert len(err.splitlines()) == 1
