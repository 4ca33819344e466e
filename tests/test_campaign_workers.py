"""Campaign workers that start once (issue 27): each case forked from a long-lived case server.

A case that raises, crashes, segfaults, hangs past its limit, leaves processes
behind or kills its server is that case's outcome alone; nothing a case does
lives on in the next case of the same worker; resume still runs each case once.
The Dask side of the same model is in tests/test_campaign.py (the local-against-
Dask test). No timed assertions: speed is benchmarks/bench_campaign.py's.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import campaign_from_data, expand, make_executor, read_rows, run_cases
from pirate_bt.campaign.workers import stop_servers

HELPER = textwrap.dedent(
    """
    import ctypes, json, logging, os, signal, subprocess, sys, time
    from pathlib import Path


    def _server():
        # The process this case process was forked from, as /proc tells it.
        with open(f"/proc/{os.getppid()}/cmdline", "rb") as f:
            return f.read().split(b"\\0")[1:3] == [b"-m", b"pirate_bt.campaign.child"]


    def _record(case, **extra):
        return {"id": case["id"], "index": case["index"], "run": case["run"],
                "outcome": "success", "reason": "fine", "seed": case["seed"],
                "server_pid": os.getppid(), "forked_from_server": _server(), **extra}


    def _log(case):
        log = os.environ.get("CAMPAIGN_TEST_LOG")
        if log:
            with open(log, "a", encoding="utf-8") as f:
                f.write(f"{case['id']} {os.getpid()}\\n")


    def behave(case, trace_dir):
        _log(case)
        what = case["run"]
        if what == "raise":
            raise RuntimeError("boom in the case")
        if what == "crash":
            print("dying now", file=sys.stderr, flush=True)
            os._exit(7)
        if what == "segfault":
            ctypes.string_at(0)
        if what in ("hang", "orphan"):
            # a child in the case's process group: it must not outlive the case
            child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
            Path(case["pid_file"]).write_text(str(child.pid))
            if what == "hang":
                time.sleep(600)
        if what == "kill-server":
            os.kill(os.getppid(), signal.SIGKILL)
            time.sleep(2)
        if what == "dirty":
            # leave every kind of global state behind
            import py_trees
            from pirate_bt.sim import simulator
            from pirate_bt.treefile.registry import default_registry
            py_trees.blackboard.Blackboard.set("/leaked", 42)
            logging.getLogger().addHandler(logging.StreamHandler())
            default_registry().register("Leaked", "pirate_bt.behaviours.basic:Wait")
            simulator._REGISTRY["leaked"] = object()
            next(simulator._NAMES)
            os.environ["LEAKED"] = "1"
            sys.modules["leaked_module"] = type(sys)("leaked_module")
        if what in ("probe", "dirty"):
            import py_trees
            from pirate_bt.sim import simulator
            from pirate_bt.treefile.registry import default_registry
            seen = {
                "blackboard": sorted(py_trees.blackboard.Blackboard.storage),
                "handlers": len(logging.getLogger().handlers),
                "registry": "Leaked" in default_registry(),
                "sims": sorted(simulator._REGISTRY),
                "next_sim_name": next(simulator._NAMES),
                "env": os.environ.get("LEAKED"),
                "module": "leaked_module" in sys.modules,
            }
            return _record(case, seen=seen)
        return _record(case)


    def real(case, trace_dir):
        from pirate_bt.campaign.case import run_case
        return {**run_case(case, trace_dir), "server_pid": os.getppid(),
                "forked_from_server": _server()}
    """
)


TARGET = "campaign_helper:behave"


@pytest.fixture
def helper(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``campaign_helper`` importable by the workers (they inherit PYTHONPATH)."""
    (tmp_path / "campaign_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    return tmp_path


HANG_LIMIT_S = 2.0
"""The wall-time limit of the fake cases that include a hang: the hang takes all of it.

The other fake cases end within milliseconds of their process's start (a raise, an
exit, a record, a child started), so a short limit is still far beyond them."""


def _cases(names: list[str], folder: Path, timeout_s: float = 30.0) -> list[dict[str, Any]]:
    return [
        {"id": f"{i:06d}-x", "index": i, "run": n, "seed": 0, "timeout_s": timeout_s,
         "pid_file": str(folder / f"pid-{i}")}
        for i, n in enumerate(names)
    ]  # fmt: skip


def _dead(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat", encoding="utf-8") as f:
            return f.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")  # or a zombie
    except FileNotFoundError:
        return True


def _gone(pid: int) -> bool:
    """Whether the process is dead, or dies within the next moments (a SIGKILL in flight)."""
    for _ in range(100):
        if _dead(pid):
            return True
        time.sleep(0.05)
    return False


needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")


@needs_proc
def test_crashes_and_hangs_stay_in_their_case_and_the_server_stays(helper: Path) -> None:
    """One worker, one server: every kind of end, and the server forks on."""
    names = ["ok", "raise", "crash", "segfault", "hang", "orphan", "ok"]
    cases = _cases(names, helper, timeout_s=HANG_LIMIT_S)
    with make_executor(workers=1) as (executor, _):
        rows = run_cases(cases, helper / "out", executor, target=TARGET)
    by = {r["run"] + str(r["index"]): r for r in rows}
    assert [r["outcome"] for r in rows] == [
        "success", "error", "error", "error", "timeout", "success", "success"
    ]  # fmt: skip
    assert "boom in the case" in by["raise1"]["reason"]
    assert by["crash2"]["reason"].startswith(
        "case process died (exit status 7) in run 'crash', seed 0: dying now"
    )
    assert "killed by SIGSEGV" in by["segfault3"]["reason"]
    assert by["hang4"]["reason"] == f"killed after its {HANG_LIMIT_S:g} s wall-time limit"
    # Every case ran in a process forked from the same server: none of them ended it.
    assert by["ok0"]["forked_from_server"] and by["ok6"]["forked_from_server"]
    assert by["ok0"]["server_pid"] == by["orphan5"]["server_pid"] == by["ok6"]["server_pid"]
    # What a case started in its process group went with it (hung or not).
    for index in (4, 5):
        assert _gone(int((helper / f"pid-{index}").read_text())), names[index]
    assert len(read_rows(helper / "out" / "results.jsonl")) == len(names)


def test_a_case_that_kills_its_server_is_an_error_and_the_server_is_replaced(
    helper: Path,
) -> None:
    cases = _cases(["ok", "kill-server", "ok"], helper)
    with make_executor(workers=1) as (executor, _):
        rows = run_cases(cases, None, executor, target=TARGET)
    assert [r["outcome"] for r in rows] == ["success", "error", "success"]
    assert rows[1]["reason"].startswith("case worker died while the case ran (killed by SIGKILL")
    assert rows[0]["server_pid"] != rows[2]["server_pid"]  # a new server for the next case


def test_no_state_leaks_from_one_case_to_the_next_in_a_worker(helper: Path) -> None:
    """A case leaves blackboard entries, handlers, registrations behind: the next sees none."""
    cases = _cases(["probe", "dirty", "probe"], helper)
    with make_executor(workers=1) as (executor, _):
        rows = run_cases(cases, None, executor, target=TARGET)
    first, dirty, after = (r["seen"] for r in rows)
    assert len({r["server_pid"] for r in rows}) == 1  # one worker, one server, in order
    assert dirty["registry"] and dirty["sims"] == ["leaked"] and dirty["env"] == "1"
    assert after == first
    assert first == {
        "blackboard": [], "handlers": first["handlers"], "registry": False, "sims": [],
        "next_sim_name": 1, "env": None, "module": False,
    }  # fmt: skip


REAL = {
    "name": "leak",
    "runs": [
        {"name": "short", "tree": "straight", "network": "straight",
         "params": {"distance": "0.2 m"}},
        {"name": "longer", "tree": "straight", "network": "straight",
         "params": {"distance": "0.3 m"}},
    ],
    "link": {"drop": [0.2]},
    "max_time": "60 s",
    "case_timeout": "120 s",
}  # fmt: skip


def _bytes(row: dict[str, Any]) -> str:
    """The row as JSON, without what differs from run to run (wall times) or worker."""
    skip = {"wall_time_s", "overruns", "trace", "server_pid", "forked_from_server"}
    return json.dumps({k: v for k, v in row.items() if k not in skip})


def test_two_real_cases_in_one_worker_give_the_rows_each_gives_alone(helper: Path) -> None:
    cases = expand(campaign_from_data(REAL))
    assert len(cases) == 2 and cases[0]["params"] != cases[1]["params"]
    with make_executor(workers=1) as (executor, _):
        together = run_cases(cases, None, executor, target="campaign_helper:real")
    assert together[0]["server_pid"] == together[1]["server_pid"]
    assert all(r["forked_from_server"] and r["outcome"] == "success" for r in together)
    for case, row in zip(cases, together, strict=True):
        with make_executor(workers=1) as (executor, _):
            (alone,) = run_cases([case], None, executor, target="campaign_helper:real")
        assert _bytes(alone) == _bytes(row)
    # And as a Python of its own would give it (how cases ran before the servers).
    code = "import json, sys; from pirate_bt.campaign.case import run_case;"
    code += " print(json.dumps(run_case(json.load(sys.stdin))))"
    fresh = subprocess.run(
        [sys.executable, "-c", code],
        input=json.dumps(cases[1]),
        capture_output=True,
        text=True,
        check=True,
        env=dict(os.environ, PYTHONHASHSEED="0"),
    )
    assert _bytes(json.loads(fresh.stdout)) == _bytes(together[1])


def test_servers_are_reused_and_restarted_when_the_environment_changes(
    helper: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """In-process (a thread executor): one server for every case, a new one for a new env."""
    try:
        with ThreadPoolExecutor(1) as pool:
            first = run_cases(_cases(["ok", "ok"], helper), None, pool, target=TARGET)
            monkeypatch.setenv("CAMPAIGN_TEST_SOMETHING", "else")
            second = run_cases(_cases(["ok"], helper), None, pool, target=TARGET)
    finally:
        stop_servers()
    assert first[0]["server_pid"] == first[1]["server_pid"] != second[0]["server_pid"]
    assert all(r["forked_from_server"] for r in [*first, *second])


@needs_proc
def test_interrupted_then_resumed_runs_each_recorded_case_once(
    helper: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C in the middle (with a hung case in flight), then resume: each case once."""
    log = helper / "ran.log"
    monkeypatch.setenv("CAMPAIGN_TEST_LOG", str(log))
    out = helper / "out"
    cases = _cases(["ok", "hang", "ok", "ok", "ok", "ok"], helper, timeout_s=HANG_LIMIT_S)

    def stop_after_first(row: dict[str, Any]) -> None:
        raise KeyboardInterrupt

    with make_executor(workers=2) as (executor, _), pytest.raises(KeyboardInterrupt):
        run_cases(cases, out, executor, on_record=stop_after_first, target=TARGET)
    first = read_rows(out / "results.jsonl")
    assert len(first) == 1 and first[0]["run"] == "ok"
    assert _gone(int((helper / "pid-1").read_text()))  # the hung case did not outlive it
    cases[1]["run"] = "ok"  # the hang is fixed; resume runs what has no row
    with make_executor(workers=2) as (executor, _):
        rows = run_cases(cases, out, executor, resume=True, target=TARGET)
    assert [r["index"] for r in rows] == list(range(6))
    assert [r["outcome"] for r in rows] == ["success"] * 6
    assert len(read_rows(out / "results.jsonl")) == 6
    ran = [line.split()[0] for line in log.read_text().splitlines()]
    assert ran.count(first[0]["id"]) == 1  # the recorded case did not run again
    assert sorted(set(ran)) == sorted(c["id"] for c in cases)


@needs_proc
@pytest.mark.usefixtures("ctrl_c_reaches_children")
def test_a_case_process_group_is_killed_on_the_worker_s_interrupt(helper: Path) -> None:
    """A worker interrupted while it waits (Ctrl-C reaches it) kills its case at once."""
    (case,) = _cases(["hang"], helper, timeout_s=300.0)
    pid_file = Path(case["pid_file"])
    code = textwrap.dedent(
        """
        import json, sys
        from pirate_bt.campaign.workers import run_in_server
        run_in_server(json.loads(sys.argv[1]), None, "campaign_helper:behave")
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", code, json.dumps(case)], stderr=subprocess.PIPE)
    try:
        for _ in range(600):
            if pid_file.exists() and pid_file.read_text():
                break
            try:
                proc.wait(timeout=0.1)
            except subprocess.TimeoutExpired:
                continue
            pytest.fail(f"the worker ended before its case started: {proc.communicate()[1]!r}")
        os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert b"KeyboardInterrupt" in err
    assert _gone(int(pid_file.read_text()))
