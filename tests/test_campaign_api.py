"""run_campaign from Python: results, writing nothing, the size bound, safe paths, inputs."""

from __future__ import annotations

import csv
import dataclasses
import os
import shutil
import textwrap
import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import (
    CampaignSpec,
    campaign_from_data,
    default_output,
    expand,
    load_campaign,
    read_rows,
    run_campaign,
    run_cases,
    run_isolated,
)
from pirate_bt.campaign.paths import slug
from pirate_bt.campaign.report import CSV_COLUMNS
from pirate_bt.campaign.stats import wilson_interval
from pirate_bt.cli import main
from pirate_bt.errors import InputError, LocatedError, ValidationFailed
from pirate_bt.safety.tally import Counters

ROOT = Path(__file__).resolve().parents[1]

# The fastest real case there is (about 1 s in its process): 0.2 m of the straight PAB.
RUN = {"name": "straight", "tree": "straight", "network": "straight"}
RUN_PARAMS = {"distance": "0.2 m"}


def _spec(**changes: Any) -> dict[str, Any]:
    spec: dict[str, Any] = {
        "name": "api",
        "runs": [{**RUN, "params": dict(RUN_PARAMS)}],
        "max_time": "60 s",
        "case_timeout": "120 s",
    }
    spec.update(changes)
    return spec


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# --- real runs ---------------------------------------------------------------------


def test_run_campaign_from_a_dict_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    work, tmp = tmp_path / "work", tmp_path / "tmp"
    work.mkdir()
    tmp.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setenv("TMPDIR", str(tmp))  # the case processes inherit it
    seen: list[str] = []
    lines: list[str] = []
    result = run_campaign(
        _spec(link={"drop": [0.0, 0.2]}),
        workers=2,
        on_record=lambda r: seen.append(r["id"]),
        echo=lines.append,
    )
    assert _files(work) == [] and _files(tmp) == []
    assert result.output is None and result.report_path is None and result.files == ()
    assert result.name == "api" and result.cases == 2
    assert [(r["index"], r["drop"], r["seed"]) for r in result.rows] == [(0, 0.0, 0), (1, 0.2, 0)]
    assert sorted(seen) == sorted(r["id"] for r in result.rows)
    assert [r["outcome"] for r in result.rows] == ["success", "success"], result.rows
    assert all(r["trace"] is None for r in result.rows)
    assert dict(result.counts) == {"success": 2, "failed-safe": 0, "error": 0, "timeout": 0}
    assert (result.violations, result.damage) == (0, 0)
    assert result.succeeded
    assert result.summary() == "2 runs: 2 success, 0 failed safe, 0 error, 0 timeout"
    assert [g.key for g in result.groups] == [
        "straight drop=0 corrupt=0 dup=0",
        "straight drop=0.2 corrupt=0 dup=0",
    ]
    assert all(g.n == 1 and g.success == 1 for g in result.groups)
    assert result.groups[0].interval == wilson_interval(1, 1)
    assert lines == ["campaign api: 2 cases on 2 local workers -> no output folder"]
    assert 0 < result.wall_s < 120
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.name = "x"  # type: ignore[misc]


def test_a_spec_file_with_hostile_names_writes_only_inside_its_output(tmp_path: Path) -> None:
    """A run named like a path, traces kept: every file lands under the output folder."""
    folder = tmp_path / "specs"
    folder.mkdir()
    shutil.copy(ROOT / "scenarios" / "straight.yaml", folder / "my-net.yaml")
    spec = folder / "hostile.campaign.yaml"
    spec.write_text(
        textwrap.dedent(
            """\
            name: "..  evil .."
            runs:
              - {name: "../../../escape", tree: straight, network: my-net.yaml,
                 params: {distance: 0.2 m}}
            max_time: 60 s
            case_timeout: 120 s
            keep_traces: all
            """
        ),
        encoding="utf-8",
    )
    out = tmp_path / "out"
    result = run_campaign(spec, workers=1, output=out)
    (row,) = result.rows
    assert row["outcome"] == "success", row
    assert row["network"] == str((folder / "my-net.yaml").resolve())  # next to the spec
    assert result.output == out and result.report_path == out / "report.md"
    assert result.report_path.exists() and set(result.files) <= set(out.iterdir())
    assert row["trace"] == str((out / "traces" / f"{row['id']}.jsonl").resolve())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "specs"]
    assert sorted(p.name for p in folder.iterdir()) == ["hostile.campaign.yaml", "my-net.yaml"]
    assert read_rows(out / "results.jsonl")[0]["id"] == row["id"]
    assert "pirate-bt campaign" in (out / "report.md").read_text(encoding="utf-8")
    loaded = load_campaign(spec)
    assert loaded.name == "..  evil .." and default_output(loaded) == Path("campaign-evil")


