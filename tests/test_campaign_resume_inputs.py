"""``--resume`` continues only the campaign that wrote the rows, inputs and timeout included.

A campaign records, as it first writes its folder, a SHA-256 of every input file its
checks read and the case timeout its cases run with (``OUT/campaign.json``). A resume
refuses (exit 2, one line, nothing rewritten) an input edited since then, and a
``--case-timeout`` other than the one it started with; it was accepted, and the rows
of the old file and the new one (or of two timeouts) were mixed in one results file.
The ``overruns`` counter is wall time: it is no part of what makes a row a case's.

Most tests run no case (an executor that records every case a success at once, or a
refusal before any worker starts); one runs a short real case through the command.
"""

from __future__ import annotations

import json
import re
import shutil
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import read_rows, run_campaign
from pirate_bt.campaign.report import write_report
from pirate_bt.cli import main
from pirate_bt.errors import InputError
from tests.hostile_support import InstantExecutor

ROOT = Path(__file__).resolve().parents[1]

AGAIN = "rerun without --resume into another --output"

TREE = """\
name: tree
runs:
  - {name: s, tree: my.yaml, network: net.yaml, params: {distance: 0.2 m}}
robots: [robot.yaml]
seeds: {start: 0, count: 2}
max_time: 60 s
case_timeout: 120 s
"""

ROUTE = """\
name: route
runs:
  - {name: lab, route: scenarios/lab.route}
seeds: {start: 0, count: 2}
"""

NAVIGATOR = """\
name: nav
runs:
  - {name: r, navigator: route, network: scenarios/lab.yaml, params: {route: scenarios/lab.route}}
seeds: {start: 0, count: 2}
"""


class Recording(InstantExecutor):
    """:class:`InstantExecutor` that also notes each case's wall-time limit."""

    def __init__(self) -> None:
        super().__init__()
        self.timeouts: list[float] = []

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
        self.timeouts.append(args[0]["timeout_s"])
        return super().submit(fn, *args, **kwargs)


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A working folder with copies of the inputs the specs name, as a user's project."""
    shutil.copy(ROOT / "trees" / "straight.yaml", tmp_path / "my.yaml")
    shutil.copytree(ROOT / "trees" / "lib", tmp_path / "lib")
    shutil.copy(ROOT / "scenarios" / "straight.yaml", tmp_path / "net.yaml")
    shutil.copy(ROOT / "hardware" / "pirate.yaml", tmp_path / "robot.yaml")
    (tmp_path / "scenarios").mkdir()
    for name in ("lab.route", "lab.yaml"):
        shutil.copy(ROOT / "scenarios" / name, tmp_path / "scenarios" / name)
    for name, text in (("tree", TREE), ("route", ROUTE), ("nav", NAVIGATOR)):
        (tmp_path / f"{name}.campaign.yaml").write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _started(spec: str, out: Path, **options: Any) -> bytes:
    """``out`` as a campaign of ``spec`` interrupted after its first case leaves it:
    its record written, one row of two; the results file's bytes."""
    run_campaign(spec, output=out, executor=InstantExecutor(), **options)
    results = out / "results.jsonl"
    first = results.read_bytes().splitlines(keepends=True)[0]
    results.write_bytes(first)
    return first


def _edit(path: Path) -> None:
    with path.open("a", encoding="utf-8") as stream:
        stream.write("# edited after the campaign started\n")


