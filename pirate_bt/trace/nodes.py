"""Reading a running tree where it moved, for the trace recorder.

:class:`NodeReader` gives, after each tick, the nodes whose status or feedback
message changed since the last tick. It reads only where the tree moved: the
nodes ticked (noted by :class:`TickedNodes`, a py_trees visitor), the live
children beside them that a parent may have stopped, and the root; or every
node, through C-level comparisons, when it cannot follow the ticks (a bare root
behaviour, ``track_nodes=False``, the first tick, or a tree in which most nodes
tick every tick). See :class:`pirate_bt.trace.writer.TraceRecorder`'s
``track_nodes``.
"""

from __future__ import annotations

import operator
from itertools import compress
from typing import Any

import py_trees

from pirate_bt.trace.records import STATUS_CODE
from pirate_bt.trace.structure import iter_with_ids

__all__ = ["NodeReader", "TickedNodes"]

_get_status = operator.attrgetter("status")
_get_feedback = operator.attrgetter("feedback_message")
_is_not = operator.is_not
_ne = operator.ne
_code = STATUS_CODE.__getitem__

Changes = tuple[list[tuple[int, str]] | None, list[tuple[int, Any]] | None]
"""``(status, feedback)``: ``(node index, status code)`` and ``(node index, message)``
pairs in node order, each ``None`` when nothing changed."""


_UNCHANGED: Changes = (None, None)

_DENSE_TICKS = 20
"""Ticks in a row with most nodes ticked after which the reader reads every node."""


class TickedNodes(py_trees.visitors.VisitorBase):
    """A py_trees visitor that notes every node ticked, for :class:`NodeReader`.

    Not ``full``: ``BehaviourTree.tick()`` (and :func:`pirate_bt.runner.tick_tree`)
    show it each node as that node's tick yields, which is exactly the set of nodes
    ticked. The list is kept until the recorder reads and clears it.

    Args:
        exact: No node of the tree overrides ``Behaviour.visit``, so visiting a node is
            appending it to :attr:`nodes`: the visitor says so through ``collects``
            (the same list), and :func:`pirate_bt.runner.tick_tree` then gathers the
            ticked nodes with one ``list.extend`` in C instead of a visit per node.
    """

    def __init__(self, exact: bool = False) -> None:
        super().__init__(full=False)
        self.nodes: list[py_trees.behaviour.Behaviour] = []
        self.run = self.nodes.append  # type: ignore[assignment]  # one C call a node
        self.collects: list[py_trees.behaviour.Behaviour] | None = self.nodes if exact else None
        # Called around every tick and with nothing to do: C no-ops, not Python methods.
        self.initialise = self.finalise = _nothing  # type: ignore[method-assign]


_nothing = type(None)
"""Called with no arguments, returns ``None``: a no-op in C."""


_INVALID = py_trees.common.Status.INVALID


