"""The recorder reads only where the tree moved: nodes ticked, nodes stopped, the root."""

from __future__ import annotations

import json
from pathlib import Path

import py_trees
import pytest
from py_trees.behaviours import StatusQueue
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.trace import TraceRecorder, read_trace
from pirate_bt.trace.structure import iter_with_ids
from tests.trace_support import run_and_record

R, S, F = Status.RUNNING, Status.SUCCESS, Status.FAILURE


def big_tree(steps: int = 30) -> py_trees.trees.BehaviourTree:
    """A mission-like tree: a memory sequence of steps, each a selector with a retry."""
    children = []
    for i in range(steps):
        first = StatusQueue(f"try {i}", [R, F] if i % 3 == 0 else [R, R, S], S)
        retry = StatusQueue(f"retry {i}", [R, S], S)
        pick = py_trees.composites.Selector(f"step {i}", memory=False, children=[first, retry])
        check = StatusQueue(f"check {i}", [S], S)
        children.append(
            py_trees.composites.Sequence(f"leg {i}", memory=True, children=[pick, check])
        )
    root = py_trees.composites.Sequence("mission", memory=True, children=children)
    return py_trees.trees.BehaviourTree(root)


def dense_tree(groups: int = 30) -> py_trees.trees.BehaviourTree:
    """Every node ticks every tick: a parallel over sequences of always-running leaves."""
    seqs = [
        py_trees.composites.Sequence(
            f"g{g}",
            memory=False,
            children=[StatusQueue(f"s{g}", [S], S), StatusQueue(f"r{g}", [R], R)],
        )
        for g in range(groups)
    ]
    policy = py_trees.common.ParallelPolicy.SuccessOnAll()
    return py_trees.trees.BehaviourTree(py_trees.composites.Parallel("all", policy, seqs))


def record(
    path: Path, tree: py_trees.trees.BehaviourTree, ticks: int, **options: object
) -> tuple[TraceRecorder, list[dict[str, Status]]]:
    clock = SimClock()
    live = [{i: n.status for i, n in iter_with_ids(tree)}]
    rec = TraceRecorder(path, tree, clock=clock, **options)  # type: ignore[arg-type]
    for _ in range(ticks):
        clock.advance(0.05)
        tree.tick()
        rec.record_tick()
        live.append({i: node.status for i, node in iter_with_ids(tree)})
    rec.close()
    return rec, live


def test_big_trees_are_tracked_by_default_and_match_the_live_tree(tmp_path: Path) -> None:
    tree = big_tree()
    assert sum(1 for _ in tree.root.iterate()) > 100
    _rec, live = record(tmp_path / "big.jsonl", tree, 150)
    assert not tree.visitors  # its visitor is taken off at close
    trace = read_trace(tmp_path / "big.jsonl")
    assert trace.outcome == "success"
    for n, expected in enumerate(live[: trace.last_tick + 1]):
        assert trace.statuses_at(n) == expected, f"tick {n}"


def test_tracked_and_polled_traces_are_the_same(tmp_path: Path) -> None:
    record(tmp_path / "tracked.jsonl", big_tree(), 150, track_nodes=True)
    record(tmp_path / "polled.jsonl", big_tree(), 150, track_nodes=False)
    tracked = (tmp_path / "tracked.jsonl").read_text().splitlines()[1:]
    polled = (tmp_path / "polled.jsonl").read_text().splitlines()[1:]
    assert tracked == polled
    run_and_record(tmp_path / "small-tracked.jsonl", track_nodes=True)
    run_and_record(tmp_path / "small-polled.jsonl", track_nodes=False)
    for name in ("small-tracked", "small-polled"):
        trace = read_trace(tmp_path / f"{name}.jsonl")
        assert trace.outcome == "success" and trace.last_tick == 14


def test_the_visitor_comes_off_at_close_and_nothing_is_patched(tmp_path: Path) -> None:
    tree = big_tree(3)
    nodes = list(tree.root.iterate())
    rec = TraceRecorder(tmp_path / "t.jsonl", tree, clock=SimClock(), track_nodes=True)
    assert len(tree.visitors) == 1
    tree.tick()
    rec.record_tick()
    rec.close()
    assert tree.visitors == []
    assert not any("tick" in vars(n) or "stop" in vars(n) for n in nodes)
    tree.tick()  # the tree still ticks as a plain py_trees tree


def test_track_nodes_needs_a_tree_with_visitors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="BehaviourTree"):
        TraceRecorder(tmp_path / "t.jsonl", big_tree(3).root, clock=SimClock(), track_nodes=True)


