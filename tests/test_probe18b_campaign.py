"""Probe 18b: campaigns of navigators and surveys.

- a ``route`` navigator whose route names another network than the run's map passed
  ``validate`` and failed at its first turn in every case: refused at the run;
- a navigator parameter left to its default and a run naming that default were two
  groups of identical cases: the second run is refused as a repeat;
- explore's ``extend`` file was not among the inputs ``--resume`` checks: a changed
  one was resumed silently;
- ``results.csv`` wrote text cells starting with ``=``, ``+``, ``-``, ``@`` raw, which
  a spreadsheet runs as formulas.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import campaign_from_data
from pirate_bt.campaign.checks import check_axes
from pirate_bt.cli import main
from pirate_bt.errors import InputError

ROOT = Path(__file__).resolve().parents[1]


def _validate(tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text(text, encoding="utf-8")
    code = main(["validate", str(spec)])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, captured.err.strip()


# --- 1. a route navigator on a map its route does not name ----------------------------


def test_a_route_navigator_whose_route_names_another_network_is_refused_at_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (
        "name: c\n"
        "runs:\n"
        "  - {name: r, navigator: route, network: lab, params: {route: t-joint.route}}\n"
    )
    code, err = _validate(tmp_path, text, capsys)
    # was: "c.campaign.yaml: ok", and every case failed at its first turn
    assert code == 2
    assert err.startswith(f"{tmp_path / 'c.campaign.yaml'}:3:33: run 'r': the route")
    assert "names network 't-joint'" in err and "not 'lab'" in err and "\n" not in err


def test_a_route_navigator_left_on_the_default_map_names_the_default(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "name: c\nruns:\n  - {name: r, navigator: route, params: {route: t-joint.route}}\n"
    code, err = _validate(tmp_path, text, capsys)
    assert code == 2
    assert ":3:15: run 'r': the route" in err
    assert "not 'straight' (the default)" in err


def test_a_route_navigator_on_its_own_network_by_any_name_still_validates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lab = ROOT / "scenarios" / "lab.yaml"
    text = (
        "name: c\n"
        "runs:\n"
        "  - {name: a, navigator: route, network: t-joint, params: {route: t-joint.route}}\n"
        f"  - {{name: b, navigator: route, network: {lab}, params: {{route: lab.route}}}}\n"
        "as_built: {count: 2}\n"
    )
    assert _validate(tmp_path, text, capsys) == (0, "")


# --- 2. a navigator's parameter left to its default, and named -------------------------


def test_a_navigator_run_naming_its_default_repeats_the_run_leaving_it_out() -> None:
    def spec(search: str) -> Any:
        return campaign_from_data(
            {
                "name": "c",
                "runs": [
                    {"name": "a", "navigator": "explore", "network": "t-joint", "blind": True},
                    {
                        "name": "b",
                        "navigator": "explore",
                        "network": "t-joint",
                        "blind": True,
                        "params": {"search": search},
                    },
                ],
            }
        )

    for same in ("3 m", "300 cm", "3m"):
        with pytest.raises(InputError, match=r"runs\[1\] repeats runs\[0\] \('a'\)"):
            check_axes(spec(same))
    check_axes(spec("2 m"))  # another value is another point
