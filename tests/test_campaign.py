"""Campaigns: the file kind, isolation of cases, resume, the report's statistics."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from pirate_bt.campaign import expand, load_campaign, make_executor, read_rows, run_cases
from pirate_bt.campaign.report import write_report
from pirate_bt.campaign.stats import group_stats, percentile, wilson_interval
from pirate_bt.campaign.workers import idle_servers
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed

ROOT = Path(__file__).resolve().parents[1]

SMALL = """\
name: small
runs:
  - {name: straight, tree: straight, network: straight, params: {distance: 0.2 m}}
link:
  drop: [0.0, 0.2]
seeds: {start: 0, count: 2}
max_time: 60 s
case_timeout: 120 s
"""


def _write(tmp_path: Path, text: str, name: str = "c.campaign.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


# --- the file kind ------------------------------------------------------------


def test_shipped_examples_validate(capsys: pytest.CaptureFixture[str]) -> None:
    files = sorted((ROOT / "scenarios" / "campaigns").glob("*.campaign.yaml"))
    assert len(files) >= 3
    assert main(["validate", *map(str, files)]) == 0
    sizes = {f.name: load_campaign(f).size() for f in files}
    assert sizes["pab-1000.campaign.yaml"] >= 1000


def test_schema_is_printed(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", "campaign"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["additionalProperties"] is False
    assert "runs" in schema["required"]


@pytest.mark.parametrize(
    ("text", "where", "words"),
    [
        ("name: x\nruns:\n  - {tree: bend}\nseedz: {count: 2}\n", ":4:1", "seedz"),
        (
            "name: x\nruns:\n  - {tree: bend}\nlink:\n  drop: [0.1, 1.5]\n",
            ":5:15",
            "drop: must be at most 1, not 1.5",
        ),
        ("name: x\nruns:\n  - {tree: bend, route: lab}\n", ":3:", "exactly one"),
        ("name: x\nruns: []\n", ":2:", "at least 1"),
        ("name: x\nruns:\n  - {tree: bend}\nmax_time: 5 kg\n", ":4:", "max_time"),
        ("name: x\nruns:\n  - {tree: bend}\nmaps: [lab]\n", ":4:1", "routes and navigators only"),
        ("name: x\nruns:\n  - {tree: bend}\nsim_faults: [[stall@1s]]\n", ":4:15", "stall"),
    ],
)
def test_bad_campaign_files_are_located_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, where: str, words: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ValidationFailed):
        load_campaign(path)
    assert main(["campaign", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}{where}" in err and words in err
    assert not (tmp_path / "campaign-x").exists()


def test_expansion_is_ordered_and_ids_are_stable(tmp_path: Path) -> None:
    spec = load_campaign(_write(tmp_path, SMALL))
    cases = expand(spec, tmp_path)
    assert len(cases) == spec.size() == 4
    assert [(c["drop"], c["seed"]) for c in cases] == [(0.0, 0), (0.0, 1), (0.2, 0), (0.2, 1)]
    assert [c["id"] for c in cases] == [c["id"] for c in expand(spec, tmp_path)]


# --- isolation ------------------------------------------------------------------

HELPER = """
import ctypes, os, time

def behave(case, trace_dir):
    what = case["run"]
    if what == "raise":
        raise RuntimeError("boom in the case")
    if what == "hang":
        time.sleep(600)
    if what == "crash":
        os._exit(7)
    if what == "segfault":
        ctypes.string_at(0)
    # forked from a case server (tests/test_campaign_workers.py has the rest of the model)
    try:
        with open(f"/proc/{os.getppid()}/cmdline", "rb") as f:
            server = b"pirate_bt.campaign.child" in f.read()
    except OSError:  # no /proc: taken on trust
        server = True
    return {"id": case["id"], "index": case["index"], "run": what, "outcome": "success",
            "reason": "fine", "seed": case["seed"], "server": server}
"""


HANG_LIMIT_S = 2.0
"""The wall-time limit of the fake cases that include a hang: the hang takes all of it.

