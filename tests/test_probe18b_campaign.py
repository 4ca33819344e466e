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

import csv
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import campaign_from_data, run_campaign
from pirate_bt.campaign.cases import expand
from pirate_bt.campaign.checks import check_axes, check_runs
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from tests.hostile_support import InstantExecutor

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
    # (since 2026-11-30 the route navigator's own check_map: a route of another network
    # is planned whole on the map, and refused when it does not fit)
    assert err.startswith(f"{tmp_path / 'c.campaign.yaml'}:3:33: run 'r': navigator 'route'")
    assert "written for the network 't-joint'" in err and "the map is 'lab'" in err
    assert "\n" not in err


def test_a_route_navigator_left_on_the_default_map_names_the_default(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "name: c\nruns:\n  - {name: r, navigator: route, params: {route: t-joint.route}}\n"
    code, err = _validate(tmp_path, text, capsys)
    assert code == 2
    assert ":3:15: run 'r': navigator 'route'" in err
    assert "the map is 'straight'" in err


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


# --- 3. explore's extend file, for --resume --------------------------------------------


def _stub(path: Path) -> None:
    text = (ROOT / "scenarios" / "t-joint.yaml").read_text(encoding="utf-8")
    text = text.replace(
        "      segments:\n        - {id: branch, type: straight, length: 2 m}\n",
        "      segments: []\n",
    )
    assert "segments: []" in text
    path.write_text(text, encoding="utf-8")


def test_explores_extend_file_is_an_input_resume_checks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    _stub(tmp_path / "first.yaml")
    spec = {
        "name": "c",
        "runs": [
            {
                "name": "second",
                "navigator": "explore",
                "network": "t-joint",
                "blind": True,
                "params": {"extend": "first.yaml"},
            }
        ],
        "seeds": {"start": 0, "count": 2},
    }
    read = check_runs(expand(campaign_from_data(spec)))
    assert tmp_path / "first.yaml" in read
    out = tmp_path / "out"
    run_campaign(spec, output=out, executor=InstantExecutor())
    results = out / "results.jsonl"
    results.write_bytes(results.read_bytes().splitlines(keepends=True)[0])
    with (tmp_path / "first.yaml").open("a", encoding="utf-8") as stream:
        stream.write("# edited after the campaign started\n")
    # was: resumed, the rows of the old survey and the new one mixed in one file
    with pytest.raises(InputError, match=r"first\.yaml: changed since the campaign"):
        run_campaign(spec, output=out, resume=True, executor=InstantExecutor())
    assert len(results.read_bytes().splitlines()) == 1


# --- 4. results.csv and spreadsheets ----------------------------------------------------


def test_results_csv_writes_no_cell_a_spreadsheet_runs_as_a_formula(tmp_path: Path) -> None:
    from pirate_bt.campaign.report import write_report

    spec = {"name": "c", "runs": [{"name": "=HYPERLINK(\"x\")", "tree": "straight",
                                   "params": {"distance": "0.1 m"}}]}  # fmt: skip
    result = run_campaign(spec, output=None, executor=InstantExecutor())
    rows = [dict(row) for row in result.rows]
    rows[0].update(reason="-2+3 cmd", failing_node="@SUM(A1)", sim_time_s=-1.5)
    write_report(rows, tmp_path, title="t")
    with (tmp_path / "results.csv").open(encoding="utf-8", newline="") as stream:
        row = next(csv.DictReader(stream))
    # was: written raw, and a spreadsheet opening the file ran them as formulas
    assert row["run"] == '\'=HYPERLINK("x")'
    assert row["reason"] == "'-2+3 cmd" and row["failing_node"] == "'@SUM(A1)"
    assert row["sim_time_s"] == "-1.5"  # a number stays a number
    assert row["outcome"] == "success" and row["params"].startswith("{")
    # results.jsonl, which the report is made again from, keeps the text as it was
    assert "'" not in rows[0]["run"]


def test_a_navigators_route_beside_the_spec_is_found_from_another_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # params: {route: my.route} was read from the working folder: a spec run from
    # elsewhere said 'my.route:1:1: no such file' for the route beside it, as the docs
    # promise for the spec's own file names
    from pirate_bt.campaign.spec import load_campaign

    folder = tmp_path / "spec"
    folder.mkdir()
    (folder / "my.route").write_text("network straight\nforward 0.2 m\n")
    spec_file = folder / "nav.campaign.yaml"
    spec_file.write_text(
        "name: navrel\nruns:\n  - {navigator: route, network: straight,"
        " params: {route: my.route}}\nseeds: {count: 1}\n"
    )
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    (case,) = expand(load_campaign(spec_file))
    assert case["params"]["route"] == str((folder / "my.route").resolve())
    assert main(["validate", str(spec_file)]) == 0
