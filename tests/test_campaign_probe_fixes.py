"""What a probe of the campaign command found, each as the user met it.

Resuming with another spec deleted the earlier rows; a route run's network became
the simulated truth; repeated axis entries were counted as independent samples; a
tree was checked against the bundled robot only; a deeply nested results line was
an internal error; a mistyped tree parameter was placed on the command line.

Most tests here run no case (a spec refused, or an executor of the test's own that
returns records at once), so the file takes a few seconds.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from pirate_bt.campaign import (
    campaign_from_data,
    expand,
    load_campaign,
    read_rows,
    run_campaign,
    run_cases,
)
from pirate_bt.campaign.case import error_record
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from tests.hostile_support import InstantExecutor

ROOT = Path(__file__).resolve().parents[1]

BASE = """\
name: base
runs:
  - {name: s, tree: straight, network: straight, params: {distance: 0.2 m}}
seeds: {start: 0, count: 2}
max_time: 60 s
"""

RESUME_HINT = (
    "--resume continues the campaign that wrote them: give the same spec, or another --output"
)


def _spec(tmp_path: Path, text: str, name: str = "c.campaign.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _done(spec: Path, out: Path) -> bytes:
    """``out/results.jsonl`` as a finished run of ``spec`` leaves it; its bytes."""
    out.mkdir(exist_ok=True)
    rows = [error_record(c, "success", "done", 0.1) for c in expand(load_campaign(spec))]
    data = "".join(json.dumps(r) + "\n" for r in rows).encode()
    (out / "results.jsonl").write_bytes(data)
    return data


def _one_error(capsys: pytest.CaptureFixture[str], path: Path | None = None) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""  # refused before the "campaign NAME: N cases on ..." line
    err = captured.err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    err = err.strip().removeprefix("pirate-bt: ")
    return err.replace(str(path), "FILE") if path is not None else err


def _column(text: str, line: int, word: str, nth: int = 1) -> str:
    """``LINE:COL`` of the ``nth`` ``word`` on 1-based line ``line`` of ``text``."""
    row = text.splitlines()[line - 1]
    at = -1
    for _ in range(nth):
        at = row.index(word, at + 1)
    return f"{line}:{at + 1}"


# --- 1. --resume with another spec ---------------------------------------------------


def test_resume_with_another_spec_is_refused_and_keeps_the_rows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "res"
    before = _done(_spec(tmp_path, BASE), out)
    other = _spec(tmp_path, BASE.replace("0.2 m", "0.3 m"), "other.campaign.yaml")
    # was: exit 0, and results.jsonl held only the new spec's two rows
    assert main(["campaign", str(other), "--workers", "1", "--output", str(out), "--resume"]) == 2
    results = out / "results.jsonl"
    assert _one_error(capsys) == (
        f"{results}:1: 2 rows of 2 are not cases of this campaign; {RESUME_HINT}"
    )
    assert results.read_bytes() == before
    assert not (out / "report.md").exists()


def test_resume_with_fewer_seeds_is_refused_at_the_first_foreign_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "res"
    before = _done(_spec(tmp_path, BASE), out)
    fewer = _spec(tmp_path, BASE.replace("count: 2", "count: 1"), "fewer.campaign.yaml")
    # was: exit 0, and the seed-1 row was gone
    assert main(["campaign", str(fewer), "--output", str(out), "--resume", "--quiet"]) == 2
    assert _one_error(capsys) == (
        f"{out / 'results.jsonl'}:2: 1 row of 2 is not a case of this campaign; {RESUME_HINT}"
    )
    assert (out / "results.jsonl").read_bytes() == before


def test_run_cases_refuses_foreign_rows_before_any_case(tmp_path: Path) -> None:
    spec = _spec(tmp_path, BASE)
    out = tmp_path / "res"
    before = _done(spec, out)
    cases = expand(load_campaign(spec))
    edited = [{**cases[0], "timeout_s": 1.0}]  # one case of the two the file holds
    pool = InstantExecutor()
    with pytest.raises(InputError, match=r"results\.jsonl:2: 1 row of 2 is not a case") as info:
        run_cases(edited, out, pool, resume=True)
    assert str(info.value).endswith(
        RESUME_HINT.replace("--resume", "resume=True").replace("--output", "output=")
    )
    assert pool.ids == []
    assert (out / "results.jsonl").read_bytes() == before


def test_a_row_whose_index_was_edited_is_foreign(tmp_path: Path) -> None:
    spec = _spec(tmp_path, BASE)
    out = tmp_path / "res"
    _done(spec, out)
    results = out / "results.jsonl"
    rows = [json.loads(line) for line in results.read_text("utf-8").splitlines()]
    rows[1]["index"] = 7
    results.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    with pytest.raises(InputError, match=r"results\.jsonl:2: 1 row of 2 is not a case"):
        run_campaign(spec, output=out, resume=True, executor=InstantExecutor())


def test_resume_reads_the_results_once_and_warns_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    spec = _spec(tmp_path, BASE)
    out = tmp_path / "res"
    data = _done(spec, out)
    first = data.splitlines(keepends=True)[0]
    (out / "results.jsonl").write_bytes(first + b'{"id": "cut')  # the second case was cut
    pool = InstantExecutor()
    with caplog.at_level(logging.WARNING):
        result = run_campaign(spec, output=out, resume=True, executor=pool)
    assert len(pool.ids) == 1 and result.cases == 2
    warned = [r.getMessage() for r in caplog.records if "skipped" in r.getMessage()]
    # was: the same warning three times (two early checks and the run)
    assert warned == [f"{out / 'results.jsonl'}:2: skipped a cut line"]
    assert [r["seed"] for r in read_rows(out / "results.jsonl")] == [0, 1]


def test_without_resume_any_content_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    out = tmp_path / "res"
    out.mkdir()
    results = out / "results.jsonl"
    mine = b'[1, 2]\n\n{"id": "../x"}\nnot json\n'
    results.write_bytes(mine)
    spec = _spec(tmp_path, BASE)
    # was: every line failed as a row, so the file counted as empty and was overwritten
    assert main(["campaign", str(spec), "--output", str(out), "--quiet"]) == 2
    assert _one_error(capsys) == (
        f"{results} holds 3 lines already; use --resume, or another --output"
    )
    assert results.read_bytes() == mine
    assert not [r for r in caplog.records if "skipped" in r.getMessage()]
    with pytest.raises(InputError, match="holds 3 lines already"):
        run_cases([], out, InstantExecutor())


# --- 2. a route run's network is its map ------------------------------------------------


def test_a_route_run_whose_network_is_not_the_routes_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "name: rm\nruns:\n  - {name: r, route: lab, network: straight}\n"
    spec = _spec(tmp_path, text)
    # was: "ok", and the campaign ran the lab route's plan in the straight pipe
    assert main(["validate", str(spec)]) == 2
    err = _one_error(capsys, spec)
    assert err.startswith(
        f"FILE:{_column(text, 3, 'network')}: run 'r': the route names network"
    ), err
    assert "lab" in err and "straight" in err and "maps" in err
    assert main(["campaign", str(spec), "--output", str(tmp_path / "o"), "--quiet"]) == 2
    assert _one_error(capsys, spec) == err
    assert not (tmp_path / "o").exists()
    with pytest.raises(InputError, match=r"^campaign spec: runs\[0\]\.network: run 'r': "):
        run_campaign({"name": "rm", "runs": [{"name": "r", "route": "lab", "network": "straight"}]})


def test_a_route_that_does_not_fit_the_runs_network_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "turn.route").write_text("forward 1 m\nat the bend turn right\n", "utf-8")
    text = "name: t\nruns:\n  - {name: t, route: turn.route, network: straight}\n"
    spec = _spec(tmp_path, text)
    assert main(["validate", str(spec)]) == 2
    err = _one_error(capsys, spec)
    assert err.startswith(f"FILE:{_column(text, 3, 'network')}: run 't': "), err
    assert "turn.route:2:1: 'at the bend turn right' does not fit the network" in err
    # the route on a map it fits: valid, and the network is the case's map
    fits = _spec(tmp_path, text.replace("straight", "bend-right"), "fits.campaign.yaml")
    assert main(["validate", str(fits)]) == 0
    [case] = expand(load_campaign(fits))
    assert case["network"] == "bend-right" and case["map"] is None


def test_a_route_run_naming_its_own_network_is_valid(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _spec(
        tmp_path,
        "name: ok\nruns:\n  - {name: a, route: lab, network: lab}\n"
        f"  - {{name: b, route: lab-service, network: {ROOT / 'scenarios' / 'lab.yaml'}}}\n",
    )
    assert main(["validate", str(spec)]) == 0


def test_shipped_campaigns_with_routes_validate(capsys: pytest.CaptureFixture[str]) -> None:
    files = sorted((ROOT / "scenarios" / "campaigns").glob("*.campaign.yaml"))
    assert main(["validate", *map(str, files)]) == 0


# --- 3. repeated axis entries --------------------------------------------------------------


@pytest.mark.parametrize(
    ("axis", "line", "word", "nth", "message"),
    [
        ("robots: [null, null]", 4, "null", 2, "robots[1] repeats robots[0] (the bundled robot)"),
        ("link: {drop: [0, 0.0]}", 4, "0.0", 1, "link.drop[1] repeats link.drop[0] (0)"),
        ("link: {dup: [0.1, 0.2, 1e-1]}", 4, "1e-1", 1, "link.dup[2] repeats link.dup[0] (0.1)"),
        ("sim_faults: [[], []]", 4, "[]", 2, "sim_faults[1] repeats sim_faults[0] (no faults)"),
        (
            "sim_faults: [[link_loss@1s], ['link_loss@1 s']]",
            4,
            "['link_loss",
            1,
            "sim_faults[1] repeats sim_faults[0] (link_loss@1s)",
        ),
    ],
)
def test_a_repeated_axis_entry_is_refused_at_the_second(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    axis: str,
    line: int,
    word: str,
    nth: int,
    message: str,
) -> None:
    text = (
        "name: d\nruns:\n  - {tree: straight, network: straight, params: {distance: 0.2 m}}\n"
        f"{axis}\n"
    )
    spec = _spec(tmp_path, text)
    # was: ok, and identical deterministic cases counted as independent samples
    assert main(["validate", str(spec)]) == 2
    err = _one_error(capsys, spec)
    assert err.startswith(f"FILE:{_column(text, line, word, nth)}: {message}: "), err
    assert main(["campaign", str(spec), "--output", str(tmp_path / "o"), "--quiet"]) == 2
    assert _one_error(capsys, spec) == err


def test_repeated_robot_files_maps_and_runs_are_refused(tmp_path: Path) -> None:
    robot = ROOT / "hardware" / "pirate.yaml"
    run = {"tree": "straight", "network": "straight", "params": {"distance": "0.2 m"}}
    for extra, where in (
        ({"robots": [str(robot), str(robot.parent / "." / robot.name)]}, "robots[1]"),
        ({"runs": [run, {**run, "name": "again"}]}, "runs[1]"),
        (
            {"runs": [{"route": "lab"}], "maps": ["lab-long", "lab-long.yaml"]},
            "maps[1]",
        ),
    ):
        data = {"name": "d", "runs": [run], **extra}
        with pytest.raises(InputError) as info:
            run_campaign(data, base=ROOT / "scenarios")
        assert str(info.value).startswith(f"campaign spec: {where} repeats"), info.value
        assert "\n" not in str(info.value)


# --- 4. every tree against every robot ------------------------------------------------------


def test_a_tree_a_robot_of_the_axis_refuses_is_refused_at_the_robot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = (ROOT / "hardware" / "pirate.yaml").read_text("utf-8")
    assert "torque: {max: 0.8 N*m, policy: refuse}" in robot
    weak = robot.replace(
        "torque: {max: 0.8 N*m, policy: refuse}", "torque: {max: 0.5 N*m, policy: refuse}"
    )
    (tmp_path / "weak.yaml").write_text(weak, encoding="utf-8")
    text = (
        "name: rb\nruns:\n  - {name: s, tree: straight, params: {distance: 0.2 m}}\n"
        "robots: [null, weak.yaml]\n"
    )
    spec = _spec(tmp_path, text)
    # was: ok, and every weak.yaml case an error row ("ValidationFailed: ... 0.5 N*m")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    lines = [
        line.removeprefix("pirate-bt: ").replace(str(spec), "FILE") for line in err.splitlines()
    ]
    assert lines and all(
        line.startswith(f"FILE:{_column(text, 4, 'weak.yaml')}: robot 'weak.yaml': run 's': ")
        for line in lines
    ), err
    assert "torque: 0.7 N*m is above the bend joints' limit 0.5 N*m" in lines[0]
    assert "trees/lib/clamp-" in lines[0]  # the tree's place
    assert main(["campaign", str(spec), "--output", str(tmp_path / "o"), "--quiet"]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"pirate-bt: {line}" for line in err.splitlines()
    ]
    assert not (tmp_path / "o").exists()
    # a route's PAB trees alike (were error rows too)
    route = _spec(
        tmp_path,
        "name: rr\nruns: [{route: straight}]\nrobots: [null, weak.yaml]\n",
        "rr.campaign.yaml",
    )
    assert main(["validate", str(route)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{route}:3:16: robot 'weak.yaml': run 'straight': ")
    assert "clamp: torque: 0.7 N*m is above the bend joints' limit 0.5 N*m" in err
    # checked against the axis's robots only: a torque above the bundled robot's limit
    # (0.8 N*m) that a stronger robot takes
    strong = robot.replace("torque: {max: 0.8 N*m,", "torque: {max: 1.0 N*m,")
    (tmp_path / "strong.yaml").write_text(strong, encoding="utf-8")
    hard = text.replace("{distance: 0.2 m}", "{distance: 0.2 m, torque: 0.9 N*m}")
    assert main(["validate", str(_spec(tmp_path, hard, "hard.campaign.yaml"))]) == 2
    capsys.readouterr()
    hard = hard.replace("[null, weak.yaml]", "[strong.yaml]")
    assert main(["validate", str(_spec(tmp_path, hard, "strong.campaign.yaml"))]) == 0


# --- 5. results files that are no rows ------------------------------------------------------


def test_a_deeply_nested_line_is_skipped_like_any_bad_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / "c-deep"
    folder.mkdir()
    results = folder / "results.jsonl"
    results.write_text("[" * 100_000 + "]" * 100_000 + "\n", encoding="utf-8")
    # was: an internal error (RecursionError), exit 1
    assert main(["campaign", "report", str(results)]) == 2
    assert capsys.readouterr().err == f"pirate-bt: {results}: no results in it\n"
    assert [r.getMessage() for r in caplog.records] == [
        f"{results}:1: skipped a line that is not a JSON row"
    ]


def test_lines_that_are_not_rows_are_not_called_cut(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    row = error_record({"id": "000000-a", "index": 0}, "success", "done", 0.1)
    results = tmp_path / "results.jsonl"
    results.write_text(
        "\n".join(
            [
                "1" * 5000,  # a 5000-digit integer (more digits than Python converts)
                json.dumps(row),
                '{"id": "000001-b", "index": 1, "outcome": "succ',  # not the last line
                json.dumps({**row, "outcome": "error"}),  # a second row for the same case
                '{"id": "000002-c", "ind',  # the cut last line
            ]
        ),
        encoding="utf-8",
    )
    assert read_rows(results) == [row]
    assert [r.getMessage() for r in caplog.records] == [
        f"{results}:1: skipped a line that is not a JSON row",
        f"{results}:3: skipped a line that is not a JSON row",
        f"{results}:4: skipped a second row for case 000000-a (the first is line 2)",
        f"{results}:5: skipped a cut line",
    ]


def test_a_row_without_its_rates_is_reported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a record made without its case (rates null) passes as a row: the report took it
    # and stopped with an internal error (NoneType.__format__), exit 1
    row = error_record({"id": "000000-a", "index": 0, "run": "s"}, "success", "done", 0.1)
    assert row["drop"] is None
    (tmp_path / "results.jsonl").write_text(json.dumps(row) + "\n", encoding="utf-8")
    assert main(["campaign", "report", str(tmp_path)]) == 0
    assert "| s drop=0 corrupt=0 dup=0 | 1 |" in (tmp_path / "report.md").read_text("utf-8")
    capsys.readouterr()


# --- 6. a mistyped tree parameter --------------------------------------------------------


def test_an_unknown_tree_parameter_is_placed_at_its_key_in_the_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "name: bp\nruns:\n  - {tree: straight, network: straight, params: {distanse: 0.2 m}}\n"
    spec = _spec(tmp_path, text)
    assert main(["validate", str(spec)]) == 2
    lines = capsys.readouterr().err.splitlines()
    # was: "--param:1:1: unknown parameter 'distanse' ..."
    assert lines[0].replace(str(spec), "FILE") == (
        f"FILE:{_column(text, 3, 'distanse')}: unknown parameter 'distanse'"
        " (parameters: distance, torque, velocity, distance_key, stop_at_feature, stop_at_change)"
        "; did you mean 'distance'?"
    )
    assert len(lines) == 1, lines  # not also "'distance' has no default and was not given"
    assert not any("--param" in line for line in lines)
    with pytest.raises(InputError) as info:
        run_campaign(
            {"name": "bp", "runs": [{"tree": "straight", "params": {"distanse": "0.2 m"}}]}
        )
    assert str(info.value).startswith(
        "campaign spec: runs[0].params.distanse: unknown parameter 'distanse'"
    )
    assert "--param" not in str(info.value)


# --- 7. small ------------------------------------------------------------------------------


def test_a_problem_of_a_spec_given_as_data_names_its_key_once() -> None:
    ok = {"name": "d", "runs": [{"tree": "straight", "params": {"distance": "0.2 m"}}]}
    for bad, expected in (
        ({"runs": "straight"}, "campaign spec: runs: must be a list, not 'straight'"),
        ({"max_time": "5 kg"}, "campaign spec: max_time: '5 kg' is a mass, but a time"),
        ({"seeds": "many"}, "campaign spec: seeds: should be a mapping of keys"),
    ):
        with pytest.raises(InputError) as info:
            campaign_from_data({**ok, **bad})
        assert str(info.value).startswith(expected), info.value


def test_an_empty_output_is_refused_not_the_working_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # `--output "$DIR"` with DIR unset ran the campaign into the working folder
    spec = _spec(tmp_path, BASE)
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["campaign", str(spec), "--output", "", "--quiet"]) == 2
    assert _one_error(capsys) == "--output: empty; name a folder"
    assert list(work.iterdir()) == []


def test_the_command_names_its_options_in_a_scheduler_file_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the message named run_campaign's arguments (scheduler_file, scheduler_timeout)
    pytest.importorskip("distributed")
    spec = _spec(tmp_path, BASE)
    missing = tmp_path / "scheduler.json"
    code = main(
        [
            "campaign",
            str(spec),
            "--scheduler-file",
            str(missing),
            "--scheduler-timeout",
            "0.2 s",
            "--output",
            str(tmp_path / "o"),
            "--quiet",
        ]
    )
    assert code == 2
    line = _one_error(capsys)
    assert line.startswith(f"--scheduler-file: no scheduler file at {missing}")
    assert line.endswith("or give a longer --scheduler-timeout")
