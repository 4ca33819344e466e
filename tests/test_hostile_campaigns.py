"""Hostile campaign specs and results files: each refused with one located line, exit 2.

None of these runs a case: every spec here is refused, or its cases are handed to
an executor of the test's own that returns records at once, so the file takes well
under a second.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from pirate_bt.campaign import (
    campaign_from_data,
    check_inputs,
    expand,
    read_rows,
    run_campaign,
    run_cases,
)
from pirate_bt.campaign.case import error_record
from pirate_bt.campaign.cases import check_runs
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from tests.hostile_support import InstantExecutor

TREE_RUN = "runs:\n  - {tree: straight, params: {distance: 0.2 m}}\n"


def _file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "h.campaign.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, *options: str) -> str:
    path = _file(tmp_path, text)
    out = tmp_path / "out"
    assert main(["campaign", str(path), "--quiet", "--output", str(out), *options]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert not out.exists()  # nothing written, no worker started
    return err.strip().removeprefix("pirate-bt: ").replace(str(path), "FILE")


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        # a case limit of 1e300 s overflowed the worker's wait: every case an error row
        ("case_timeout: 1e300 s", "FILE:4:1: case_timeout is at most 604800 s, not '1e300 s'"),
        # a tick rate of 1e9 Hz ran each case until its wall-time limit killed it
        ("rate: 1e9 Hz", "FILE:4:1: rate is at most 1000 Hz, not '1e9 Hz'"),
        ("max_time: 1e300 s", "FILE:4:1: max_time is at most 1e+09 s, not '1e300 s'"),
        # a boolean was taken for a seed count of 1, a float for a count of variants
        ("seeds: {count: true}", "FILE:4:9: count: must be a whole number, not true"),
        ("as_built: {count: 2.0}", "FILE:4:12: count: must be a whole number, not 2.0"),
    ],
)
def test_limits_out_of_bounds_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, expected: str
) -> None:
    runs = TREE_RUN
    if line.startswith("as_built"):
        runs = "runs:\n  - {route: straight}\n"
    assert _refused(tmp_path, capsys, f"name: h\n{runs}{line}\n") == expected


def test_an_endless_case_timeout_option_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    err = _refused(tmp_path, capsys, f"name: h\n{TREE_RUN}", "--case-timeout", "1e300 s")
    assert err == "--case-timeout is at most 604800 s, not '1e300 s'"
    with pytest.raises(InputError, match="case_timeout is at most 604800 s"):
        run_campaign(_file(tmp_path, f"name: h\n{TREE_RUN}"), case_timeout=float("inf"))


def test_a_bad_tree_parameter_is_placed_in_the_spec_not_on_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "name: h\nruns:\n  - {tree: straight, params: {distance: fast}}\n"
    # was: --param:1:1: parameter 'distance': ...
    assert _refused(tmp_path, capsys, text) == (
        "FILE:3:31: parameter 'distance': not a quantity: 'fast'"
        " (expected e.g. '90 deg', '80 mm/s')"
    )
    text = "name: h\nruns:\n  - {tree: straight, params: {distance: 1 m, speed: 2}}\n"
    assert _refused(tmp_path, capsys, text).startswith(
        "FILE:3:46: unknown parameter 'speed' (parameters: distance, "
    )
    with pytest.raises(InputError) as info:
        run_campaign({"name": "h", "runs": [{"tree": "straight", "params": {"distance": "x"}}]})
    assert str(info.value).startswith("campaign spec: runs[0].params.distance: parameter")


@pytest.mark.parametrize(
    ("value", "message"),
    [
        # was: .../trees/straight.yaml:48:75: drive: Input should be greater than 0
        ("-1 m", "drive: distance: must be more than 0 m, not -1.0 m (used at "),
        ("1e309 m", "'1e309 m' is not a finite number"),
    ],
)
def test_a_tree_parameter_value_the_tree_refuses_is_placed_in_the_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, message: str
) -> None:
    text = f"name: h\nruns:\n  - tree: straight\n    params: {{distance: {value}}}\n"
    err = _refused(tmp_path, capsys, text)
    assert err.startswith(f"FILE:4:14: parameter 'distance': {message}"), err
    # validate makes the checks campaign makes before it runs a case (was: exit 0)
    assert main(["validate", str(tmp_path / "h.campaign.yaml")]) == 2
    assert capsys.readouterr().err.startswith(f"{tmp_path / 'h.campaign.yaml'}:4:14: ")


def test_a_tree_parameter_without_a_default_must_be_given(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It was checked with the tree's example values, and every case became an error row.
    err = _refused(tmp_path, capsys, "name: h\nruns:\n  - {tree: straight}\n")
    # at the run that left it out, naming the declaration (it was placed at the tree's
    # declaration alone, so two runs of one tree could not be told apart)
    assert err.startswith(
        "FILE:3:5: run 'straight': parameter 'distance' has no default and was not given"
    ), err
    assert err.endswith("straight.yaml:6:1)"), err
    two = (
        "name: h\nruns:\n  - {name: one, tree: straight, params: {distance: 1 m}}\n"
        "  - {name: two, tree: straight, params: {velocity: 50 mm/s}}\n"
    )
    err = _refused(tmp_path, capsys, two)
    assert err.startswith("FILE:4:33: run 'two': parameter 'distance' has no default"), err


def test_an_output_that_is_a_file_is_refused_before_any_worker(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _file(tmp_path, f"name: h\n{TREE_RUN}")
    blocker = tmp_path / "blocker"
    blocker.write_text("mine\n", encoding="utf-8")
    for output, expected in (
        (blocker, f"{blocker}: the output is a file, not a folder; give another --output"),
        (blocker / "sub", f"{blocker / 'sub'}: cannot make the output folder: Not a directory"),
    ):
        # was: "campaign h: 1 cases on 2 local workers", then an internal error (exit 1)
        assert main(["campaign", str(path), "--quiet", "--output", str(output)]) == 2
        captured = capsys.readouterr()
        assert captured.out == ""
        assert captured.err == f"pirate-bt: {expected}\n"
    assert blocker.read_text(encoding="utf-8") == "mine\n"
    (tmp_path / "o" / "results.jsonl").mkdir(parents=True)
    with pytest.raises(InputError, match=r"results\.jsonl: not a file"):
        run_campaign(path, output=tmp_path / "o")


def _rows(tmp_path: Path) -> tuple[list[dict[str, Any]], Path]:
    spec = {"name": "h", "runs": [{"tree": "straight"}], "seeds": {"count": 3}}
    cases = expand(campaign_from_data(spec))
    rows = [error_record(c, "success", "done", 0.1) for c in cases]
    folder = tmp_path / "o"
    folder.mkdir()
    return rows, folder


def test_tampered_and_cut_rows_are_skipped_with_their_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    rows, folder = _rows(tmp_path)
    lines = [json.dumps(r) for r in rows]
    bad = [
        {**rows[0], "index": "abc"},
        {**rows[0], "outcome": "bogus"},
        {**rows[0], "violations": "lots"},
        {**rows[0], "sim_time_s": float("nan")},
        {**rows[0], "damage_kinds": {"x": "y"}},
        {**rows[0], "id": "../../etc"},
        [1, 2, 3],
    ]
    text = "\n".join([*(json.dumps(b) for b in bad), lines[1][:40], lines[2]]) + "\n"
    results = folder / "results.jsonl"
    results.write_bytes(text.encode() + b"\xff\xfe not utf-8\n")
    assert read_rows(results) == [rows[2]]
    warned = [r.getMessage() for r in caplog.records]
    assert f"{results}:1: skipped a row that is not a case's result: index 'abc'" in warned[0]
    # a line cut in the middle of the file and bytes that are not UTF-8 are no cut last line
    assert f"{results}:8: skipped a line that is not a JSON row" in warned[7]
    assert f"{results}:10: skipped a line that is not a JSON row" in warned[8]
    # The report of a file with no valid row: exit 2, one line (was an internal error).
    results.write_text(json.dumps(bad[0]) + "\n", encoding="utf-8")
    assert main(["campaign", "report", str(folder)]) == 2
    assert capsys.readouterr().err == f"pirate-bt: {results}: no results in it\n"


def test_resume_refuses_a_row_whose_index_was_edited(tmp_path: Path) -> None:
    rows, folder = _rows(tmp_path)
    cases = [{**r, "timeout_s": 1.0} for r in rows]
    edited = {**rows[1], "index": 7}  # its id is a case's, its index another's
    text = "".join(json.dumps(r) + "\n" for r in (rows[0], edited))
    (folder / "results.jsonl").write_text(text, encoding="utf-8")
    pool = InstantExecutor()
    # It was run again and its row dropped; a row that is not one of the cases is now
    # refused, before any case and before the file is rewritten (test_campaign_probe_fixes).
    with pytest.raises(InputError, match=r"results\.jsonl:2: 1 row of 2 is not a case"):
        run_cases(cases, folder, pool, resume=True)
    assert pool.ids == []
    assert (folder / "results.jsonl").read_text(encoding="utf-8") == text
    (folder / "results.jsonl").write_text(json.dumps(rows[0]) + "\n", encoding="utf-8")
    out = run_cases(cases, folder, pool, resume=True)
    assert sorted(pool.ids) == sorted([rows[1]["id"], rows[2]["id"]])
    assert [r["index"] for r in out] == [0, 1, 2]
    assert sorted(r["index"] for r in read_rows(folder / "results.jsonl")) == [0, 1, 2]


def test_two_runs_of_one_name_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Both were labelled 'straight' (the tree's stem), and the report counted the runs in
    # the level pipe and up the riser as one group.
    text = (
        "name: h\nruns:\n  - {tree: straight, params: {distance: 0.2 m}}\n"
        "  - {tree: straight, network: riser, params: {distance: 0.2 m}}\n"
    )
    # at the second run's own key (its name comes from its tree), not at 'runs:' (2:1)
    assert _refused(tmp_path, capsys, text) == (
        "FILE:4:6: runs[0] and runs[1] are both named 'straight': give each run a 'name'"
        " of its own (the report's groups are told apart by it) (first at FILE:3:6)"
    )
    named = text.replace("{tree: straight, network", "{name: riser, tree: straight, network")
    assert len(expand(campaign_from_data(yaml.safe_load(named)))) == 2


@pytest.mark.parametrize("key", ["network", "robots", "maps"])
def test_a_network_or_robot_file_that_does_not_validate_stops_the_campaign(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "schema_version: 1\nname: bad\ndiameter: 63 mm\nsegments:\n"
        "  - {type: straight, length: -1 m}\n",
        encoding="utf-8",
    )
    run = "{tree: straight, params: {distance: 0.2 m}}"
    extra = ""
    if key == "network":
        run = "{tree: straight, network: bad.yaml, params: {distance: 0.2 m}}"
    elif key == "robots":
        robot = (Path(__file__).parents[1] / "hardware" / "pirate.yaml").read_text("utf-8")
        assert "weight: 15 N" in robot
        bad.write_text(robot.replace("weight: 15 N", "weight: -15 N"), encoding="utf-8")
        extra = "robots: [bad.yaml]\n"
    else:
        run, extra = "{route: straight}", "maps: [bad.yaml]\n"
    # were error rows, one per case ("ValidationFailed: .../bad.yaml:5:22: ...")
    err = _refused(tmp_path, capsys, f"name: h\nruns:\n  - {run}\n{extra}")
    assert err.startswith(f"{bad}:")


def test_a_bundled_route_by_its_bare_name_is_the_route_not_the_network() -> None:
    spec = campaign_from_data(
        {"name": "h", "runs": [{"route": "straight"}, {"route": "t-joint-straight"}]}
    )
    # were refused: 'straight' was read as scenarios/straight.yaml (the network: "unknown
    # command 'segments:'"), and 't-joint-straight' (a route only) as no such file
    check_inputs(spec)
    cases = expand(spec)
    check_runs(cases, spec)
    assert [Path(c["route"]).name for c in cases] == ["straight", "t-joint-straight"]


def test_a_fault_on_a_motor_the_robot_lacks_is_refused_at_its_entry(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = f"name: h\n{TREE_RUN}sim_faults:\n  - []\n  - [link_loss@1s, motor_stall:nosuch@1s]\n"
    # was an error row per case: "ConfigurationError: fault motor_stall: unknown motor 'nosuch'"
    assert _refused(tmp_path, capsys, text).startswith(
        "FILE:6:20: fault motor_stall: unknown motor 'nosuch' (motors: camera_tilt, "
    )