STALL = """\
name: stall
runs:
  - {name: bend, tree: bend, network: bend-right, params: {roll: 90 deg}}
sim_faults:
  - ["motor_stall:bend_3_drive@5s+20s"]
max_time: 120 s
case_timeout: 120 s
"""


def test_a_failing_case_row_has_its_first_cause_and_node(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The bend PAB with its third drive stalled, through the command: the row, the report."""
    spec = tmp_path / "stall.campaign.yaml"
    spec.write_text(STALL, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--workers", "1", "--output", str(out), "--quiet"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"campaign stall: 1 cases on 1 local worker -> {out}",
        "campaign stall: 1 runs: 0 success, 1 failed safe, 0 error, 0 timeout",
        *(f"wrote {out / name}" for name in ("results.csv", "report.md", "report.html")),
    ]
    (row,) = read_rows(out / "results.jsonl")
    assert row["outcome"] == "failed-safe", row
    assert row["reason"].startswith("stall: bend_3_drive draws "), row["reason"]
    assert row["failing_node"] == "bend/pass bend/confirm enter/front into turn"
    assert "link" not in row
    assert {f.name for f in dataclasses.fields(Counters)} <= set(row)
    assert row["safe_states"] == 1 and (row["violations"], row["damage"]) == (0, 0)
    md = (out / "report.md").read_text(encoding="utf-8")
    reasons = md.split("## Most frequent failure reasons\n\n", 1)[1]
    assert reasons.startswith(f"- 1 × {row['reason']}\n")
    assert f"- 1 × `{row['failing_node']}`" in md
    assert "| safe states | 1 | 1 |  |" in md
    with (out / "results.csv").open(encoding="utf-8") as f:
        (csv_row,) = csv.DictReader(f)
    assert csv_row["reason"] == row["reason"] and csv_row["safe_states"] == "1"


def test_the_command_takes_max_cases(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "stall.campaign.yaml"
    spec.write_text(STALL.replace("name: stall", "name: s\nseeds: {count: 4}"), "utf-8")
    assert main(["campaign", str(spec), "--max-cases", "3", "--output", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err == (
        f"pirate-bt: {spec}:2:9: the campaign expands to 4 cases, more than the limit of 3"
        " (max_cases): seeds.count 4\n"
    )
    assert main(["campaign", str(spec), "--max-cases", "0"]) == 2
    assert main(["campaign", str(spec), "--case-timeout", "0 s"]) == 2
    assert capsys.readouterr().err == (
        "pirate-bt: --max-cases must be at least 1\n"
        "pirate-bt: --case-timeout must be positive, not '0 s'\n"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stall.campaign.yaml"]


# --- the size bound ----------------------------------------------------------------


def _refused_fast(spec: Any, **options: Any) -> str:
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as info:
            run_campaign(spec, **options)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 5_000_000  # nothing was expanded (memory, not the wall clock, tells)
    message = str(info.value)
    assert "\n" not in message
    return message


def test_a_huge_seed_range_is_refused_before_expanding(tmp_path: Path) -> None:
    message = _refused_fast(_spec(seeds={"start": 0, "count": 10**12}), output=tmp_path / "o")
    assert message == (
        "campaign spec: seeds.count: the campaign expands to 1,000,000,000,000 cases,"
        " more than the limit of 100,000 (max_cases): seeds.count 1,000,000,000,000"
    )
    assert not (tmp_path / "o").exists()
    model = CampaignSpec.model_validate(_spec(seeds={"count": 10**12}))
    assert _refused_fast(model).startswith("campaign 'api': seeds.count: the campaign expands")


def test_the_bound_names_the_file_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rates = ", ".join(f"{i / 1000:g}" for i in range(1000))
    path = tmp_path / "big.campaign.yaml"
    path.write_text(
        "name: big\nruns:\n  - {tree: straight, params: {distance: 0.2 m}}\n"
        f"link:\n  drop: [{rates}]\nseeds: {{start: 0, count: 1000000}}\n",
        encoding="utf-8",
    )
    expected = (
        f"{path}:6:19: the campaign expands to 1,000,000,000 cases, more than the limit of"
        " 100,000 (max_cases): link.drop 1,000 × seeds.count 1,000,000"
    )
    assert _refused_fast(path) == expected
    with pytest.raises(LocatedError):
        run_campaign(path)
    # The command expands through the same check.
    assert main(["campaign", str(path), "--output", str(tmp_path / "o")]) == 2
    assert expected in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_max_cases_is_the_callers(tmp_path: Path) -> None:
    spec = _spec(seeds={"count": 4})
    message = _refused_fast(spec, max_cases=3)
    assert message.endswith(
        "expands to 4 cases, more than the limit of 3 (max_cases): seeds.count 4"
    )
    assert len(expand(campaign_from_data(spec), max_cases=4)) == 4
    with pytest.raises(InputError, match="limit of 3"):
        expand(campaign_from_data(spec), max_cases=3)


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"sim_faults": [["motor_stall:bend_1_drive@20s"]] * 1_000_000}, "at most 1000 items"),
        ({"sim_faults": [["motor_stall:bend_1_drive@20s"] * 100_000]}, "at most 64 items"),
        ({"link": {"drop": [0.0] * 1_000_000}}, "at most 1000 items"),
        ({"description": "x" * 10_000_000}, "at most 10000 characters"),
        ({"runs": [{**RUN, "params": {"distance": "1" * 10_000_000}}]}, "at most 200 char"),
        ({"runs": [{**RUN, "params": {"d" * 10_000_000: "1 m"}}]}, "at most 200 char"),
        ({"runs": [{**RUN, "tree": "t" * 10_000_000}]}, "at most 4096 characters"),
        (
            {"seeds": {"start": 10**100}},
            "seeds.start: must be at most 9223372036854775807, not a 101-digit number",
        ),
    ],
)
def test_oversized_texts_and_lists_are_refused(changes: dict[str, Any], words: str) -> None:
    # (how fast is no assertion here: a wall-clock limit failed under a loaded suite;
    # the refusal names the length before anything is expanded)
    with pytest.raises(InputError, match=words):
        run_campaign(_spec(**changes))


def test_a_huge_campaign_file_is_refused_before_it_is_read(tmp_path: Path) -> None:
    path = tmp_path / "huge.campaign.yaml"
    path.write_text("name: huge\ndescription: " + "x" * 2_000_000 + "\n", encoding="utf-8")
    with pytest.raises(ValidationFailed, match=r"huge\.campaign\.yaml:1:1: the file has 2,000,0"):
        run_campaign(path)


# --- paths ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name", ["../../etc/x", "/etc/passwd", "a/b", "evil\x00name", "x" * 300, "..", "", "-rf"]
)
def test_unsafe_case_ids_are_refused_before_any_case(tmp_path: Path, name: str) -> None:
    cases = [
        {"id": "000000-ok", "index": 0, "run": "a", "seed": 0, "timeout_s": 5.0},
        {"id": name, "index": 1, "run": "b", "seed": 0, "timeout_s": 5.0},
    ]
    out = tmp_path / "out"
    with ThreadPoolExecutor(1) as pool, pytest.raises(InputError) as info:
        run_cases(cases, out, pool)
    assert str(info.value).startswith("case id ")
    assert "is not a safe file name (letters, digits, '.', '_', '-'" in str(info.value)
    assert "\n" not in str(info.value)
    assert not out.exists()
    # The function the workers run refuses it too, without starting a process.
    record = run_isolated(cases[1], str(out / "traces"))
    assert record["outcome"] == "error" and "not a safe file name" in record["reason"]
    assert list(tmp_path.iterdir()) == []


def test_the_exact_traversal_message() -> None:
    case = {"id": "../../etc/x", "index": 0, "seed": 0, "timeout_s": 1.0}
    with ThreadPoolExecutor(1) as pool, pytest.raises(InputError) as info:
        run_cases([case], None, pool)
    assert str(info.value) == (
        "case id '../../etc/x' is not a safe file name (letters, digits, '.', '_', '-',"
        " starting with a letter or digit, at most 128 characters)"
    )


def test_expanded_case_ids_are_safe_whatever_the_names() -> None:
    spec = campaign_from_data(
        _spec(
            name="x .. y",
            runs=[{**RUN, "name": "../../../../etc/passwd", "params": dict(RUN_PARAMS)}],
            robots=[None, "/etc/../../robot.yaml"],
        )
    )
    for case in expand(spec):
        assert case["id"] == f"{case['index']:06d}-{case['id'][7:]}"
        assert len(case["id"]) == 15 and set(case["id"][7:]) <= set("0123456789abcdef")


@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("../../etc/x", "not a path: the campaign's name may not hold '/' or"),
        ("a\\b", "not a path"),
        ("evil\x00", "control characters"),
        ("x" * 101, "at most 100 characters"),
    ],
)
def test_campaign_names_that_would_be_paths_are_refused(name: str, words: str) -> None:
    with pytest.raises(InputError, match=f"campaign spec: name: .*{words}"):
        campaign_from_data(_spec(name=name))


def test_slugs() -> None:
    assert slug("../../etc/x") == "etc-x"
    assert slug("pab-drop") == "pab-drop"
    assert slug("..") == "campaign"
    assert slug("évasion totale") == "vasion-totale"
    assert len(slug("y" * 1000)) == 64


# --- input files --------------------------------------------------------------------


def test_a_missing_tree_file_is_a_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError) as info:
        run_campaign(_spec(runs=[{**RUN, "tree": "no-such-tree.yaml"}]))
    assert str(info.value) == (
        "campaign spec: runs[0].tree: tree 'no-such-tree.yaml': no such file, nor a bundled tree"
    )
    (tmp_path / "adir").mkdir()
    with pytest.raises(InputError, match=r"runs\[0\]\.tree: tree 'adir': .*is a directory"):
        run_campaign(_spec(runs=[{**RUN, "tree": "adir"}]))
    assert [p.name for p in tmp_path.iterdir()] == ["adir"]


def test_missing_inputs_in_a_file_are_located(tmp_path: Path) -> None:
    path = tmp_path / "c.campaign.yaml"
    path.write_text(
        "name: c\n"
        "runs:\n"
        "  - {tree: no-such-tree.yaml, network: no-such-net}\n"
        "robots: [null, missing-robot.yaml]\n",
        encoding="utf-8",
    )
    with pytest.raises(ValidationFailed) as info:
        run_campaign(path, output=tmp_path / "out")
    lines = str(info.value).splitlines()
    assert lines == [
        f"{path}:3:6: tree 'no-such-tree.yaml': no such file, nor a bundled tree",
        f"{path}:3:31: network 'no-such-net': no such file, nor a bundled network",
        f"{path}:4:16: robot 'missing-robot.yaml': no such file",
    ]
    assert not (tmp_path / "out").exists()


def test_options_are_checked(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="resume needs an output folder"):
        run_campaign(_spec(), resume=True)
    with pytest.raises(InputError, match="workers must be at least 1"):
        run_campaign(_spec(), workers=0)
    with ThreadPoolExecutor(1) as pool, pytest.raises(InputError, match="at most one of"):
        run_campaign(_spec(), executor=pool, scheduler="tcp://127.0.0.1:9")
    with pytest.raises(InputError, match="case_timeout"):
        run_campaign(_spec(), case_timeout="5 kg")
    with pytest.raises(TypeError):
        run_campaign(42)  # type: ignore[arg-type]
    assert os.listdir(tmp_path) == []


def test_the_csv_has_every_counter() -> None:
    assert {f.name for f in dataclasses.fields(Counters)} <= set(CSV_COLUMNS)
    assert not {"link", "failed", "loss_ratio"} & set(CSV_COLUMNS)


def test_reasons_that_differ_only_in_numbers_count_as_one(tmp_path: Path) -> None:
    stall = "stall: bend_3_drive draws 1.50 A at 0 mm/s for {} s (commanded 80 mm/s)"
    reasons = [
        stall.format("0.55"),
        stall.format("0.50"),
        stall.format("0.55"),
        stall.format("0.55").replace("bend_3", "bend_1"),
        "RuntimeError: boom",
    ]
    rows = [
        {"id": f"{i:06d}-a", "index": i, "run": "bend", "drop": 0.0, "corrupt": 0.0, "dup": 0.0,
         "seed": i, "outcome": "failed-safe", "reason": reason, "failing_node": "bend/pass",
         "retries": i, "violations": 0, "damage": 1, "damage_kinds": {"over-torque": 1}}
        for i, reason in enumerate(reasons)
    ]  # fmt: skip
    from pirate_bt.campaign.report import write_report

    write_report(rows, tmp_path, title="t")
    md = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert md.split("## Most frequent failure reasons\n\n", 1)[1].split("\n\n")[0] == (
        f"- 3 × {stall.format('0.50–0.55')}\n"
        f"- 1 × {stall.format('0.55').replace('bend_3', 'bend_1')}\n"
        "- 1 × RuntimeError: boom"
    )
    assert "| retries | 10 | 4 |  |" in md
    assert "| damage | 5 | 5 | over-torque 5 |" in md


def test_run_names_are_labels_not_mathtext_or_files(tmp_path: Path) -> None:
    from pirate_bt.campaign.report import write_report

    rows = [
        {"id": f"{i:06d}-a", "index": i, "run": "../x $\\frac$", "drop": drop, "corrupt": 0.0,
         "dup": 0.0, "seed": 0, "outcome": "success"}
        for i, drop in enumerate([0.0, 0.1])
    ]  # fmt: skip
    files = write_report(rows, tmp_path / "out", title="<b>../t</b>")
    assert {p.parent for p in files} == {tmp_path / "out"}
    assert "&lt;b&gt;../t&lt;/b&gt;" in (tmp_path / "out" / "report.html").read_text()
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_a_target_that_is_not_there_is_refused_once_before_any_case(tmp_path: Path) -> None:
    # each case process imported it and died of it: one error row per case
    out = tmp_path / "out"
    with pytest.raises(InputError, match=r"^target: no module named 'no_such_module_17'"):
        run_campaign(_spec(), output=out, target="no_such_module_17:run")
    with pytest.raises(InputError, match=r"^target: pirate_bt\.campaign\.case has no function"):
        run_campaign(_spec(), output=out, target="pirate_bt.campaign.case:nope")
    assert not out.exists()


def test_a_target_that_raises_as_it_is_imported_is_refused_with_its_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "broken_target_17.py").write_text("raise ValueError('no config')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(InputError, match=r"^target: importing broken_target_17 raised .*no config"):
        run_campaign(_spec(), target="broken_target_17:run")


def test_workers_beside_a_cluster_or_an_executor_is_refused_not_dropped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with ThreadPoolExecutor(1) as pool, pytest.raises(InputError, match="give one or the other"):
        run_campaign(_spec(), executor=pool, workers=4)
    with pytest.raises(InputError, match=r"^workers is the local pool's size; with scheduler"):
        run_campaign(_spec(), scheduler="tcp://127.0.0.1:9", workers=2)
    spec = tmp_path / "w.campaign.yaml"
    spec.write_text("name: w\nruns:\n  - {tree: straight, network: straight}\n")
    code = main(["campaign", str(spec), "--workers", "2", "--scheduler", "tcp://127.0.0.1:9"])
    assert code == 2
    err = capsys.readouterr().err
    assert "--workers is the local pool's size; with --scheduler" in err, err
    assert not (tmp_path / "campaign-w").exists() and not Path("campaign-w").exists()
