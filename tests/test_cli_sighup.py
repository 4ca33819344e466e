"""SIGHUP (the terminal closed, an ssh session dropped) stops a command as SIGTERM
does: the run's robot in its safe state (the run a failure, exit 1, its why the
signal), one line and exit 129 outside a run. It killed the process
outright (the drives left to the bridge's watchdog). Ignored by the caller (``nohup``),
it stays ignored."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import pirate_bt.cli.schema as schema
from pirate_bt.cli import main


def test_a_hangup_during_a_command_is_one_line_and_129(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def hung_up(_args: object) -> int:
        os.kill(os.getpid(), signal.SIGHUP)  # raises in this thread, from main's handler
        raise AssertionError("SIGHUP did not interrupt")

    def unhandled(_signum: int, _frame: object) -> None:
        raise AssertionError("main left SIGHUP to the handler it found")

    monkeypatch.setattr(schema, "run", hung_up)
    before = signal.signal(signal.SIGHUP, unhandled)
    try:
        assert main(["schema", "tree"]) == 129
        assert signal.getsignal(signal.SIGHUP) is unhandled  # left as found
    finally:
        signal.signal(signal.SIGHUP, before)
    assert capsys.readouterr().err.strip() == "pirate-bt: terminated (SIGHUP)"


def test_a_hangup_the_caller_ignores_stays_ignored(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[object] = []

    def look(_args: object) -> int:
        seen.append(signal.getsignal(signal.SIGHUP))
        return 0

    monkeypatch.setattr(schema, "run", look)
    before = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        assert main(["schema", "tree"]) == 0
    finally:
        signal.signal(signal.SIGHUP, before)
    assert seen == [signal.SIG_IGN]


def test_a_run_hung_up_ends_in_its_safe_state_with_its_trace(tmp_path: Path) -> None:
    trace = tmp_path / "run.jsonl"
    child = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pirate_bt",
            "run",
            "straight",
            "--param",
            "distance=3 m",
            "--realtime",
            "--quiet",
            "--trace",
            str(trace),
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        for _ in range(300):  # the run has started once its trace has ticks
            if trace.exists() and trace.stat().st_size > 2000:
                break
            time.sleep(0.05)
        child.send_signal(signal.SIGHUP)
        _, err = child.communicate(timeout=60)
    finally:
        if child.poll() is None:
            child.kill()
    # a run interrupted ends as every run that does not succeed: 1, its why the signal
    assert child.returncode == 1, err
    assert "FAILURE - interrupted (SIGHUP)" in err.strip().splitlines()[-1], err
    from pirate_bt.trace.reader import read_trace

    assert read_trace(trace).outcome == "interrupted"