def _one_line(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    assert captured.out == ""  # refused before the "campaign NAME: N cases on ..." line
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err, captured.err
    return captured.err.strip().removeprefix("pirate-bt: ")


# --- 1. an input file edited between the first run and the resume --------------------


def test_a_real_campaign_refuses_to_resume_after_a_subtree_file_is_edited(
    here: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = TREE.replace("count: 2", "count: 1")
    (here / "one.campaign.yaml").write_text(spec, encoding="utf-8")
    command = ["campaign", "one.campaign.yaml", "--workers", "1", "--output", "out", "--quiet"]
    assert main(command) == 0
    capsys.readouterr()
    record = json.loads((here / "out" / "campaign.json").read_text("utf-8"))
    files = [Path(entry["file"]) for entry in record["inputs"]]
    assert here / "my.yaml" in files and here / "lib" / "hold.yaml" in files
    results = (here / "out" / "results.jsonl").read_bytes()
    hold = (here / "lib" / "hold.yaml").read_bytes()
    _edit(here / "lib" / "hold.yaml")  # a file the tree's subtrees pull in
    # was: exit 0, and the rows of the old subtree and the new one mixed in one file
    assert main([*command, "--resume"]) == 2
    assert _one_line(capsys) == f"lib/hold.yaml: changed since the campaign in out started; {AGAIN}"
    assert (here / "out" / "results.jsonl").read_bytes() == results
    (here / "lib" / "hold.yaml").write_bytes(hold)  # the same content again: resumed
    assert main([*command, "--resume"]) == 0
    assert (here / "out" / "results.jsonl").read_bytes() == results


@pytest.mark.parametrize(
    ("spec", "edited"),
    [
        ("route.campaign.yaml", "scenarios/lab.route"),
        ("route.campaign.yaml", "scenarios/lab.yaml"),  # the route's own network line
        ("nav.campaign.yaml", "scenarios/lab.route"),  # a navigator parameter's file
        ("tree.campaign.yaml", "my.yaml"),
        ("tree.campaign.yaml", "net.yaml"),
        ("tree.campaign.yaml", "robot.yaml"),
    ],
)
def test_resume_refuses_an_input_edited_since_the_campaign_started(
    here: Path, capsys: pytest.CaptureFixture[str], spec: str, edited: str
) -> None:
    first = _started(spec, Path("out"))
    record = (here / "out" / "campaign.json").read_bytes()
    _edit(here / edited)
    assert main(["campaign", spec, "--output", "out", "--resume", "--quiet"]) == 2
    assert _one_line(capsys) == f"{edited}: changed since the campaign in out started; {AGAIN}"
    assert (here / "out" / "results.jsonl").read_bytes() == first  # nothing written
    assert (here / "out" / "campaign.json").read_bytes() == record
    pool = InstantExecutor()
    with pytest.raises(InputError, match="^" + re.escape(f"{edited}: changed since")):
        run_campaign(spec, output="out", resume=True, executor=pool)
    assert pool.ids == []


def test_an_unchanged_campaign_resumes_and_runs_only_what_is_missing(here: Path) -> None:
    _started("tree.campaign.yaml", Path("out"))
    record = (here / "out" / "campaign.json").read_bytes()
    (here / "my.yaml").touch()  # a newer time, the same content
    pool = InstantExecutor()
    result = run_campaign("tree.campaign.yaml", output="out", resume=True, executor=pool)
    assert len(pool.ids) == 1 and result.cases == 2
    assert (here / "out" / "campaign.json").read_bytes() == record  # as the campaign started


def test_several_edited_inputs_are_one_line_naming_the_first(here: Path) -> None:
    _started("tree.campaign.yaml", Path("out"))
    _edit(here / "net.yaml")
    _edit(here / "robot.yaml")
    with pytest.raises(InputError) as info:
        run_campaign("tree.campaign.yaml", output="out", resume=True, executor=InstantExecutor())
    assert str(info.value) == (
        "net.yaml: changed since the campaign in out started (and 1 more input file);"
        " rerun without resume=True into another output="
    )


def test_a_folder_written_before_records_existed_resumes_unchecked(here: Path) -> None:
    _started("tree.campaign.yaml", Path("out"))
    (here / "out" / "campaign.json").unlink()
    _edit(here / "my.yaml")
    pool = InstantExecutor()
    result = run_campaign("tree.campaign.yaml", output="out", resume=True, executor=pool)
    assert len(pool.ids) == 1 and result.cases == 2
    # no record made now: it could not say what the earlier rows were run with
    assert not (here / "out" / "campaign.json").exists()


def test_a_record_that_is_not_one_is_refused_on_resume(
    here: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _started("tree.campaign.yaml", Path("out"))
    (here / "out" / "campaign.json").write_text('{"format": 1, "inputs": "x"}', "utf-8")
    assert main(["campaign", "tree.campaign.yaml", "--output", "out", "--resume"]) == 2
    assert _one_line(capsys) == (
        f"{Path('out') / 'campaign.json'}: not the record a campaign writes as it starts"
        f" (no case_timeout_s); {AGAIN}"
    )
    assert (here / "out" / "results.jsonl").read_bytes() == first


def test_a_new_campaign_into_an_empty_folder_records_its_inputs_afresh(here: Path) -> None:
    run_campaign("tree.campaign.yaml", output="out", executor=InstantExecutor())
    (here / "out" / "results.jsonl").write_bytes(b"")  # stopped before any row
    _edit(here / "my.yaml")
    run_campaign("tree.campaign.yaml", output="out", resume=True, executor=InstantExecutor())
    assert len(read_rows(here / "out" / "results.jsonl")) == 2
    _edit(here / "my.yaml")  # and again: the record is the second start's
    with pytest.raises(InputError, match=r"^my\.yaml: changed since"):
        run_campaign("tree.campaign.yaml", output="out", resume=True, executor=InstantExecutor())


# --- 2. --case-timeout on resume -------------------------------------------------------


def test_resume_refuses_another_case_timeout_as_it_refuses_an_edited_spec(
    here: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _started("tree.campaign.yaml", Path("out"))  # the spec's 120 s
    command = ["campaign", "tree.campaign.yaml", "--output", "out", "--resume", "--quiet"]
    # was: exit 0, the second case killed after 60 s where the first had 120 s
    assert main([*command, "--case-timeout", "60 s"]) == 2
    assert _one_line(capsys) == (
        f"--case-timeout: 60 s is not the 120 s the campaign in out started with; leave it"
        f" out, or {AGAIN}"
    )
    assert (here / "out" / "results.jsonl").read_bytes() == first
    pool = Recording()
    with pytest.raises(InputError, match=r"^case_timeout: 60 s is not the 120 s"):
        run_campaign(
            "tree.campaign.yaml", output="out", resume=True, case_timeout=60, executor=pool
        )
    assert pool.ids == []
    # the same limit, however written, is the campaign's own
    run_campaign(
        "tree.campaign.yaml", output="out", resume=True, case_timeout="2 min", executor=pool
    )
    assert pool.timeouts == [120.0]


def test_resume_keeps_the_case_timeout_the_campaign_started_with(here: Path) -> None:
    _started("tree.campaign.yaml", Path("out"), case_timeout="30 s")
    pool = Recording()
    with pytest.raises(InputError, match=r"^case_timeout: 120 s is not the 30 s"):
        # the spec's own value is another limit than the one the campaign ran with
        run_campaign(
            "tree.campaign.yaml", output="out", resume=True, case_timeout=120, executor=pool
        )
    run_campaign("tree.campaign.yaml", output="out", resume=True, executor=pool)
    assert pool.timeouts == [30.0]  # left out: the campaign's, not the spec's 120 s


def test_an_edited_spec_case_timeout_is_still_refused_by_its_rows(here: Path) -> None:
    _started("tree.campaign.yaml", Path("out"))
    (here / "tree.campaign.yaml").write_text(TREE.replace("120 s", "60 s"), encoding="utf-8")
    with pytest.raises(InputError, match=r"results\.jsonl:1: 1 row of 1 is not a case"):
        run_campaign("tree.campaign.yaml", output="out", resume=True, executor=InstantExecutor())


# --- 3. overruns are wall time ----------------------------------------------------------


def test_overruns_are_no_part_of_a_rows_identity(here: Path) -> None:
    run_campaign("tree.campaign.yaml", output="out", executor=InstantExecutor())
    results = here / "out" / "results.jsonl"
    rows = [json.loads(line) for line in results.read_text("utf-8").splitlines()]
    rows[0]["overruns"] = 7  # another machine, another load: another count
    results.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    pool = InstantExecutor()
    result = run_campaign("tree.campaign.yaml", output="out", resume=True, executor=pool)
    assert pool.ids == [] and result.cases == 2  # both rows still the cases'


def test_the_report_says_overruns_are_wall_time(tmp_path: Path) -> None:
    rows = [
        {"id": f"00000{i}-x", "index": i, "run": "s", "outcome": "success", "overruns": i}
        for i in range(2)
    ]
    write_report(rows, tmp_path, title="t")
    assert "| tick overruns (wall time) | 1 | 1 |" in (tmp_path / "report.md").read_text("utf-8")


# --- 4. another name: the report would go under it, campaign.json keep the old ---------


def test_a_resume_under_another_name_is_refused(
    here: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _started("tree.campaign.yaml", here / "out")
    renamed = here / "renamed.campaign.yaml"
    renamed.write_text(TREE.replace("name: tree", "name: other"), encoding="utf-8")
    command = ["campaign", str(renamed), "--output", "out", "--resume", "--quiet"]
    # was: resumed, the report rewritten as campaign 'other', campaign.json still 'tree'
    assert main(command) == 2
    assert _one_line(capsys) == (
        f"name: 'other' is not 'tree', the campaign in out; name it 'tree' to resume it, or {AGAIN}"
    )
    assert (here / "out" / "results.jsonl").read_bytes() == first
    assert json.loads((here / "out" / "campaign.json").read_text("utf-8"))["campaign"] == "tree"
    # the same cases under the name it started with resume
    run_campaign("tree.campaign.yaml", output=here / "out", resume=True, executor=InstantExecutor())
    assert len(read_rows(here / "out" / "results.jsonl")) == 2
