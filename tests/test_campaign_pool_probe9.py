"""A pool probe's findings: a dead worker of the local pool, a campaign killed with SIGKILL.

1. A local pool worker killed (from outside, or by its case) broke the whole
   ``ProcessPoolExecutor``: every case still to run was recorded ``error`` (``worker
   lost: ... terminated abruptly``) and ``--resume`` counted them as done. Now only
   the case that was running in the dead worker is lost; the pool is replaced and
   every other case runs.
2. After the campaign's main process was killed with SIGKILL, its pool workers, their
   case servers and the cases ran on for ever (re-parented to PID 1). Now they end with
   it (Linux: ``PR_SET_PDEATHSIG``).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import uuid
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.campaign import make_executor, read_rows, run_cases
from pirate_bt.campaign.engine import LOST_REASON

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="needs Linux (/proc, PR_SET_PDEATHSIG)"
)

HELPER = textwrap.dedent(
    """
    import os, signal, subprocess, sys, time
    from pathlib import Path


    def _ppid(pid):
        with open(f"/proc/{pid}/stat", encoding="utf-8") as f:
            return int(f.read().rsplit(")", 1)[1].split()[1])


    def behave(case, trace_dir):
        log = os.environ.get("PROBE9_LOG")
        if log:
            with open(log, "a", encoding="utf-8") as f:
                f.write(f"{case['id']}\\n")
        server = os.getppid()
        worker = _ppid(server)
        if case["run"] == "kill-worker":  # the pool worker this case's server serves
            os.kill(worker, signal.SIGKILL)
            time.sleep(30)
        if case["run"] == "linger":  # a child in its group too, then wait to be killed
            subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
            Path(case["started"]).write_text(str(os.getpid()))
            time.sleep(600)
        time.sleep(float(case.get("sleep", 0.0)))
        return {"id": case["id"], "index": case["index"], "run": case["run"],
                "outcome": "success", "reason": "fine", "seed": case["seed"],
                "worker_pid": worker}
    """
)

TARGET = "probe9_helper:behave"


@pytest.fixture
def helper(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``probe9_helper`` importable by the workers (they inherit PYTHONPATH)."""
    (tmp_path / "probe9_helper.py").write_text(HELPER, encoding="utf-8")
    monkeypatch.setenv("PYTHONPATH", f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    return tmp_path


def _cases(names: list[str], **extra: Any) -> list[dict[str, Any]]:
    return [
        {"id": f"{i:06d}-p9", "index": i, "run": n, "seed": 0, "timeout_s": 60.0, **extra}
        for i, n in enumerate(names)
    ]


def test_a_dead_pool_worker_loses_only_its_own_case(
    helper: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    log = helper / "ran.log"
    monkeypatch.setenv("PROBE9_LOG", str(log))
    out = helper / "out"
    cases = _cases(["ok", "ok", "kill-worker", "ok", "ok", "ok"], sleep=0.3)
    with make_executor(workers=2) as (executor, _):
        rows = run_cases(cases, out, executor, target=TARGET)
        assert getattr(executor, "replaced", None) == 1
    assert [r["index"] for r in rows] == list(range(6))
    outcomes = {r["run"] + str(r["index"]): r["outcome"] for r in rows}
    assert outcomes == {
        "ok0": "success",
        "ok1": "success",
        "kill-worker2": "error",
        "ok3": "success",
        "ok4": "success",
        "ok5": "success",
    }
    assert rows[2]["reason"] == LOST_REASON
    assert sum(r["outcome"] == "error" for r in rows) == 1
    ran = log.read_text().split()
    assert ran.count(cases[2]["id"]) == 1  # the case that killed its worker is not run again
    assert set(ran) == {c["id"] for c in cases}
    # a new pool ran the cases after it: other workers than the first ones
    assert len({r["worker_pid"] for r in rows if r["outcome"] == "success"}) >= 3
    # resume: every case has its row, nothing runs again
    assert len(read_rows(out / "results.jsonl")) == 6
    log.unlink()
    with make_executor(workers=2) as (executor, _):
        again = run_cases(cases, out, executor, resume=True, target=TARGET)
    assert [r["outcome"] for r in again] == [r["outcome"] for r in rows]
    assert not log.exists()


def test_workers_that_die_every_time_are_given_up(helper: Path) -> None:
    """Every case kills its worker: each is lost once, the pool replaced a bounded number
    of times, and the campaign ends."""
    cases = _cases(["kill-worker"] * 3)
    with make_executor(workers=2) as (executor, _):
        rows = run_cases(cases, None, executor, target=TARGET)
        assert getattr(executor, "replaced", 0) <= len(cases)
    assert [r["outcome"] for r in rows] == ["error"] * 3
    assert all(r["reason"].startswith("worker lost") for r in rows)


# --- a campaign killed with SIGKILL leaves nothing behind ------------------------------

RUNNER = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path
    from pirate_bt.campaign import make_executor, run_cases

    cases = json.loads(sys.argv[1])
    with make_executor(workers=2) as (executor, _):
        run_cases(cases, Path(sys.argv[2]), executor, target="probe9_helper:behave")
    """
)


def _tagged(tag: str) -> dict[int, str]:
    """The live processes whose environment holds ``PROBE9_TAG=tag``, and their command lines."""
    found: dict[int, str] = {}
    needle = f"PROBE9_TAG={tag}".encode()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if needle not in (entry / "environ").read_bytes().split(b"\0"):
                continue
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
            command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if state not in ("Z", "X"):
            found[int(entry.name)] = command
    return found


def test_a_campaign_killed_with_sigkill_leaves_no_process(helper: Path) -> None:
    tag = uuid.uuid4().hex
    cases = [
        {**case, "started": str(helper / f"started-{case['index']}")}
        for case in _cases(["linger", "linger", "ok", "ok"])
    ]
    started = [Path(case["started"]) for case in cases[:2]]
    env = dict(os.environ, PROBE9_TAG=tag)
    main = subprocess.Popen(
        [sys.executable, "-c", RUNNER, json.dumps(cases), str(helper / "out")],
        env=env,
        start_new_session=True,  # not in pytest's group: nothing of it gets our signals
    )
    try:
        deadline = time.monotonic() + 30.0
        while not all(p.exists() for p in started):
            assert main.poll() is None, "the campaign ended before its cases started"
            assert time.monotonic() < deadline, "the cases did not start"
            time.sleep(0.05)
        before = _tagged(tag)
        # the main process, 2 pool workers, 2 servers, 2 cases and their 2 children
        assert len(before) >= 9, before
        # 2 servers and the 2 case processes forked from them (the same command line)
        assert sum("pirate_bt.campaign.child" in c for c in before.values()) == 4
        main.send_signal(signal.SIGKILL)
        main.wait(timeout=10)
        deadline = time.monotonic() + 5.0
        while (left := _tagged(tag)) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert left == {}, f"still running after the campaign was killed: {left}"
    finally:
        main.kill()
        main.wait(timeout=10)
        for pid in _tagged(tag):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