class NodeReader:
    """The status and feedback changes of a tree's nodes, tick after tick.

    Args:
        tree: The tree (a ``BehaviourTree`` or its root behaviour). Its shape must
            not change.
        track_nodes: Follow the ticks through a :class:`TickedNodes` visitor added to
            the tree's ``visitors`` (``None`` or ``True``; ``True`` needs a
            ``BehaviourTree``), or read every node every tick (``False``).

    Raises:
        ValueError: ``track_nodes=True`` for a bare root behaviour.
    """

    def __init__(self, tree: Any, track_nodes: bool | None = None) -> None:
        pairs = list(iter_with_ids(tree))
        self.ids: list[str] = [node_id for node_id, _ in pairs]
        """Path ids of the nodes, depth first (the trace's node order)."""
        self._nodes = [node for _, node in pairs]
        self.root: py_trees.behaviour.Behaviour = self._nodes[0]
        self._indices = range(len(self._nodes))
        self._status = [py_trees.common.Status.INVALID] * len(self._nodes)
        self._feedback: list[Any] = [""] * len(self._nodes)
        self._dense = 0
        visit = py_trees.behaviour.Behaviour.visit
        self._ticked = TickedNodes(exact=all(type(node).visit is visit for node in self._nodes))
        self._ticked_nodes = self._ticked.nodes
        self._visited: py_trees.trees.BehaviourTree | None = None
        if track_nodes is not False:
            if isinstance(tree, py_trees.trees.BehaviourTree):
                tree.visitors.append(self._ticked)
                self._visited = tree
            elif track_nodes:
                raise ValueError("track_nodes=True needs a BehaviourTree (its visitors)")
        index_of = {id(node): index for index, node in enumerate(self._nodes)}
        self._index_of = index_of
        self._children: list[tuple[int, ...]] = [
            tuple(index_of[id(child)] for child in node.children) for node in self._nodes
        ]
        self._last_ticked: list[py_trees.behaviour.Behaviour] = []
        self._watched_ids: list[int] = []
        self._watched: list[py_trees.behaviour.Behaviour] = []
        self._calm = False
        """Whether the next tick may take the shortcut of :meth:`changes`."""
        self._last_statuses: list[py_trees.common.Status] = []
        self._last_messages: list[Any] = []
        self._live: list[set[int]] = [set() for _ in self._nodes]
        """Per node: its children whose recorded status is not INVALID."""
        self._parent: list[int] = [-1] * len(self._nodes)
        for index, children in enumerate(self._children):
            for child in children:
                self._parent[child] = index

    def changes(self, first: bool = False) -> Changes:
        """What changed since the last call (``first``: the run's first tick, read whole)."""
        ticked = self._ticked_nodes
        if self._calm and ticked == self._last_ticked:
            # The common tick, at the cost of a few C calls: the same nodes ticked as
            # last time, few of them, and no status changed then, so the same nodes are
            # to be read (the ticked ones and the live children beside them).
            watched = self._watched
            if list(map(_get_status, watched)) == self._last_statuses:
                ticked.clear()
                messages = list(map(_get_feedback, watched))
                last = self._last_messages
                if messages == last:
                    return _UNCHANGED
                # A timeout's countdown or a step's progress changes a message every
                # tick: the changed ones noted, in node order (_watched_ids is sorted).
                # A plain loop: for a handful of nodes it is twice as fast as
                # map/compress/zip, whose iterator objects cost more than the compares.
                # The three lists are as long as _watched by construction; zip's strict
                # keyword would cost a third of the loop (keywords are parsed per call).
                changed: list[tuple[int, Any]] = []
                recorded = self._feedback
                for index, message, before in zip(self._watched_ids, messages, last):  # noqa: B905
                    if message != before:
                        recorded[index] = message
                        changed.append((index, message))
                self._last_messages = messages
                return None, changed
        status = feedback = None
        if self._visited is not None and not first:
            # Read where the tree moved: the nodes ticked, the ones their parents
            # stopped, and the root (see track_nodes).
            count = len(ticked)
            status, feedback = self._moved_changes(ticked)
            ticked.clear()
            # Most nodes ticked in every tick (a big parallel): reading them all is cheaper.
            self._dense = self._dense + 1 if count * 2 > len(self._nodes) else 0
            if self._dense >= _DENSE_TICKS:
                self.close()
        else:
            ticked.clear()
            # Every node, through map + attrgetter and one C-level list comparison;
            # map(is_not/ne) and compress pick out the nodes that changed, all in C.
            statuses = list(map(_get_status, self._nodes))
            if statuses != self._status:
                flags = list(map(_is_not, statuses, self._status))
                codes = map(_code, compress(statuses, flags))
                status = list(zip(compress(self._indices, flags), codes, strict=True))
                self._status = statuses
                self._relive()
            messages = list(map(_get_feedback, self._nodes))
            if messages != self._feedback:
                flags = list(map(_ne, messages, self._feedback))
                feedback = list(
                    zip(compress(self._indices, flags), compress(messages, flags), strict=True)
                )
                self._feedback = messages
        return status, feedback

    def close(self) -> None:
        """Stop following the ticks: take the visitor off the tree (idempotent)."""
        self._calm = False
        tree, self._visited = self._visited, None
        if tree is not None:
            tree.visitors[:] = [v for v in tree.visitors if v is not self._ticked]
        self._ticked.nodes.clear()

    def _relive(self) -> None:
        """Rebuild every node's set of live children from the recorded statuses."""
        statuses = self._status
        for index, children in enumerate(self._children):
            self._live[index] = {c for c in children if statuses[c] is not _INVALID}

    def _moved_changes(
        self, ticked: list[py_trees.behaviour.Behaviour]
    ) -> tuple[list[tuple[int, str]] | None, list[tuple[int, Any]] | None]:
        """Status and feedback changes of the nodes that moved since the last record.

        py_trees changes a node's status in its own tick, or in a ``stop()`` that its
        parent (or the tree, from outside a tick) calls; a stop turns a node INVALID,
        so a node that was INVALID and not ticked cannot have changed. Read: every
        ticked node; each live child of a ticked node that was not ticked itself; and
        the root. A stopped node's children are all read in turn (their stop may have
        written a feedback message), and so on down while nodes changed.
        """
        nodes, live, children, index_of = self._nodes, self._live, self._children, self._index_of
        moved = [index_of[id(node)] for node in ticked if id(node) in index_of]
        moved_set = set(moved)
        # Live children of ticked nodes that were not ticked themselves, and the root.
        pending = [c for index in moved for c in live[index] if c not in moved_set]
        if 0 not in moved_set:
            pending.append(0)
        status: list[tuple[int, str]] = []
        feedback: list[tuple[int, Any]] = []
        for index in moved:
            self._read(index, nodes[index], status, feedback)
        seen: set[int] = set()
        while pending:
            index = pending.pop()
            if index in seen or index in moved_set:
                continue
            seen.add(index)
            if self._read(index, nodes[index], status, feedback):
                pending.extend(children[index])  # stopped from outside its own tick
        # What the next tick's shortcut compares with (see changes).
        self._last_ticked = ticked[:]
        self._calm = (
            not status and len(moved) == len(ticked) and len(ticked) * 2 <= len(self._nodes)
        )
        self._watched_ids = sorted(moved + list(seen))
        self._watched = [nodes[index] for index in self._watched_ids]
        self._last_statuses = [self._status[index] for index in self._watched_ids]
        self._last_messages = [self._feedback[index] for index in self._watched_ids]
        if len(status) > 1:
            status.sort()
        if len(feedback) > 1:
            feedback.sort()
        return status or None, feedback or None

    def _read(
        self,
        index: int,
        node: py_trees.behaviour.Behaviour,
        status: list[tuple[int, str]],
        feedback: list[tuple[int, Any]],
    ) -> bool:
        """Note node ``index``'s changes in ``status``/``feedback``; whether its status moved."""
        message = node.feedback_message
        if message != self._feedback[index]:
            self._feedback[index] = message
            feedback.append((index, message))
        value = node.status
        if value is self._status[index]:
            return False
        self._status[index] = value
        status.append((index, _code(value)))
        up = self._parent[index]
        if up >= 0:
            if value is _INVALID:
                self._live[up].discard(index)
            else:
                self._live[up].add(index)
        return True
