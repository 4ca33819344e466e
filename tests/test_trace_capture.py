"""The trace's capture in the tick: what the runner and the recorder do to keep it cheap.

The records themselves are pinned by tests/test_golden_runs.py and the other
tests/test_trace*.py; these tests cover the shortcuts taken on the way.
"""

from __future__ import annotations

import os
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.runner import tick_tree
from pirate_bt.trace.nodes import NodeReader, TickedNodes
from pirate_bt.trace.sink_ring import Ring

R, S, F = Status.RUNNING, Status.SUCCESS, Status.FAILURE


def _steps_tree(leaf: type[py_trees.behaviour.Behaviour] | None = None) -> Any:
    """A memory sequence of selectors over queues: different nodes tick in each tick."""
    children = []
    for i in range(4):
        first = py_trees.behaviours.StatusQueue(f"try {i}", [R, F], S)
        second = (leaf or py_trees.behaviours.StatusQueue)(f"retry {i}", [R, S], S)  # type: ignore[call-arg]
        children.append(py_trees.composites.Selector(f"step {i}", False, [first, second]))
    root = py_trees.composites.Sequence("steps", memory=True, children=children)
    return py_trees.trees.BehaviourTree(root)


class _Seen(py_trees.visitors.VisitorBase):
    """A user's visitor: every node shown to it, in order."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.nodes: list[py_trees.behaviour.Behaviour] = []

    def run(self, behaviour: py_trees.behaviour.Behaviour) -> None:
        self.nodes.append(behaviour)


def _names(nodes: list[py_trees.behaviour.Behaviour]) -> list[str]:
    return [node.name for node in nodes]


def test_the_runner_gathers_the_ticked_nodes_as_visiting_them_would() -> None:
    """With the trace's visitor alone on the tree, tick_tree extends its list in C: the
    same nodes, in the same order, as a visitor shown each node (BehaviourTree.tick())."""
    traced, plain = _steps_tree(), _steps_tree()
    reader = NodeReader(traced)
    ticked = reader._ticked
    assert ticked.collects is ticked.nodes
    seen = _Seen()
    plain.visitors.append(seen)
    for _ in range(12):
        tick_tree(traced)
        plain.tick()
        assert _names(ticked.nodes) == _names(seen.nodes)
        assert ticked.nodes, "something ticked"
        ticked.nodes.clear()
        seen.nodes.clear()
    reader.close()
    assert traced.visitors == []


def test_a_node_that_overrides_visit_is_visited() -> None:
    """A node class with its own visit() keeps it: the reader's visitor does not claim
    that visiting is appending, and the runner visits node by node."""
    calls: list[str] = []

    class Visited(py_trees.behaviours.StatusQueue):
        def visit(self, visitor: Any) -> None:
            calls.append(self.name)
            super().visit(visitor)

    tree = _steps_tree(Visited)
    reader = NodeReader(tree)
    assert reader._ticked.collects is None
    for _ in range(6):
        tick_tree(tree)
    assert calls and all(name.startswith("retry") for name in calls)
    assert any(node.name.startswith("retry") for node in reader._ticked.nodes)


def test_with_another_visitor_every_visitor_sees_every_node() -> None:
    """The shortcut is for the trace's visitor alone: beside a user's visitor, both are
    shown each node as before."""
    tree = _steps_tree()
    reader = NodeReader(tree)
    seen = _Seen()
    tree.visitors.append(seen)
    tick_tree(tree)
    assert _names(reader._ticked.nodes) == _names(seen.nodes) != []
    assert isinstance(reader._ticked, TickedNodes)


def test_the_ring_is_mapped_ahead_and_still_carries_frames() -> None:
    """The ring's memory is faulted in by a thread; frames put meanwhile are intact, and
    closing waits for the thread."""
    created = Ring.create(1 << 16)
    if created is None:  # pragma: no cover - not Linux
        return
    ring, fd = created
    os.close(fd)
    try:
        head = 0
        frames = [bytes([n % 251]) * 700 for n in range(300)]  # wraps the 64 kB ring thrice
        for frame in frames:
            head = ring.put(head, frame)
            assert ring.get(head - len(frame), head) == frame
    finally:
        ring.close()
    assert ring._prefaulting is None
    ring.close()  # idempotent
