"""Probe 19, the command-line contract: outputs that are the command's own input, and
errors that leave standard output empty."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.resources import default_robot_path


@pytest.mark.parametrize("how", ["positional", "--robot", "symlink"])
def test_a_header_onto_its_robot_description_is_refused_and_the_description_kept(
    tmp_path: Path, how: str, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = tmp_path / "r.yaml"
    shutil.copyfile(default_robot_path(), robot)
    before = robot.read_bytes()
    out = robot
    if how == "symlink":
        out = tmp_path / "layout.h"
        out.symlink_to(robot)
    args = (
        ["robot", "header", str(robot), "-o", str(out)]
        if how == "positional"
        else ["robot", "--robot", str(robot), "header", "-o", str(out)]
    )
    assert main(args) == 2  # was 0: the robot description replaced by a C header
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        f"pirate-bt: -o: {out} is the robot description file; name another file"
    ]
    assert robot.read_bytes() == before


def test_robot_draw_to_a_suffix_it_cannot_draw_prints_no_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "boards.txt"
    assert main(["robot", "--draw", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # was the whole board table, then the error
    assert captured.err.splitlines() == [
        "pirate-bt: --draw: cannot draw to 'boards.txt': use .dot, .svg or .png"
    ]
    assert not out.exists()


def test_trace_export_onto_the_trace_it_reads_is_refused_and_the_trace_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("mcap")
    jsonl = tmp_path / "run.jsonl"
    mcap = tmp_path / "run.mcap"
    assert main(["run", "straight", "--param", "distance=0.2m", "--trace", str(jsonl)]) == 0
    assert main(["trace", "export", str(jsonl), "-o", str(mcap)]) == 0
    before = mcap.read_bytes()
    capsys.readouterr()
    # was "wrote run.mcap", exit 0: the trace rewritten while it was being read
    assert main(["trace", "export", str(mcap), "-o", str(mcap)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        f"pirate-bt: -o: {mcap} is the trace file; name another file"
    ]
    assert mcap.read_bytes() == before


def test_campaign_report_on_a_file_of_no_results_is_one_warning_and_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    # a trace given by mistake: every line JSON, none a case's result
    trace = tmp_path / "run.jsonl"
    trace.write_text("".join(f'{{"tick": {i}}}\n' for i in range(500)), encoding="utf-8")
    assert main(["campaign", "report", str(trace)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == [
        f"pirate-bt: {trace}: no results in it; none of its 500 rows is a case's result"
    ]
    warned = [r.getMessage() for r in caplog.records if r.name.startswith("pirate_bt.campaign")]
    # was 500 warnings, one per line, before the error
    assert warned == [f"{trace}:1: skipped a row that is not a case's result: no case id"]
    assert not (tmp_path / "report.md").exists()


def test_campaign_report_still_warns_of_every_bad_row_beside_good_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    from pirate_bt.campaign import campaign_from_data, expand
    from pirate_bt.campaign.case import error_record

    spec = {"name": "h", "runs": [{"tree": "straight"}], "seeds": {"count": 1}}
    good = [error_record(c, "success", "done", 0.1) for c in expand(campaign_from_data(spec))]
    results = tmp_path / "results.jsonl"
    lines = [json.dumps({"tick": i}) for i in range(3)] + [json.dumps(good[0])]
    results.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert main(["campaign", "report", str(results)]) == 0
    warned = [r.getMessage() for r in caplog.records if r.name.startswith("pirate_bt.campaign")]
    assert warned == [
        f"{results}:{n}: skipped a row that is not a case's result: no case id" for n in (1, 2, 3)
    ]


def test_network_output_name_too_long_is_named_by_its_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / ("a" * 5000 + ".yaml")
    assert main(["network", "perturb", "lab", "--seed", "1", "-o", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    (line,) = captured.err.splitlines()  # was the whole 5000-character name, then why
    assert line.startswith("pirate-bt: -o: a file name of ")
    assert line.endswith(" characters is too long (at most 4096)")


@pytest.mark.parametrize(
    "argv",
    [
        ["navigate", "goal", "--sim", "lab", "--map", "lab", "--param", "segment=run-d"],
        ["survey", "-o", "{tmp}/surveyed.yaml"],
    ],
    ids=["navigate", "survey"],
)
def test_a_trace_folder_that_is_a_file_is_named_by_its_option(
    tmp_path: Path, argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "runs"
    blocker.write_text("mine\n", encoding="utf-8")
    args = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main([*args, "--trace", str(blocker), "-q"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    # was "trace: ...", the API's parameter, not the option typed
    assert captured.err.splitlines() == [
        f"pirate-bt: --trace: {blocker} is a file, not a folder; give a folder"
    ]
    assert blocker.read_text(encoding="utf-8") == "mine\n"
    assert not (tmp_path / "surveyed.yaml").exists()


@pytest.mark.parametrize(
    ("argv", "option"),
    [(["render", "straight", "-o"], "-o"), (["robot", "--draw"], "--draw")],
    ids=["render", "robot"],
)
def test_a_folder_where_the_dot_source_goes_is_refused_before_any_work(
    tmp_path: Path, argv: list[str], option: str, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "q.dot").mkdir()
    picture = tmp_path / "q.svg"
    assert main([*argv, str(picture)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""  # robot printed its board table first
    # render said "out: cannot write 'q.dot' ...", the API's parameter
    assert captured.err.splitlines() == [
        f"pirate-bt: {option}: cannot write 'q.dot' beside 'q.svg', the diagram's source:"
        " it is a folder"
    ]
    assert not picture.exists()


def test_an_output_name_the_system_refuses_is_no_input_to_the_library() -> None:
    # not_an_input's target.exists() raised OSError (File name too long) for a part of
    # over 255 bytes, a raw line for planner code that had not checked the name first
    from pirate_bt.api.options import not_an_input

    not_an_input(Path("x" * 300 + ".jsonl"), "trace", {"tree": "trees/bend.yaml"})
