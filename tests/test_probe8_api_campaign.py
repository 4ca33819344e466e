"""The eighth probe of the planner's campaign API: hostile specs and output folders.

Each test is a bug the probe found (the input, what it did): it failed before its
fix. No test here runs a simulation: specs are refused, or their cases are handed
to an executor of the test's own that returns records at once.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from pirate_bt.campaign import read_rows, run_campaign
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from tests.hostile_support import InstantExecutor, refused

SPEC = {
    "name": "p8",
    "runs": [{"tree": "straight", "network": "straight", "params": {"distance": "0.2 m"}}],
    "seeds": {"count": 2},
}


@pytest.mark.parametrize(
    ("make", "words"),
    [
        # every case an error row: FileExistsError: [Errno 17] File exists: '.../traces'
        (lambda out: (out / "traces").write_text("x"), ("traces: not a folder",)),
        # every case ran, then the command failed writing the report (exit 2)
        (lambda out: (out / "report.md").mkdir(), ("report.md: not a file",)),
        (lambda out: (out / "results.csv").mkdir(), ("results.csv: not a file",)),
        (lambda out: (out / "success_vs_drop.png").mkdir(), ("success_vs_drop.png",)),
        # the results file's rewrite failed after the workers had started
        (lambda out: (out / "results.jsonl.part").mkdir(), ("results.jsonl.part: not a file",)),
    ],
)
def test_an_output_folder_the_campaign_cannot_finish_is_refused_before_any_case(
    tmp_path: Path, make: object, words: tuple[str, ...]
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    make(out)  # type: ignore[operator]
    pool = InstantExecutor()
    refused(
        lambda: run_campaign(SPEC, executor=pool, output=out), *words, "output="
    )  # the API names its argument
    assert pool.ids == []  # no case ran
    assert not (out / "results.jsonl").exists()


def test_the_command_refuses_a_traces_file_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "p8.campaign.yaml"
    spec.write_text(
        "name: p8\nruns: [{tree: straight, params: {distance: 0.2 m}}]\n", encoding="utf-8"
    )
    out = tmp_path / "out"
    out.mkdir()
    (out / "traces").write_text("x")
    assert main(["campaign", str(spec), "--quiet", "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "traces: not a folder" in err, err
    assert sorted(p.name for p in out.iterdir()) == ["traces"]


def test_a_usable_output_folder_still_runs(tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "traces").mkdir(parents=True)
    result = run_campaign(SPEC, executor=InstantExecutor(), output=out)
    assert result.cases == 2 and (out / "report.md").is_file()
    with pytest.raises(InputError, match="holds 2 lines already"):
        run_campaign(SPEC, executor=InstantExecutor(), output=out)


def test_a_case_server_starts_without_a_warning_of_its_own_import() -> None:
    # Every server wrote runpy's RuntimeWarning ("'pirate_bt.campaign.child' found in
    # sys.modules after import of package 'pirate_bt.campaign' ... unpredictable
    # behaviour"): the package imported the module the server runs as __main__, so it
    # ran as two copies, and a server killed under a case was recorded as
    # "case worker died while the case ran (killed by SIGKILL: <frozen runpy>...".
    done = subprocess.run(
        [sys.executable, "-W", "error", "-m", "pirate_bt.campaign.child"],
        input=b"",
        capture_output=True,
        timeout=60,
        check=False,
    )
    assert (done.returncode, done.stderr.decode()) == (0, "")
    alone = "import sys, pirate_bt.campaign; sys.exit('pirate_bt.campaign.child' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", alone], timeout=60, check=False).returncode == 0


@pytest.mark.parametrize(
    ("run", "place", "words"),
    [
        # each was "nav.campaign.yaml: run 'goal': ..." with no line or column
        ("{navigator: nosuch, network: lab}", "2:9", "no navigator named 'nosuch'"),
        (
            "{navigator: goal, network: lab, params: {segmnt: riser}}",
            "2:49",
            "navigator 'goal' takes no parameter 'segmnt' (it takes: segment)",
        ),
        (
            "{navigator: goal, network: lab, params: {segment: nosuch}}",
            "2:26",
            "the map 'lab' has no segment 'nosuch'",
        ),
    ],
)
def test_a_navigator_run_that_cannot_be_made_is_placed_at_its_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], run: str, place: str, words: str
) -> None:
    spec = tmp_path / "nav.campaign.yaml"
    spec.write_text(f"name: nav\nruns: [{run}]\n", encoding="utf-8")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err, err
    assert err.startswith(f"{spec}:{place}: run "), err


def test_a_navigator_run_given_as_data_names_its_key() -> None:
    runs = [{"navigator": "goal", "network": "lab", "params": {"segmnt": "riser"}}]
    refused(
        lambda: run_campaign({"name": "x", "runs": runs}, executor=InstantExecutor()),
        "campaign spec: runs[0].params.segmnt: run 'goal': ",
    )


@pytest.mark.parametrize(
    ("first", "second"),
    [
        ("1 m", "1m"),  # both ran: the same cases counted twice as independent samples
        ("1 m", "100 cm"),
        ("0.2 m", "200 mm"),
    ],
)
def test_two_runs_whose_parameters_read_the_same_are_refused(first: str, second: str) -> None:
    runs = [
        {"name": "a", "tree": "straight", "params": {"distance": first}},
        {"name": "b", "tree": "straight", "params": {"distance": second}},
    ]
    refused(
        lambda: run_campaign({"name": "x", "runs": runs}, executor=InstantExecutor()),
        "runs[1] repeats runs[0] ('a') under another name",
    )


def test_runs_whose_parameters_differ_are_not_refused() -> None:
    runs = [
        {"name": "a", "tree": "straight", "params": {"distance": "1 m"}},
        {"name": "b", "tree": "straight", "params": {"distance": "1 cm"}},
        {"name": "c", "tree": "straight", "params": {"distance": "1 m", "stop_at_feature": True}},
    ]
    result = run_campaign({"name": "x", "runs": runs}, executor=InstantExecutor())
    assert result.cases == 3
    assert result.rows[2]["params"] == {"distance": "1 m", "stop_at_feature": "true"}


def test_a_yaml_boolean_parameter_is_a_boolean_not_the_number_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = tmp_path / "b.campaign.yaml"
    spec.write_text("name: b\nruns: [{tree: straight, params: {distance: true}}]\n")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    # was: parameter 'distance': '1' needs a unit: write it as e.g. '1 m'
    assert f"{spec}:2:34: parameter 'distance': not a quantity: 'true'" in err, err


@pytest.mark.parametrize("name", ["/dev/zero", "/dev/null", "fifo"])
def test_campaign_report_refuses_a_device_or_a_pipe(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    # /dev/zero was read until the kernel killed the command (exit 137), and the report
    # would have gone into /dev; a FIFO waited for ever
    from tests.hostile_support import no_hang

    path = Path(name)
    if name == "fifo":
        path = tmp_path / "results.jsonl"
        os.mkfifo(path)
    with contextlib.contextmanager(no_hang)(20):
        assert main(["campaign", "report", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a file of results" in err, err
    refused(lambda: read_rows(path), "not a file of results")


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        # each was "max_time: Input should be a valid string": nothing of what to write
        ("max_time: 600", "max_time: give a time with its unit, e.g. '600 s', not 600"),
        ("rate: .nan", "rate: give a frequency with its unit, e.g. '20 Hz', not nan"),
        ("case_timeout: null", "case_timeout: give a time with its unit, e.g. '300 s', not null"),
        ("case_timeout: [1]", "case_timeout: give a time with its unit, e.g. '300 s', not a list"),
    ],
)
def test_a_limit_without_its_unit_says_what_to_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, expected: str
) -> None:
    spec = tmp_path / "l.campaign.yaml"
    spec.write_text(f"name: l\nruns: [{{tree: straight}}]\n{line}\n", encoding="utf-8")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{spec}:3:1: {expected}") and err.count("\n") == 1, err


@pytest.mark.parametrize(
    ("line", "place"),
    [
        # each was refused as "Input should be less than or equal to 1" (or 10); then
        # as "Input should be a finite number", naming no key and not the value
        ("link: {drop: [.nan]}", "4:15: drop: must be a finite number, not nan"),
        ("link: {corrupt: [0, .inf]}", "4:21: corrupt: must be a finite number, not inf"),
        ("as_built: {count: 2, scale: .nan}", "4:22: scale: must be a finite number, not nan"),
    ],
)
def test_a_nan_or_infinite_rate_or_scale_is_called_what_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, place: str
) -> None:
    run = "{route: bend-right}" if "as_built" in line else "{tree: straight}"
    spec = tmp_path / "n.campaign.yaml"
    spec.write_text(f"name: n\nruns:\n  - {run}\n{line}\n", encoding="utf-8")
    assert main(["validate", str(spec)]) == 2
    err = capsys.readouterr().err
    assert err == f"{spec}:{place}\n", err


HELPER = """
import os, pathlib, time

