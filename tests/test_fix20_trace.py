"""Trace leftovers of the twentieth session: a forked child and the trace's lock, and
MCAP files written by another tool (the ``mcap`` library's Writer)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.trace import read_trace
from pirate_bt.trace.sink_formats import held

ROOT = Path(__file__).resolve().parent.parent

# A run that forks a child (os.fork without exec, as multiprocessing's fork start
# method does) while its trace is open. The run says "forked PID" once the child runs; the child
# then waits for a byte on its standard input; with "close" it first closes its copy of the
# recorder (a `with` block it falls out of). The run then ends ("ended") or is killed.
_FORKING = """
import os, sys
import py_trees
from py_trees.behaviours import StatusQueue
from py_trees.common import Status
from pirate_bt.clock import SimClock
from pirate_bt.trace import TraceRecorder

path = sys.argv[1]
background, child_closes, killed = (flag == "1" for flag in sys.argv[2:5])
s, r = Status.SUCCESS, Status.RUNNING
root = py_trees.composites.Sequence("run", memory=True, children=[StatusQueue("a", [r, r, s], s)])
tree = py_trees.trees.BehaviourTree(root)
clock = SimClock()
recorder = TraceRecorder(path, tree, clock=clock, background=background)
clock.advance(0.1)
tree.tick()
recorder.record_tick()
ready, told = os.pipe()
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)  # the test reads the run's output to its end: not held open here
    if child_closes:
        recorder.close()
    os.write(told, b"x")
    os.read(0, 1)  # until the test says so
    os._exit(0)
os.read(ready, 1)  # the child runs
print("forked", pid, flush=True)
for _ in range(2):
    clock.advance(0.1)
    tree.tick()
    recorder.record_tick()
if killed:
    os.kill(os.getpid(), 9)
recorder.close()
print("ended", flush=True)
"""


def _fork_run(path: Path, background: bool, child_closes: bool, killed: bool) -> tuple[Any, int]:
    run = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(_FORKING),
            str(path),
            "1" if background else "0",
            "1" if child_closes else "0",
            "1" if killed else "0",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert run.stdout is not None
    said, child = run.stdout.readline().split()
    assert said == "forked"
    return run, int(child)


def _let_child_go(run: Any) -> None:
    run.stdin.write("x")
    run.stdin.close()


def _free_within(path: Path, limit_s: float) -> bool:
    """Whether the trace is free (no writer holds it) within ``limit_s``, polled."""
    deadline = time.monotonic() + limit_s
    while held(path):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


@pytest.mark.parametrize(
    ("suffix", "background", "child_closes"),
    [
        (".jsonl", False, False),
        (".jsonl.gz", False, True),
        (".mcap", False, True),
        (".jsonl", True, True),
        (".mcap", True, False),
    ],
)
def test_a_forked_child_does_not_keep_the_trace_of_a_run_that_ended(
    tmp_path: Path, suffix: str, background: bool, child_closes: bool
) -> None:
    path = tmp_path / f"run{suffix}"
    run, _ = _fork_run(path, background, child_closes, killed=False)
    try:
        assert run.stdout is not None
        assert run.stdout.readline() == "ended\n"
        assert run.wait(30) == 0
        # the child lives on; the run's trace is whole and free for another run
        assert not held(path)
        trace = read_trace(path)
        assert trace.end is not None and trace.last_tick == 3
    finally:
        _let_child_go(run)
        run.wait(30)
    assert not list(tmp_path.glob(".*")), "a twin left beside the trace"


def test_a_run_killed_with_a_forked_child_alive_leaves_its_trace_written_and_free(
    tmp_path: Path,
) -> None:
    path = tmp_path / "run.jsonl"
    run, child = _fork_run(path, background=True, child_closes=False, killed=True)
    try:
        assert run.wait(30) == -signal.SIGKILL
        # the writer process wrote what it was handed and let the file go; before, it
        # waited for the end of a pipe the child still held, the file locked meanwhile
        assert _free_within(path, 30.0)
        trace = read_trace(path)
        assert (trace.last_tick, trace.outcome) == (3, "incomplete")
        os.kill(child, 0)  # (the child is still alive)
    finally:
        _let_child_go(run)
