"""Trace queries answer for the ticks the trace holds now, not those of the first query.

``TraceQueries`` built its index of status and feedback changes once, at the first
query: ticks replaced, cut or appended to afterwards were not seen (a node that failed
in an appended tick had never failed).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import py_trees
import pytest
from py_trees.behaviours import StatusQueue
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.trace import Trace, TraceRecorder, read_trace
from pirate_bt.trace.text import summarise


def _recorded(path: Path, ticks: int) -> Trace:
    """A run of ``ticks`` ticks: ``a`` runs, then succeeds; ``b`` runs, then fails (tick 3)."""
    py_trees.blackboard.Blackboard.clear()
    s, f, r = Status.SUCCESS, Status.FAILURE, Status.RUNNING
    root = py_trees.composites.Sequence(
        "pab", memory=True, children=[StatusQueue("a", [r, s], s), StatusQueue("b", [r, f], f)]
    )
    tree = py_trees.trees.BehaviourTree(root)
    clock = SimClock()
    with TraceRecorder(path, tree, clock=clock, background=False) as recorder:
        for _ in range(ticks):
            clock.advance(0.1)
            tree.tick()
            recorder.record_tick()
    return read_trace(path)


@pytest.fixture
def runs(tmp_path: Path) -> tuple[Trace, Trace]:
    return _recorded(tmp_path / "short.jsonl", 2), _recorded(tmp_path / "long.jsonl", 3)


def test_ticks_appended_after_a_query_are_answered_for(runs: tuple[Trace, Trace]) -> None:
    short, long = runs
    assert short.failures() == []
    assert [c.status for c in short.statuses("b")] == ["RUNNING"]
    short.ticks.extend(long.ticks[len(short.ticks) :])  # the same list, grown
    assert [(f.tick, f.path) for f in short.failures()] == [(3, "pab/b"), (3, "pab")]
    assert [c.status for c in short.statuses("b")] == ["RUNNING", "FAILURE"]
    assert short.first_tick("b", "FAILURE") == 3


def test_ticks_replaced_or_cut_after_a_query_are_answered_for(runs: tuple[Trace, Trace]) -> None:
    short, long = runs
    third = long.ticks[-1]
    assert (third.n, long.first_tick("b", "FAILURE")) == (3, 3)
    long.ticks = long.ticks[:2]  # another list, cut
    assert long.first_tick("b", "FAILURE") is None
    assert long.failures() == []
    assert short.statuses("b")[-1].status == "RUNNING"
    short.ticks[-1] = third  # changed in place: the same list, as long as before
    assert [c.status for c in short.statuses("b")] == ["FAILURE"]


def test_the_summary_counts_a_repeated_status_once(tmp_path: Path) -> None:
    """A tick record that gives a node the status it had is no change: the summary's
    ``runs``/``ok``/``fail`` are counts of changes, as the docs and ``statuses()`` say."""
    path = tmp_path / "run.jsonl"
    s, f, r = Status.SUCCESS, Status.FAILURE, Status.RUNNING
    root = StatusQueue("probe", [r, r, s, s, f, f], f)
    clock = SimClock()
    with TraceRecorder(path, root, clock=clock, background=False, every_tick=True) as recorder:
        for _ in range(6):
            clock.advance(0.5)
            root.tick_once()
            recorder.record_tick()
    # as a trace written by another tool may have it: every tick gives the status
    lines = path.read_text().splitlines()
    codes = "RRSSFF"
    for at, code in enumerate(codes, start=1):
        record = json.loads(lines[at])
        record["status"] = {"0": code}
        lines[at] = json.dumps(record)
    path.write_text("\n".join(lines) + "\n")
    trace = read_trace(path)
    assert [c.status for c in trace.statuses("probe")] == ["RUNNING", "SUCCESS", "FAILURE"]
    counted = summarise(trace).nodes["0"]
    assert (counted.runs, counted.successes, counted.failures) == (2, 1, 1)
    assert counted.running_s == pytest.approx(1.0)  # ticks 1 to 3: 0.5 s to 1.5 s


def test_a_frame_after_a_tick_replaced_in_place_is_of_the_new_tick(
    runs: tuple[Trace, Trace],
) -> None:
    short, _ = runs
    assert short.statuses_at(2)["0.1"] == Status.RUNNING
    second = short.ticks[-1]
    # the same list, its last tick (2: b RUNNING) replaced by one where b failed
    short.ticks[-1] = dataclasses.replace(second, status={**second.status, "0.1": "F"})
    assert short.statuses_at(2)["0.1"] == Status.FAILURE
    assert short.statuses("b")[-1].status == "FAILURE"