def test_a_stop_by_a_parent_that_did_not_tick_the_child_is_seen(tmp_path: Path) -> None:
    """A selector's higher-priority child takes over: the lower one is stopped, not ticked."""
    urgent = StatusQueue("urgent", [F, F, R, R], R)
    chore = StatusQueue("chore", [R], R)
    root = py_trees.composites.Selector("pick", memory=False, children=[urgent, chore])
    tree = py_trees.trees.BehaviourTree(root)
    clock = SimClock()
    with TraceRecorder(tmp_path / "p.jsonl", tree, clock=clock, track_nodes=True) as rec:
        for _ in range(4):
            clock.advance(0.05)
            tree.tick()
            rec.record_tick()
    trace = read_trace(tmp_path / "p.jsonl")
    assert trace.frame_at(2).status["0.1"] == "R"
    assert trace.frame_at(3).status["0.1"] == "I"  # stopped by the selector at tick 3
    assert trace.frame_at(3).status["0.0"] == "R"


def test_stopped_nodes_are_seen(tmp_path: Path) -> None:
    """A stop from outside a tick (an interrupt) turns nodes INVALID in the next record."""
    tree = big_tree()
    clock = SimClock()
    with TraceRecorder(tmp_path / "s.jsonl", tree, clock=clock, track_nodes=True) as rec:
        for _ in range(3):
            clock.advance(0.05)
            tree.tick()
            rec.record_tick()
        tree.root.stop(Status.INVALID)
        rec.record_tick()
    last = read_trace(tmp_path / "s.jsonl").frame_at(4).status
    assert set(last.values()) == {"I"}


def test_dense_trees_are_read_whole(tmp_path: Path) -> None:
    tree = dense_tree()
    path = tmp_path / "dense.jsonl"
    clock = SimClock()
    rec = TraceRecorder(path, tree, clock=clock, track_nodes=True, every_tick=True)
    live = []
    for _ in range(30):
        clock.advance(0.05)
        tree.tick()
        rec.record_tick()
        live.append({i: n.status for i, n in iter_with_ids(tree)})
    assert tree.visitors == []  # most nodes ticked 20 ticks in a row: read whole
    rec.close()
    trace = read_trace(path)
    for n, expected in enumerate(live, start=1):
        assert trace.statuses_at(n) == expected


@pytest.mark.parametrize("as_tree, follows", [(True, True), (False, False)])
def test_default_follows_a_behaviour_tree(tmp_path: Path, as_tree: bool, follows: bool) -> None:
    tree = big_tree(3)
    rec = TraceRecorder(tmp_path / "t.jsonl", tree if as_tree else tree.root, clock=SimClock())
    try:
        assert (len(tree.visitors) == 1) is follows
    finally:
        rec.close()
    lines = [json.loads(x) for x in (tmp_path / "t.jsonl").read_text().splitlines()]
    assert lines[-1]["type"] == "end"


def test_a_write_from_outside_is_seen_when_the_node_next_ticks(tmp_path: Path) -> None:
    """The documented limit of tracking: only a node's own tick/stop marks it."""
    tree = big_tree()
    last_leg = tree.root.children[-1]
    clock = SimClock()
    with TraceRecorder(tmp_path / "w.jsonl", tree, clock=clock, track_nodes=True) as rec:
        clock.advance(0.05)
        tree.tick()
        rec.record_tick()
        last_leg.feedback_message = "set from outside"
        clock.advance(0.05)
        tree.tick()
        rec.record_tick()
    trace = read_trace(tmp_path / "w.jsonl")
    leg_id = next(i for i, n in iter_with_ids(tree) if n is last_leg)
    assert trace.frame_at(2).feedback.get(leg_id, "") == ""


def test_a_raising_node_is_named_in_a_tracked_trace(tmp_path: Path) -> None:
    """Following the ticks hides neither the culprit from the runner nor the last tick."""
    from pirate_bt.runner import Runner
    from pirate_bt.trace import attach_trace

    class Boom(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            raise RuntimeError("boom")

    tree = big_tree()
    tree.root.children[0].children[1] = Boom("boom")  # replaces "check 0"
    tree.root.children[0].children[1].parent = tree.root.children[0]
    clock = SimClock()
    runner = Runner(tree, clock=clock, period_s=0.05)
    attach_trace(runner, tmp_path / "boom.jsonl")
    result = runner.run()
    assert result.failing_node is not None and result.failing_node.endswith("leg 0/boom")
    trace = read_trace(tmp_path / "boom.jsonl")
    assert trace.outcome == "error"
    assert trace.end is not None and trace.end["error"]["node"] == "0.0.1"
    assert trace.last_tick == result.ticks
    assert tree.visitors == []
