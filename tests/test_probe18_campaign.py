"""Probe 18: campaign specs written from the docs, hostile and honest.

Each test is a bug a researcher writing campaign specs met, fixed.
"""

from __future__ import annotations

import errno
import json
import resource
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import case as case_module
from pirate_bt.campaign import load_campaign, run_campaign
from pirate_bt.campaign import report as report_module
from pirate_bt.campaign.case import run_case
from pirate_bt.campaign.cases import check_axes, expand
from pirate_bt.campaign.sink import RowSink
from pirate_bt.campaign.spec import campaign_from_data
from pirate_bt.campaign.stats import group_stats
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.task import navigators
from pirate_bt.task.explore_parts import SurveyIncomplete

_HUGE = {
    "name": "huge",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.2 m"}}],
    "link": {"drop": [0.0, 0.1]},
    "seeds": {"start": 0, "count": 1_000_000_000},
}


def _bounded(code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a Python of its own with 1.5 GB of address space: a spec that
    expands in memory fails there fast, not on the machine running the tests."""

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (3 << 29, 3 << 29))

    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=limit,
        check=False,
    )


def test_a_limit_raised_past_memory_is_refused_not_expanded(tmp_path: Path) -> None:
    # max_cases=10**11 let a spec of 2 * 10**9 cases expand in memory: 7.8 GB
    # within 20 s, until the machine ran out (a MemoryError, or the OOM killer).
    code = f"""
from pirate_bt.campaign import run_campaign
from pirate_bt.errors import InputError
try:
    run_campaign({_HUGE!r}, max_cases=100_000_000_000, output="out")
except InputError as error:
    print(error)
"""
    done = _bounded(code, tmp_path)
    assert done.returncode == 0, done.stderr[-500:]
    assert done.stdout.startswith("max_cases: at most 1,000,000 cases, not 100,000,000,000")
    assert not (tmp_path / "out").exists()
    with pytest.raises(InputError, match="at most 1,000,000"):
        expand(campaign_from_data(_HUGE), max_cases=10**12)


def test_the_command_refuses_a_limit_past_memory_in_one_line(tmp_path: Path) -> None:
    (tmp_path / "big.campaign.yaml").write_text(
        "name: big\nruns:\n  - {tree: straight, network: straight, params: {distance: 0.2 m}}\n"
        "seeds: {count: 1000000000}\n"
    )
    code = """
import sys
from pirate_bt.cli import main
sys.exit(main(["campaign", "big.campaign.yaml", "--max-cases", "99999999999", "--output", "o"]))
"""
    done = _bounded(code, tmp_path)
    assert done.returncode == 2, done.stderr[-500:]
    assert done.stderr.startswith("pirate-bt: --max-cases: at most 1,000,000 cases, not 99,999,")
    assert done.stderr.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_the_ceiling_itself_is_still_allowed() -> None:
    spec = {**_HUGE, "link": {"drop": [0.0]}, "seeds": {"count": 3}}
    assert len(expand(campaign_from_data(spec), max_cases=1_000_000)) == 3


def test_a_fault_point_that_lists_one_fault_twice_is_the_point_once(tmp_path: Path) -> None:
    # [X, X] runs exactly as [X] (the simulator's result is the same, counters and
    # all), but the two points were taken as different and their identical,
    # deterministic cases counted as independent samples.
    stall = "motor_stall:bend_1_drive@5s+2s"
    spec = tmp_path / "f.campaign.yaml"
    spec.write_text(
        "name: f\nruns:\n  - {tree: straight, network: straight, params: {distance: 0.2 m}}\n"
        f'sim_faults: [["{stall}", "{stall}"], ["{stall}"]]\n'
    )
    with pytest.raises(InputError) as caught:
        check_axes(load_campaign(spec))
    assert str(caught.value) == (
        f"{spec}:4:84: sim_faults[1] repeats sim_faults[0] ({stall}, {stall}): its cases would"
        " run twice and be counted as independent samples; remove one"
    )


def test_ctrl_c_says_how_many_cases_were_kept_and_how_many_remain(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # It said "results.jsonl keeps the cases done" whether none or 39 of 40 were.
    import pirate_bt.campaign as campaign

    real = campaign.run_campaign
    seen: list[str] = []

    def interrupted_after_two(spec: Any, **options: Any) -> Any:
        def record(row: dict[str, Any]) -> None:
            seen.append(row["id"])
            if len(seen) == 2:
                raise KeyboardInterrupt  # Ctrl-C as the second row arrives

        return real(spec, **options, on_record=record)

    monkeypatch.setattr(campaign, "run_campaign", interrupted_after_two)
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text(
        "name: c\nruns:\n  - {tree: straight, network: straight, params: {distance: 0.1 m}}\n"
        "seeds: {count: 5}\nmax_time: 60 s\n"
    )
    out = tmp_path / "out"
    code = main(["campaign", str(spec), "--workers", "1", "--output", str(out), "--quiet"])
    assert code == 130
    err = capsys.readouterr().err
    assert err == (
        f"pirate-bt: campaign interrupted; {out}/results.jsonl keeps 2 of its 5 cases (the"
        " cases in flight are not recorded); run again with --resume to run the other 3\n"
    )
    assert len((out / "results.jsonl").read_text().splitlines()) == 2


class _Incomplete:
    """A survey that finds what it cannot survey at once, as ``explore`` does."""

    def next_step(self, obs: Any) -> None:
        raise SurveyIncomplete("an opening at 3.33 m with no branch the robot could steer into")


class _Broken:
    def next_step(self, obs: Any) -> None:
        raise ZeroDivisionError("a bug in the planner")


def test_a_survey_that_ends_incomplete_is_failed_safe_not_an_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # explore on an as-built variant it could not survey counted as an `error` (as a
    # crash would), where `pirate-bt survey` calls the same end a failure, robot safe.
    monkeypatch.setitem(navigators._BUILT_IN, "incomplete", _Incomplete)
    monkeypatch.setitem(navigators._BUILT_IN, "broken", _Broken)
    spec = campaign_from_data(
        {
            "name": "s",
            "runs": [
                {"navigator": "incomplete", "network": "t-joint", "blind": True},
                {"navigator": "broken", "network": "t-joint", "blind": True},
            ],
            "max_time": "60 s",
        }
    )
    incomplete, broken = (run_case(case) for case in expand(spec))
    assert incomplete["outcome"] == "failed-safe"
    assert incomplete["reason"] == (
        "navigator 'incomplete' raised SurveyIncomplete: an opening at 3.33 m with no branch"
        " the robot could steer into"
    )
    assert broken["outcome"] == "error"  # a bug in the navigator stays one
    assert broken["reason"] == "navigator 'broken' raised ZeroDivisionError: a bug in the planner"


@pytest.mark.parametrize("name", ["no-such-folder", "a-file.yaml"])
def test_a_base_that_is_not_a_folder_is_refused_not_passed_over(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str
) -> None:
    # A mistyped base (or a file) was passed over: every relative name then resolved
    # against the working folder, silently, and a missing one was said missing there.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a-file.yaml").write_text("x: 1\n")
    spec = {"name": "b", "runs": [{"tree": "mine.yaml", "params": {"distance": "0.1 m"}}]}
    with pytest.raises(InputError) as caught:
        run_campaign(spec, base=tmp_path / name, workers=1)
    assert str(caught.value) == f"base: {str(tmp_path / name)!r} is not a folder"


def test_a_reason_with_a_hash_of_its_own_does_not_break_the_report(tmp_path: Path) -> None:
    # Reasons alike but for their numbers count as one; a '#' in a reason was taken
    # for a number, and `campaign report` (and every campaign's end) died with
    # "internal error: ValueError: zip() argument 2 is longer than argument 1".
    rows = []
    for index, reason in enumerate(["item # missing", "item 3 missing", "item 4 missing"]):
        rows.append(
            {
                "id": f"{index:06d}-0000000{index}",
                "index": index,
                "run": "r",
                "tree": "straight",
                "outcome": "error",
                "reason": f"RuntimeError in top/exploder: {reason}",
                "wall_time_s": 0.1,
            }
        )
    results = tmp_path / "results.jsonl"
    results.write_text("".join(json.dumps(row) + "\n" for row in rows))
    assert main(["campaign", "report", str(results)]) == 0
    report = (tmp_path / "report.md").read_text()
    assert "- 2 × RuntimeError in top/exploder: item 3–4 missing\n" in report
    assert "- 1 × RuntimeError in top/exploder: item # missing\n" in report


def test_a_resume_counts_the_rows_it_keeps_in_its_line_and_its_bar(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A resume of 3 cases with 1 done said "3 cases on ..." and its bar ended at
    # "2/3 ... ok 2" with every case done: the kept rows were counted nowhere.
    spec = {
        "name": "r",
        "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}],
        "seeds": {"count": 3},
        "max_time": "60 s",
    }
    out = tmp_path / "out"
    run_campaign(spec, workers=1, output=out)
    results = out / "results.jsonl"
    results.write_text(results.read_text().splitlines(keepends=True)[0])
    capsys.readouterr()
    said: list[str] = []
    result = run_campaign(spec, workers=1, output=out, resume=True, progress=True, echo=said.append)
    assert result.counts["success"] == 3
    assert said == [f"campaign r: 3 cases (1 done, 2 to run) on 1 local worker -> {out}"]
    bar = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert "| 3/3 [" in bar and bar.endswith("ok 3 safe 0 err 0 t/o 0]")


def test_the_report_keeps_a_failure_reason_whole(tmp_path: Path) -> None:
    # Reasons were cut at 120 characters without a mark: the report said "where the
    # map has no turn" of "... no turn and no end within 0.61 m", and two causes
    # alike for their first 120 characters counted as one.
    head = (
        "belief and map disagree: the pipe blocked the robot at 3.30 m (believed, 0.90 m"
        " after 'tee'), where the map has no turn"
    )
    reasons = [f"{head} and no end within 0.61 m", f"{head} nor a bend within 0.61 m"]
    rows = [
        {
            "id": f"{index:06d}-0000000{index}",
            "index": index,
            "run": "r",
            "route": "t-joint",
            "outcome": "failed-safe",
            "reason": reason,
            "wall_time_s": 0.1,
        }
        for index, reason in enumerate(reasons)
    ]
    results = tmp_path / "results.jsonl"
    results.write_text("".join(json.dumps(row) + "\n" for row in rows))
    assert main(["campaign", "report", str(results)]) == 0
    report = (tmp_path / "report.md").read_text()
    for reason in reasons:
        assert f"- 1 × {reason}\n" in report
    (group,) = group_stats([{**rows[0], "reason": "x" * 5000}])
    assert list(group.reasons) == ["x" * 999 + "…"]  # a bound, and marked


def test_two_robots_of_one_file_name_are_two_groups(tmp_path: Path) -> None:
    # robots: [a/robot.yaml, b/robot.yaml] made one group "robot=robot" of both
    # robots' runs: the comparison the axis was written for was lost.
    def row(index: int, robot: str, outcome: str) -> dict[str, Any]:
        return {
            "id": f"{index:06d}-0000000{index}",
            "index": index,
            "run": "r",
            "tree": "straight",
            "robot": robot,
            "outcome": outcome,
            "reason": "done" if outcome == "success" else "stall: bend_1_drive",
            "wall_time_s": 0.1,
        }

    a, b = str(tmp_path / "a" / "robot.yaml"), str(tmp_path / "b" / "robot.yaml")
    rows = [row(0, a, "success"), row(1, b, "failed-safe"), row(2, a, "success")]
    groups = group_stats(rows)
    assert [(g.key, g.n, g.success) for g in groups] == [
        (f"r robot={a} drop=0.0 corrupt=0.0 dup=0.0", 2, 2),
        (f"r robot={b} drop=0.0 corrupt=0.0 dup=0.0", 1, 0),
    ]
    # a robot alone under its name keeps the short label
    (one,) = group_stats([row(0, a, "success")])
    assert one.key == "r robot=robot drop=0 corrupt=0 dup=0"
    # two drop rates alike to 6 digits were one group "drop=0.1" too
    rates = [{**row(i, a, "success"), "drop": d} for i, d in enumerate([0.1, 0.1000001, 0.1])]
    assert [(g.key, g.n) for g in group_stats(rates)] == [
        ("r robot=" + a + " drop=0.1 corrupt=0.0 dup=0.0", 2),
        ("r robot=" + a + " drop=0.1000001 corrupt=0.0 dup=0.0", 1),
    ]


def test_the_report_again_keeps_the_campaigns_name(tmp_path: Path) -> None:
    # `campaign report OUT/results.jsonl` ("the report again") titled it by the folder:
    # the report of campaign 'smoke' in out/ became "# out".
    spec = {
        "name": "smoke",
        "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}],
        "max_time": "60 s",
    }
    out = tmp_path / "out"
    run_campaign(spec, workers=1, output=out)
    assert (out / "report.md").read_text().startswith("# smoke\n")
    assert main(["campaign", "report", str(out / "results.jsonl")]) == 0
    assert (out / "report.md").read_text().startswith("# smoke\n")
    assert "<title>smoke</title>" in (out / "report.html").read_text()


def test_the_report_says_whose_counters_are_unknown(tmp_path: Path) -> None:
    # A case that crashed has no counters (null); the report summed them as 0 and
    # said "violations 0" with no word that one run's were never known.
    rows = [
        {
            "id": f"{index:06d}-0000000{index}",
            "index": index,
            "run": "r",
            "tree": "straight",
            "outcome": outcome,
            "reason": reason,
            "wall_time_s": 0.1,
            "violations": violations,
            "damage": violations,
        }
        for index, (outcome, reason, violations) in enumerate(
            [("success", "done", 0), ("error", "case process died (killed by SIGSEGV)", None)]
        )
    ]
    results = tmp_path / "results.jsonl"
    results.write_text("".join(json.dumps(row) + "\n" for row in rows))
    assert main(["campaign", "report", str(results)]) == 0
    said = (
        "1 of 2 runs ended without a result of their own (a crash, a hang, an exception"
        " outside the run): their counters are unknown and not in these totals, violations"
        " and damage included."
    )
    assert f"\n\n{said}\n" in (tmp_path / "report.md").read_text()
    assert f"<p>{said}</p>" in (tmp_path / "report.html").read_text()
    results.write_text(json.dumps(rows[0]) + "\n")
    assert main(["campaign", "report", str(results)]) == 0
    assert "without a result of their own" not in (tmp_path / "report.md").read_text()


def test_a_trace_the_disk_has_no_room_for_stops_the_campaign_not_a_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A full disk under traces/ made the case an `error` row ("SinkError: ... trace
    # writer: OSError: [Errno 28] No space left on device") beside its half-written
    # trace: the campaign stopped at the next row, and the resume after making room
    # never ran the case again, so the disk's failure stayed in the statistics.
    spec = campaign_from_data(
        {
            "name": "t",
            "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "1 m"}}],
            "keep_traces": "all",
        }
    )
    (case,) = expand(spec)
    traces = tmp_path / "traces"
    said = (
        f"{traces}/{case['id']}.jsonl: the trace writer failed (exit 1): trace writer:"
        " OSError: [Errno 28] No space left on device"
    )

    def full(case: dict[str, Any], trace: Path | None) -> dict[str, Any]:
        assert trace is not None
        trace.write_text('{"type": "header"}\n{"type": "ti')  # as far as it got
        return {"outcome": "error", "reason": f"SinkError: {said}"}

    monkeypatch.setattr(case_module, "_tree_case", full)
    record = run_case(case, str(traces))
    assert not list(traces.iterdir())  # no half-written trace
    results = tmp_path / "results.jsonl"
    results.write_text("")
    with RowSink(results) as sink, pytest.raises(InputError) as caught:
        sink.write(record)
    assert str(caught.value) == (
        f"{traces}/{case['id']}.jsonl: No space left on device: cannot write case"
        f" {case['id']}'s trace; the rows before it stay: make room, then run again with"
        " resume=True"
    )
    assert results.read_text() == ""  # not a row: a resume runs the case again


def test_a_report_a_read_only_folder_refuses_is_not_told_to_make_room(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # On a read-only file system it said "Read-only file system; ... make room".
    results = tmp_path / "results.jsonl"
    results.write_text(
        json.dumps(
            {"id": "000000-00000000", "index": 0, "run": "r", "tree": "straight"}
            | {"outcome": "success", "reason": "done", "wall_time_s": 0.1}
        )
        + "\n"
    )

    def read_only(path: Path, write: Any) -> None:
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(report_module, "write_atomically", read_only)
    assert main(["campaign", "report", str(results)]) == 2
    assert capsys.readouterr().err == (
        f"pirate-bt: {tmp_path}/results.csv: cannot write the report: Read-only file system;"
        f" the rows stay in {results}: make the folder writable, then `pirate-bt campaign"
        f" report {results}`\n"
    )


def test_the_reproduce_line_carries_the_limits_the_campaign_ran_with(tmp_path: Path) -> None:
    # "Reproduce with: pirate-bt campaign c.campaign.yaml" left out --max-cases (the
    # line then refused a spec the campaign had run) and --case-timeout.
    spec = tmp_path / "c.campaign.yaml"
    spec.write_text(
        "name: c\nruns:\n  - {tree: straight, network: straight, params: {distance: 0.1 m}}\n"
        "max_time: 60 s\n"
    )
    out = tmp_path / "out"
    argv = ["campaign", str(spec), "--workers", "1", "--output", str(out), "--quiet"]
    assert main([*argv, "--max-cases", "200000", "--case-timeout", "90 s"]) == 0
    assert (
        f"    pirate-bt campaign {spec} --workers 1 --case-timeout '90 s' --max-cases 200000\n"
        in (out / "report.md").read_text()
    )


@pytest.mark.parametrize(
    "stop", [KeyboardInterrupt(), InputError("results.jsonl: No space left on device")]
)
def test_ctrl_c_leaves_no_trace_without_its_row(tmp_path: Path, stop: BaseException) -> None:
    # Interrupted (or stopped by a full disk), the campaign left the traces of the
    # cases in flight (cut where they were killed, or whole) under traces/ with no
    # row naming them.
    spec = {
        "name": "k",
        "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.1 m"}}],
        "seeds": {"count": 5},
        "keep_traces": "all",
        "max_time": "60 s",
    }
    out = tmp_path / "out"
    ids = [case["id"] for case in expand(campaign_from_data(spec))]
    seen: list[str] = []
    mine = out / "traces" / "notes.txt"  # not a case's: stays

    def record(row: dict[str, Any]) -> None:
        seen.append(row["id"])
        if len(seen) == 2:
            late = next(i for i in ids if i not in seen)
            (out / "traces" / f"{late}.jsonl").write_text('{"type": "header"}\n{"ty')
            mine.write_text("mine\n")
            raise stop  # Ctrl-C, or a row the disk refused, with a case in flight

    with pytest.raises(type(stop)):
        run_campaign(spec, workers=1, output=out, on_record=record)
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert sorted(p.name for p in (out / "traces").iterdir()) == sorted(
        [*(Path(row["trace"]).name for row in rows), "notes.txt"]
    )
    assert len(rows) == 2


@pytest.mark.parametrize(
    "named",
    ["torque: 0.7 N*m", "stop_at_feature: false", "velocity: 0.08 m/s", 'distance_key: ""'],
)
def test_a_run_naming_a_parameters_default_repeats_the_run_leaving_it(
    tmp_path: Path, named: str
) -> None:
    # {distance: 0.2 m} and {distance: 0.2 m, torque: 0.7 N*m} (torque's default) run
    # the same cases, but were taken as two runs and counted as independent samples.
    spec = tmp_path / "d.campaign.yaml"
    spec.write_text(
        "name: d\nruns:\n"
        "  - {name: a, tree: straight, network: straight, params: {distance: 0.2 m}}\n"
        "  - {name: b, tree: straight, network: straight,"
        f" params: {{distance: 20 cm, {named}}}}}\n"
    )
    with pytest.raises(InputError) as caught:
        check_axes(load_campaign(spec))
    assert str(caught.value) == (
        f"{spec}:4:5: runs[1] repeats runs[0] ('a') under another name: its cases would run"
        " twice and be counted as independent samples; remove one"
    )
    # another value of the parameter is another run
    spec.write_text(spec.read_text().replace("20 cm", "30 cm"))
    check_axes(load_campaign(spec))


def test_too_many_workers_is_said_of_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The command said "workers: at most 1024 local processes", the function's name.
    spec = tmp_path / "w.campaign.yaml"
    spec.write_text("name: w\nruns:\n  - {tree: straight, params: {distance: 0.1 m}}\n")
    argv = ["campaign", str(spec), "--workers", "2000", "--output", str(tmp_path / "o")]
    assert main(argv) == 2
    assert capsys.readouterr().err == (
        "pirate-bt: --workers: at most 1024 local processes, not 2000\n"
    )


def test_a_spec_from_python_may_hold_numpy_counts_and_paths(tmp_path: Path) -> None:
    # seeds: {count: np.int64(3)} was refused ("must be a whole number, not
    # np.int64(3)") beside a NumPy float rate that was taken; a Path for a file name
    # was refused as "must be text, not PosixPath(...)".
    import numpy as np

    tree = tmp_path / "mine.yaml"
    tree.write_text((Path(__file__).parents[1] / "trees" / "straight.yaml").read_text())
    spec = campaign_from_data(
        {
            "name": "np",
            "runs": [{"tree": tree, "network": "straight", "params": {"distance": "0.1 m"}}],
            "seeds": {"start": np.int32(2), "count": np.int64(3)},
            "link": {"drop": np.array([0.0, 0.1])},
            "robots": [None, Path(__file__).parents[1] / "hardware" / "pirate.yaml"],
        }
    )
    assert (spec.seeds.start, spec.seeds.count, spec.runs[0].tree) == (2, 3, str(tree))
    with pytest.raises(InputError, match=r"seeds\.count: must be a whole number, not np\.True_"):
        campaign_from_data({"name": "b", "runs": [{"route": "lab"}], "seeds": {"count": np.True_}})


def test_a_survey_campaign_may_not_write_its_surveys_outside_its_folder(tmp_path: Path) -> None:
    # params: {output: /anywhere/x.yaml} made every case of the explore navigator write
    # its survey to that one file, outside the output folder ("nothing a spec says
    # becomes a path outside the output folder"), each case over the last.
    spec = tmp_path / "s.campaign.yaml"
    escaped = tmp_path / "escaped.yaml"
    spec.write_text(
        "name: s\nruns:\n  - {navigator: explore, network: t-joint, blind: true,"
        f" params: {{output: {escaped}}}}}\n"
    )
    with pytest.raises(InputError) as caught:
        run_campaign(spec, workers=1, output=tmp_path / "out")
    assert str(caught.value) == (
        f"{spec}:3:66: run 'explore': every case of navigator 'explore' would write its"
        " survey to this one file, outside the campaign's folder; leave 'output' out (a"
        " campaign writes only into its own folder)"
    )
    assert not (tmp_path / "out").exists() and not escaped.exists()