The other fake cases end within milliseconds of their process's start (a raise, an
exit, a record), so a short limit is still far beyond them."""


def _fake_cases(names: list[str], timeout_s: float = 30.0) -> list[dict[str, object]]:
    return [
        {"id": f"{i:06d}-x", "index": i, "run": n, "seed": 0, "timeout_s": timeout_s}
        for i, n in enumerate(names)
    ]


def test_a_raise_a_hang_and_a_crash_are_outcomes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "campaign_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    cases = _fake_cases(["ok", "raise", "hang", "crash", "ok"], timeout_s=HANG_LIMIT_S)
    with make_executor(workers=2) as (executor, _what):
        rows = run_cases(cases, tmp_path / "out", executor, target="campaign_helper:behave")
    by_run = {r["index"]: r for r in rows}
    assert [by_run[i]["outcome"] for i in range(5)] == [
        "success",
        "error",
        "timeout",
        "error",
        "success",
    ]
    assert "boom in the case" in by_run[1]["reason"]
    assert f"{HANG_LIMIT_S:g} s wall-time limit" in by_run[2]["reason"]
    assert "exit status 7" in by_run[3]["reason"]
    assert len(read_rows(tmp_path / "out" / "results.jsonl")) == 5


def test_results_are_not_overwritten_without_resume(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.jsonl").write_text('{"id": "000000-x", "index": 0}\n{"id": "cut', "utf-8")
    assert main(["campaign", str(_write(tmp_path, SMALL)), "--output", str(out)]) == 2
    assert read_rows(out / "results.jsonl") == [{"id": "000000-x", "index": 0}]


# --- real runs: interruption, resume, local against Dask ---------------------------


def _strip(rows: list[dict[str, object]]) -> list[dict[str, object]]:
    # wall-clock figures differ from run to run: the ticks over their wall-time budget too
    wall = ("wall_time_s", "trace", "overruns")
    return [{k: v for k, v in r.items() if k not in wall} for r in rows]


@pytest.mark.usefixtures("ctrl_c_reaches_children")
def test_interrupt_then_resume_runs_each_case_once(tmp_path: Path) -> None:
    # cases of a few seconds each, so that the interrupt lands in the middle of the
    # campaign even when its workers start once and a case takes a fraction of a second
    spec = _write(tmp_path, SMALL.replace("count: 2", "count: 3").replace("0.2 m", "2 m"))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "pirate_bt", "campaign", str(spec), "--workers", "1"]
    command += ["--output", str(out), "--quiet"]
    proc = subprocess.Popen(command, start_new_session=True, stderr=subprocess.PIPE, text=True)
    results = out / "results.jsonl"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and len(read_rows(results)) < 1:
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C reaches the whole foreground group
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "--resume" in err
    first = read_rows(results)
    assert 1 <= len(first) < 6
    assert not (out / "report.md").exists()
    assert main(["campaign", str(spec), "--output", str(out), "--resume", "--quiet"]) == 0
    rows = read_rows(results)
    assert sorted(r["index"] for r in rows) == list(range(6))
    assert {r["outcome"] for r in rows} == {"success"}
    assert (out / "report.md").exists() and (out / "results.csv").exists()


@pytest.mark.slow
def test_local_and_dask_cluster_give_the_same_rows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    distributed = pytest.importorskip("distributed")
    from pirate_bt.campaign.cluster import PLUGIN_NAME

    (tmp_path / "campaign_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    spec_path = _write(tmp_path, SMALL)
    spec = load_campaign(spec_path)
    cases = expand(spec, tmp_path)
    with make_executor(workers=1) as (executor, _):
        local = run_cases(cases, tmp_path / "local", executor)
    # The scheduler writes its own scheduler file when it starts, as `dask scheduler
    # --scheduler-file` does. (Client.write_scheduler_file is not used: once tasks have
    # run, distributed 2026.8's scheduler_info() holds metrics keyed by tuples, which
    # its json.dump refuses.)
    scheduler_file = tmp_path / "scheduler.json"
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        scheduler_kwargs={"scheduler_file": str(scheduler_file)},
    ) as cluster:
        assert main(
            ["campaign", str(spec_path), "--scheduler", cluster.scheduler_address, "--quiet",
             "--output", str(tmp_path / "dask")]
        ) == 0  # fmt: skip
        # The same isolation on the cluster (reached by its scheduler file this time):
        # each case forked from the worker's case server; a hang is killed, a raise,
        # a crash and a segfault recorded, and no Dask worker dies of any of them.
        assert scheduler_file.exists()
        with distributed.Client(cluster) as client:
            workers = set(client.scheduler_info()["workers"])
            # the first campaign's plugin started a server per worker thread; they stay
            assert client.run(idle_servers) == dict.fromkeys(workers, 1)
        with make_executor(scheduler_file=str(scheduler_file)) as (executor, what):
            assert "Dask cluster" in what
            odd = run_cases(
                _fake_cases(["hang", "raise", "crash", "segfault", "ok", "ok"], HANG_LIMIT_S),
                tmp_path / "odd",
                executor,
                target="campaign_helper:behave",
            )
        assert [r["outcome"] for r in odd] == ["timeout", "error", "error", "error"] + [
            "success"
        ] * 2
        assert "boom in the case" in odd[1]["reason"]
        assert "exit status 7" in odd[2]["reason"] and "killed by SIGSEGV" in odd[3]["reason"]
        assert odd[4]["server"] and odd[5]["server"]
        with distributed.Client(cluster) as client:
            assert set(client.scheduler_info()["workers"]) == workers  # the same two workers
            assert client.run(idle_servers) == dict.fromkeys(workers, 1)
            client.unregister_worker_plugin(PLUGIN_NAME)  # its tear-down stops them
            assert client.run(idle_servers) == dict.fromkeys(workers, 0)
    dask_rows = read_rows(tmp_path / "dask" / "results.jsonl")
    assert len(local) == 4
    assert _strip(sorted(dask_rows, key=lambda r: r["index"])) == _strip(local)
    assert any(r["retries"] > 0 for r in local if r["drop"] > 0)


def test_missing_scheduler_is_bad_input(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = _write(tmp_path, SMALL)
    nobody = ["--scheduler", "tcp://127.0.0.1:9", "--quiet"]
    monkeypatch.chdir(tmp_path)  # the default output folder, campaign-small/, is made here
    code = main(["campaign", str(spec), *nobody, "--scheduler-timeout", "1 s"])
    assert code == 2
    err = capsys.readouterr().err
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in err, err
    assert "after 1 s" in err  # as long as asked, not the default 10 s
    # nothing ran: the folder the command made is taken away again (it was left empty,
    # in the repository's root when the suite ran from there)
    assert not (tmp_path / "campaign-small").exists()
    assert main(["campaign", str(spec), *nobody, "--scheduler-timeout", "0 s"]) == 2
    assert "--scheduler-timeout must be positive" in capsys.readouterr().err  # its option


# --- statistics and the report -------------------------------------------------------


@pytest.mark.parametrize(
    ("k", "n", "low", "high"),
    [
        (0, 10, 0.0, 0.2775),  # the textbook "0 of 10" bound
        (5, 10, 0.2366, 0.7634),
        (10, 10, 0.7225, 1.0),
        (81, 263, 0.2553, 0.3662),  # Wilson (1927) / Newcombe (1998) worked example
        (0, 1000, 0.0, 0.00383),
    ],
)
def test_wilson_interval_matches_known_values(k: int, n: int, low: float, high: float) -> None:
    got = wilson_interval(k, n)
    assert got[0] == pytest.approx(low, abs=5e-5)
    assert got[1] == pytest.approx(high, abs=5e-5)


def test_percentiles_and_groups() -> None:
    assert percentile([], 50) is None
    assert percentile([1.0, 2.0, 3.0, 4.0], 50) == 2.5
    assert percentile([float(i) for i in range(101)], 95) == 95.0
    rows = [
        {"index": i, "run": "bend", "drop": 0.1, "corrupt": 0, "dup": 0, "seed": i,
         "outcome": o, "reason": "r", "failing_node": "bend/pass", "sim_time_s": 10.0 + i}
        for i, o in enumerate(["success", "success", "failed-safe", "error"])
    ]  # fmt: skip
    (group,) = group_stats(rows)
    assert (group.n, group.success, group.failed_safe, group.errors) == (4, 2, 1, 1)
    assert group.nodes["bend/pass"] == 2


def test_report_files(tmp_path: Path) -> None:
    rows = [
        {"id": f"{i:06d}-a", "index": i, "run": run, "drop": drop, "corrupt": 0.0, "dup": 0.0,
         "seed": i, "outcome": "success" if i % 3 else "failed-safe", "reason": "clamp lost",
         "failing_node": None, "sim_time_s": 40.0, "violations": 0, "damage": 0,
         "retries": 2}
        for i, (run, drop) in enumerate(
            [(r, d) for r in ("bend", "t-joint") for d in (0.0, 0.1, 0.2) for _ in range(5)]
        )
    ]  # fmt: skip
    files = write_report(rows, tmp_path, title="t", command="pirate-bt campaign x")
    names = {p.name for p in files}
    assert {"report.md", "report.html", "results.csv", "success_vs_drop.png"} <= names
    md = (tmp_path / "report.md").read_text()
    assert "| bend drop=0.1 corrupt=0 dup=0 | 5 |" in md
    assert "clamp lost" in md and "pirate-bt campaign x" in md
    csv_lines = (tmp_path / "results.csv").read_text().splitlines()
    assert len(csv_lines) == 31 and "retries" in csv_lines[0]
    assert main(["campaign", "report", str(tmp_path / "results.csv")]) == 2


def test_a_bad_tree_parameter_stops_the_campaign_before_any_case(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    spec = _write(tmp_path, SMALL.replace("distance: 0.2 m", "distanse: 0.2 m"))
    out = tmp_path / "out"
    assert main(["campaign", str(spec), "--output", str(out), "--quiet"]) == 2
    assert "unknown parameter 'distanse'" in capsys.readouterr().err
    assert not (out / "results.jsonl").exists()


def test_read_rows_keeps_one_row_per_case(tmp_path: Path) -> None:
    path = tmp_path / "results.jsonl"
    path.write_text(
        '{"id": "a", "outcome": "success"}\n{"id": "b"}\n{"id": "a", "outcome": "error"}\n{"id',
        encoding="utf-8",
    )
    assert read_rows(path) == [{"id": "a", "outcome": "success"}, {"id": "b"}]
