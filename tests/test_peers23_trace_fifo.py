"""A named pipe that appears at a trace's path after the run's checks is refused at once.

The API and the command line refuse a trace path that is a named pipe before the run
starts; one made there afterwards (another program, a race) was opened by the trace
writer, which waited for a reader for ever: the run never began, and never ended. The
trace layer's own callers (``TraceRecorder``) had no check at all.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import py_trees
import pytest

import pirate_bt
from pirate_bt.trace import writer
from pirate_bt.trace.recorder_args import TraceWriteError
from pirate_bt.trace.writer import TraceRecorder

ROOT = Path(__file__).resolve().parent.parent
WAIT_S = 30.0
"""Only a writer waiting for a reader for ever reaches this."""

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")


def _outcome(call: Callable[[], Any], fifo: Path) -> BaseException | None:
    """What ``call`` raised (``None``: it returned), in a thread; a call still waiting
    after :data:`WAIT_S` fails the test, and is let go by a reader of the pipe."""
    outcome: list[BaseException | None] = []

    def run() -> None:
        try:
            call()
        except BaseException as exc:  # what the test looks at
            outcome.append(exc)
        else:
            outcome.append(None)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(WAIT_S)
    if thread.is_alive():  # let the writer go: a reader opens the pipe, and leaves
        reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        try:
            thread.join(WAIT_S)
        finally:
            os.close(reader)
        pytest.fail(f"still waiting on the named pipe {fifo.name} after {WAIT_S:g} s")
    return outcome[0]


def _tree() -> py_trees.trees.BehaviourTree:
    return py_trees.trees.BehaviourTree(py_trees.behaviours.Success("done"))


@pytest.mark.parametrize("name", ["t.jsonl", "t.jsonl.gz", "t.mcap"])
@pytest.mark.parametrize("background", [False, True])
def test_a_trace_recorder_refuses_a_named_pipe_nobody_reads(
    tmp_path: Path, name: str, background: bool
) -> None:
    if name.endswith(".mcap"):
        pytest.importorskip("mcap")
        if background:
            pytest.skip("an MCAP trace is written in-process")
    fifo = tmp_path / name
    os.mkfifo(fifo)
    raised = _outcome(lambda: TraceRecorder(fifo, _tree(), background=background).close(), fifo)
    assert isinstance(raised, TraceWriteError), raised
    assert str(raised) == f"{fifo}: cannot write trace: it is a named pipe nobody reads, not a file"


def test_a_run_whose_trace_becomes_a_named_pipe_after_its_checks_ends_with_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    trace = tmp_path / "run.jsonl"
    checked = writer.check_destination

    def then_a_pipe(path: Any) -> None:  # after every check of the run: the recorder's own
        checked(path)
        os.mkfifo(path)

    monkeypatch.setattr(writer, "check_destination", then_a_pipe)
    raised = _outcome(
        lambda: pirate_bt.simulate_tree(
            ROOT / "trees" / "straight.yaml", params={"distance": "0.1 m"}, trace=trace
        ),
        trace,
    )
    assert isinstance(raised, pirate_bt.InputError), raised
    assert "it is a named pipe nobody reads, not a file" in str(raised)
    assert "\n" not in str(raised)


def test_a_named_pipe_something_reads_is_written_as_before(tmp_path: Path) -> None:
    fifo = tmp_path / "t.jsonl"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    try:
        recorder = TraceRecorder(fifo, _tree(), background=False)
        recorder.close()
        with os.fdopen(os.dup(reader), "rb") as stream:
            first = stream.readline()
    finally:
        os.close(reader)
    assert first.startswith(b'{"type": "header"') or first.startswith(b'{"type":"header"'), first
