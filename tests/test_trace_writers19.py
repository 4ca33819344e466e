"""Two writers of one trace file at once: the second is refused, the first's trace stays whole.

Three ``simulate_tree(..., trace="same.jsonl")`` at once mixed their lines into one file
(each truncating what the others had written), which no reader could read.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.behaviours import StatusQueue
from py_trees.common import Status

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError
from pirate_bt.trace import TraceRecorder, open_writer, read_trace
from pirate_bt.trace.recorder_args import check_free

ROOT = Path(__file__).resolve().parent.parent


def _tree() -> py_trees.trees.BehaviourTree:
    py_trees.blackboard.Blackboard.clear()
    s, r = Status.SUCCESS, Status.RUNNING
    root = py_trees.composites.Sequence(
        "pab", memory=True, children=[StatusQueue("a", [r, s], s), StatusQueue("b", [r, s], s)]
    )
    return py_trees.trees.BehaviourTree(root)


def _in_thread(call: Any) -> BaseException | None:
    """What ``call()`` raised in another thread (``None`` if nothing)."""
    raised: list[BaseException | None] = [None]

    def run() -> None:
        try:
            call()
        except BaseException as exc:  # handed to the test
            raised[0] = exc

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    return raised[0]


@pytest.mark.parametrize("suffix", [".jsonl", ".jsonl.gz", ".mcap"])
@pytest.mark.parametrize("background", [None, False])
def test_a_second_recorder_of_a_file_being_written_is_refused(
    tmp_path: Path, suffix: str, background: bool | None
) -> None:
    path = tmp_path / f"run{suffix}"
    tree = _tree()
    clock = SimClock()
    first = TraceRecorder(path, tree, clock=clock, background=background)
    clock.advance(0.1)
    tree.tick()
    first.record_tick()
    other = _tree()
    raised = _in_thread(lambda: TraceRecorder(path, other, clock=SimClock()))
    assert isinstance(raised, InputError)
    message = str(raised)
    assert message.startswith(f"{path}: cannot write trace: another run is writing it")
    assert "\n" not in message
    for _ in range(3):  # the first run goes on, undisturbed
        clock.advance(0.1)
        tree.tick()
        first.record_tick()
    first.close()
    trace = read_trace(path)
    assert (trace.outcome, trace.last_tick) == ("success", 4)
    # once the first has ended, the file may be written again
    again = TraceRecorder(path, _tree(), clock=SimClock(), background=background)
    again.close()
    assert read_trace(path).last_tick == 0


def test_a_link_to_a_file_being_written_is_the_same_file(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    first = open_writer(path)
    (tmp_path / "link.jsonl").symlink_to(path)
    (tmp_path / "hard.jsonl").hardlink_to(path)
    for name in ("link.jsonl", "hard.jsonl"):
        with pytest.raises(OSError, match="another run is writing it"):
            open_writer(tmp_path / name)
    first.close()
    open_writer(tmp_path / "hard.jsonl").close()


_HOLDER = """
import sys
import py_trees
from py_trees.behaviours import StatusQueue
from py_trees.common import Status
from pirate_bt.clock import SimClock
from pirate_bt.trace import TraceRecorder

s, r = Status.SUCCESS, Status.RUNNING
root = py_trees.composites.Sequence("held", memory=True, children=[StatusQueue("a", [r, r, s], s)])
tree = py_trees.trees.BehaviourTree(root)
clock = SimClock()
recorder = TraceRecorder(sys.argv[1], tree, clock=clock)
clock.advance(0.1)
tree.tick()
recorder.record_tick()
print("holding", flush=True)
sys.stdin.readline()
for _ in range(2):
    clock.advance(0.1)
    tree.tick()
    recorder.record_tick()
recorder.close()
"""


def test_a_run_of_another_process_keeps_its_trace_whole(tmp_path: Path) -> None:
    path = tmp_path / "same.jsonl"
    holder = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_HOLDER), str(path)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert holder.stdout is not None and holder.stdin is not None
    try:
        assert holder.stdout.readline() == "holding\n"
        with pytest.raises(InputError) as raised:
            pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}, trace=path)
        assert str(raised.value) == (
            f"trace: cannot write {path}: another run is writing it (a trace holds one run);"
            " name another file, or wait until that run has ended"
        )
        holder.stdin.write("go on\n")
        holder.stdin.close()
        assert holder.wait(60) == 0
    finally:
        if holder.poll() is None:
            holder.kill()
            holder.wait()
    trace = read_trace(path)
    assert (trace.structure.name, trace.outcome, trace.last_tick) == ("held", "success", 3)


def test_a_file_being_written_is_found_before_a_run_connects(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    check_free(path)  # no file: free
    first = TraceRecorder(path, _tree(), clock=SimClock())
    with pytest.raises(InputError) as raised:
        check_free(path)
    assert getattr(raised.value, "strerror", None) == (
        "another run is writing it (a trace holds one run); name another file,"
        " or wait until that run has ended"
    )
    first.close()
    check_free(path)
    assert read_trace(path).end is not None  # the look changed nothing


def test_a_run_to_a_file_being_written_is_refused_before_it_starts(tmp_path: Path) -> None:
    """The API's checks before anything connects include the trace file being free:
    nothing is started, no safe state is entered for it (it used to be found only when
    the recorder was made, after the simulator had started)."""
    path = tmp_path / "busy.jsonl"
    first = TraceRecorder(path, _tree(), clock=SimClock())
    try:
        with pytest.raises(InputError) as raised:
            pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}, trace=path)
        assert str(raised.value).startswith(f"trace: cannot write {path}: another run")
        done = subprocess.run(
            [
                *(sys.executable, "-m", "pirate_bt", "run", "straight"),
                *("--param", "distance=0.1m", "--sim", "straight", "--trace", str(path)),
            ],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert done.returncode == 2, done.stderr
        assert "safe state" not in done.stderr  # refused before anything ran
        assert "another run is writing it" in done.stderr.strip().splitlines()[-1]
    finally:
        first.close()
    assert read_trace(path).end is not None  # the first run's trace whole