def cut(case, trace_dir=None):
    trace = pathlib.Path(trace_dir) / f"{case['id']}.jsonl"
    trace.parent.mkdir(parents=True, exist_ok=True)
    trace.write_text('{"type": "header"}\\n{"type": "tick", "cut')
    if case["index"] == 0:
        time.sleep(120)  # killed at its wall-time limit
    os._exit(3)  # a crash
"""


def test_a_killed_or_crashed_case_names_the_trace_it_left(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # its row said trace: null while traces/ID.jsonl, cut, held what it did before
    (tmp_path / "p8_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    out = tmp_path / "out"
    result = run_campaign(SPEC, workers=2, output=out, target="p8_helper:cut", case_timeout="2 s")
    rows = {row["index"]: row for row in result.rows}
    assert (rows[0]["outcome"], rows[1]["outcome"]) == ("timeout", "error")
    for row in rows.values():
        assert row["trace"] == str((out / "traces" / f"{row['id']}.jsonl").resolve())
        assert Path(row["trace"]).is_file()


@pytest.mark.parametrize(
    ("axes", "words"),
    [
        # null is the bundled robot, which is hardware/pirate.yaml
        ({"robots": [None, "hardware/pirate.yaml"]}, "robots[1] repeats robots[0]"),
        # null is the truth = the run's own map, here bend-right
        (
            {"runs": [{"route": "bend-right"}], "maps": [None, "bend-right"]},
            "maps[1] repeats maps[0] (the map)",
        ),
        # a tree's network defaults to straight
        (
            {
                "runs": [
                    {"tree": "straight", "params": {"distance": "0.2 m"}},
                    {
                        "name": "b",
                        "tree": "straight",
                        "network": "straight",
                        "params": {"distance": "0.2 m"},
                    },
                ]
            },
            "runs[1] repeats runs[0] ('straight') under another name",
        ),
        # a route's network defaults to its own network line
        (
            {
                "runs": [
                    {"route": "bend-right"},
                    {"name": "b", "route": "bend-right", "network": "bend-right"},
                ]
            },
            "runs[1] repeats runs[0] ('bend-right') under another name",
        ),
    ],
)
def test_an_entry_that_names_its_axis_default_repeats_a_null_entry(
    monkeypatch: pytest.MonkeyPatch, axes: dict[str, object], words: str
) -> None:
    # each ran: the same deterministic cases counted twice as independent samples
    monkeypatch.chdir(Path(__file__).resolve().parent.parent)
    spec = {**SPEC, **axes}
    refused(lambda: run_campaign(spec, executor=InstantExecutor()), words)


def test_maps_that_differ_for_some_run_are_not_a_repeat() -> None:
    # null is each run's own map: bend-right for one run, t-joint for the other
    runs = [{"route": "bend-right"}, {"route": "t-joint"}]
    spec = {"name": "m", "runs": runs, "maps": [None, "bend-right"]}
    assert run_campaign(spec, executor=InstantExecutor()).cases == 4


@pytest.mark.parametrize("target", ["nosuch", "a:b:c", "mod:", ":f", "a b:c", None])
def test_a_target_that_is_no_module_function_is_refused_before_any_case(target: object) -> None:
    # each case died of it ("case process died (exit status 1): ..."), one error row each
    pool = InstantExecutor()
    refused(lambda: run_campaign(SPEC, executor=pool, target=target), "target: ")  # type: ignore[arg-type]
    assert pool.ids == []


def test_the_markdown_report_keeps_its_table_and_lists_whatever_the_names_hold(
    tmp_path: Path,
) -> None:
    # a run named 'a|b' split the group's row into an extra column; a reason with a
    # newline ended its list item ("# heading" became a heading); a node name with a
    # backtick ended its code span
    from pirate_bt.campaign.case import error_record
    from pirate_bt.campaign.report import write_report

    case = {
        "id": "000000-aaaaaaaa", "index": 0, "run": "a|b", "tree": "straight", "params": {},
        "seed": 0, "drop": 0.0, "corrupt": 0.0, "dup": 0.0, "sim_faults": [],
    }  # fmt: skip
    row = error_record(case, "failed-safe", "first line\n# heading | x", 1.0)
    row["failing_node"] = "seq/odd`name"
    write_report([row], tmp_path)
    md = (tmp_path / "report.md").read_text(encoding="utf-8").splitlines()
    header = next(line for line in md if line.startswith("| group"))
    group = next(line for line in md if line.startswith("| a"))
    assert group.replace("\\|", "").count("|") == header.count("|"), group
    assert "- 1 × first line # heading | x" in md
    assert not any(line.startswith("# heading") for line in md)
    assert "- 1 × ``seq/odd`name``" in md
