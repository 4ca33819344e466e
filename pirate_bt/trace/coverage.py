"""Which nodes ever ran: a run's coverage, counted as BehaviorTree.CPP's ``TreeObserver`` counts it.

BT.CPP's ``TreeObserver`` keeps, per node, the number of status *transitions*
(changes to RUNNING, SUCCESS, FAILURE or SKIPPED; a change back to IDLE does not
count), and how many of them were to SUCCESS, FAILURE and SKIPPED. A test (or a
campaign of a thousand runs) then knows which nodes never ran and which guard
never took its failure branch. :class:`CoverageRecorder` counts the same for a
py_trees tree, off the tick path, plus what BT.CPP's observer cannot see:

``ticks``
    how many ticks reached the node;
``halts``
    how often it was stopped while RUNNING (a higher priority took over, a guard
    cut it short, the run ended);
``skips``
    how often its guard passed it over without ticking it (``skip_if``,
    ``while``, ``failure_if`` and any decorator that answers for its child).

py_trees and BT.CPP keep statuses differently. A BT.CPP parent resets its
children to IDLE when it finishes, a reactive one (``ReactiveSequence``,
``ReactiveFallback``) resets every child but the running one on each tick,
decorators reset their child when it finishes, and the tree resets its root
after a finished tick; composites and decorators turn RUNNING before they tick
a child. py_trees leaves a finished child's status as it was. The recorder
keeps each node's status *as BT.CPP would show it* (:data:`RUNNING`,
:data:`SUCCESS`, :data:`FAILURE`, or :data:`IDLE` plus the status it was reset
from: BT.CPP's "was SUCCESS, now idle" codes 11, 12, 13) and counts transitions
against that, so a condition re-checked by a reactive sequence on every tick
counts one success per tick, as in BT.CPP. The Groot2 server
(:mod:`pirate_bt.interop.groot2_server`) shows the same codes: it listens to
the recorder (:meth:`CoverageRecorder.add_listener`).

Cost: the recorder adds a py_trees visitor that notes each node ticked (one
C-level ``append``) and, after the tick, reads those nodes. A tick that repeats
the last one exactly (the same nodes ticked, the same statuses, the last tick
a fixed point: the common case while an action runs) is recognised with two
C-level list comparisons and counted in bulk later.

Attach one to a runner with :func:`attach_coverage` (the API does for every
run: ``RunResult.coverage``, ``MissionResult.coverage``); read the counts with
:meth:`CoverageRecorder.coverage`. The counts as data (:class:`Coverage`,
:class:`NodeCoverage`, :func:`merge_coverage`, their JSON and table) are
:mod:`pirate_bt.trace.coverage_counts`, re-exported here.
"""

from __future__ import annotations

import operator
import weakref
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Final

import py_trees
from py_trees.common import Status

from pirate_bt.trace.coverage_counts import (
    _FIELDS,
    GUARDS,
    Coverage,
    NodeCoverage,
    merge_coverage,
    name_paths,
)
from pirate_bt.trace.coverage_counts import _LETTER as _LETTER
from pirate_bt.trace.structure import iter_with_ids, node_kind

__all__ = [
    "FAILURE",
    "GUARDS",
    "IDLE",
    "RUNNING",
    "SKIPPED",
    "SUCCESS",
    "Coverage",
    "CoverageRecorder",
    "NodeCoverage",
    "attach_coverage",
    "coverage_of",
    "merge_coverage",
    "name_paths",
]

IDLE: Final = 0
RUNNING: Final = 1
SUCCESS: Final = 2
FAILURE: Final = 3
SKIPPED: Final = 4
"""BT.CPP's ``NodeStatus`` values; ``10 + s`` is "was ``s``, now IDLE"."""

_CODE: Final = {Status.INVALID: IDLE, Status.RUNNING: RUNNING, Status.SUCCESS: SUCCESS}
_CODE[Status.FAILURE] = FAILURE
_status = operator.attrgetter("status")


class _Ticked(py_trees.visitors.VisitorBase):
    """Notes every node ticked (not ``full``: shown each node as its tick yields)."""

    def __init__(self) -> None:
        super().__init__(full=False)
        self.nodes: list[py_trees.behaviour.Behaviour] = []
        self.run = self.nodes.append  # type: ignore[assignment]  # one C call a node


Listener = Callable[[Mapping[int, int], Sequence[tuple[int, int]]], None]
"""``listener(codes, transitions)`` after each tick: the node indices whose BT.CPP-view
code changed (index -> new code), and the tick's transitions in order (index, BT.CPP
status 0-4; 0 is a reset or halt to IDLE)."""


def _kind(node: py_trees.behaviour.Behaviour) -> str:
    """The node's kind (:func:`~pirate_bt.trace.structure.node_kind`), with ``condition``
    for a leaf whose class declares only success and failure as outcomes."""
    kind = node_kind(node)
    outcomes = getattr(type(node), "outcomes", None)
    if kind == "leaf" and callable(outcomes):
        try:
            found = outcomes(getattr(node, "params", None))
        except Exception:  # outcomes that need parameters it has not got: not a condition
            return kind
        if set(found) == {"success", "failure"}:
            return "condition"
    return kind


class CoverageRecorder:
    """Counts, per node, ticks, transitions, successes, failures, halts and skips.

    Args:
        tree: The tree (a ``py_trees.trees.BehaviourTree``: the recorder adds a
            visitor to it). Its shape must not change.
        name: The tree's name (default: the root's).

    Call :meth:`record_tick` after every tick (the runner's post-tick hook does,
    see :func:`attach_coverage`) and :meth:`finish` once at the end.
    """

    def __init__(self, tree: py_trees.trees.BehaviourTree, name: str | None = None) -> None:
        if not isinstance(tree, py_trees.trees.BehaviourTree):
            raise TypeError("coverage needs a py_trees BehaviourTree (it adds a visitor)")
        from pirate_bt.behaviours.guards_nodes import _Precondition

        pairs = list(iter_with_ids(tree))
        self.tree = tree
        self.name = name or str(tree.root.name)
        self.ids = [node_id for node_id, _ in pairs]
        self.nodes = [node for _, node in pairs]
        n = len(self.nodes)
        self._index_of = {id(node): i for i, node in enumerate(self.nodes)}
        self.parent = [-1] * n
        self.children: list[tuple[int, ...]] = []
        for node in self.nodes:
            self.children.append(tuple(self._index_of[id(c)] for c in node.children))
        for i, kids in enumerate(self.children):
            for c in kids:
                self.parent[c] = i
        self.kinds = [_kind(node) for node in self.nodes]
        self.paths = name_paths([str(node.name) for node in self.nodes], self.parent)
        composites = py_trees.composites
        self._leaf = [
            not isinstance(node, composites.Composite | py_trees.decorators.Decorator)
            and not node.children
            for node in self.nodes
        ]
        self._decorator = [
            not isinstance(node, composites.Composite) and len(node.children) == 1
            for node in self.nodes
        ]
        # Reactive composites reset every child but the running one (BT.CPP's
        # ReactiveSequence and ReactiveFallback); the others keep finished children
        # while they run (Sequence, Fallback, Parallel).
        self._reactive = [
            isinstance(node, composites.Sequence | composites.Selector) and not node.memory
            for node in self.nodes
        ]
        self._guard = [isinstance(node, _Precondition) for node in self.nodes]
        self.shown = [IDLE] * n
        """Each node's status as BT.CPP would show it (see the module docstring)."""
        self._py: list[Status] = [Status.INVALID] * n
        self._counts = [[0] * len(_FIELDS) for _ in range(n)]
        self._visitor = _Ticked()
        tree.visitors.append(self._visitor)
        self._listeners: list[tuple[Listener, bool]] = []
        self._last_ticked: list[py_trees.behaviour.Behaviour] = []
        self._last_statuses: list[Status] = []
        self._steady = False
        self._streak = 0
        self._deltas: list[tuple[int, list[int]]] = []
        self._events: list[tuple[int, int]] = []
        self._finished = False

    # -- reading the tick in progress

    def index_of(self, node: py_trees.behaviour.Behaviour) -> int | None:
        """The node's index (depth first, as in traces), or ``None`` if not of this tree."""
        return self._index_of.get(id(node))

    def ticked_so_far(self) -> list[py_trees.behaviour.Behaviour]:
        """The nodes whose tick has ended so far in the tick in progress."""
        return list(self._visitor.nodes)

    # -- listening

    def add_listener(self, listener: Listener, transitions: bool = True) -> None:
        """Call ``listener(codes, transitions)`` after every tick that changed something
        (and, with ``transitions``, after every tick with transitions)."""
        self._listeners.append((listener, transitions))

    def remove_listener(self, listener: Listener) -> None:
        self._listeners = [(fn, t) for fn, t in self._listeners if fn is not listener]

    # -- recording

    def record_tick(self, _info: object = None) -> None:
        """Count the tick that just ended (a runner post-tick hook)."""
        ticked = self._visitor.nodes
        if not ticked:
            return  # a paused tick: nothing ran
        statuses = list(map(_status, ticked))
        if self._steady and ticked == self._last_ticked and statuses == self._last_statuses:
            self._streak += 1
            ticked.clear()
            if self._events:
                for listener, wants in self._listeners:
                    if wants:
                        listener({}, self._events)
            return
        self._flush()
        last = ticked[:]
        ticked.clear()
        self._tick(last, statuses)

    def _flush(self) -> None:
        streak, self._streak = self._streak, 0
        if streak:
            counts = self._counts
            for index, delta in self._deltas:
                row = counts[index]
                for k, value in enumerate(delta):
                    if value:
                        row[k] += value * streak

    def _tick(self, ticked: list[py_trees.behaviour.Behaviour], statuses: list[Status]) -> None:
        index_of, shown, py, counts = self._index_of, self.shown, self._py, self._counts
        leaf, children, parent = self._leaf, self.children, self.parent
        order = sorted({index_of[id(node)] for node in ticked if id(node) in index_of})
        ticked_set = set(order)
        before = {i: shown[i] for i in order}
        deltas: dict[int, list[int]] = {}
        events: list[tuple[int, int]] = []
        stopped = False

        def delta(i: int) -> list[int]:
            row = deltas.get(i)
            if row is None:
                row = deltas[i] = [0] * len(_FIELDS)
            return row

        def reset(i: int) -> None:  # BT.CPP resetStatus(): a finished node back to IDLE
            if shown[i] in (SUCCESS, FAILURE):
                before.setdefault(i, shown[i])
                shown[i] += 10
                events.append((i, IDLE))

        def halt(i: int) -> None:
            before.setdefault(i, shown[i])
            if shown[i] == RUNNING:
                delta(i)[4] += 1
                shown[i] = 10 + RUNNING
                events.append((i, IDLE))
            elif parent[i] >= 0 and self._keeps(parent[i]):
                pass  # BT.CPP's Fallback and Parallel keep a finished child while they run
            else:
                reset(i)

        # 1. Every node ticked, parents first: composites and decorators turn RUNNING
        #    before their children run, then each node ends with its result.
        for i in order:
            row = delta(i)
            row[0] += 1
            status = self.nodes[i].status
            py[i] = status
            if not leaf[i] and shown[i] != RUNNING:
                row[1] += 1
                shown[i] = RUNNING
                events.append((i, RUNNING))
            code = _CODE[status]
            if code == IDLE:  # ticked, then stopped within the same tick
                if leaf[i] and shown[i] != RUNNING:
                    row[1] += 1
                    shown[i] = RUNNING
                    events.append((i, RUNNING))
                halt(i)
                stopped = True
            elif shown[i] != code:
                row[1] += 1
                shown[i] = code
                events.append((i, code))
                if code == SUCCESS:
                    row[2] += 1
                elif code == FAILURE:
                    row[3] += 1
        # 2. Nodes a ticked parent stopped without ticking them (and their children).
        pending = [c for i in order for c in children[i] if c not in ticked_set]
        if 0 not in ticked_set:
            pending.append(0)
        seen: set[int] = set()
        while pending:
            i = pending.pop()
            if i in seen or i in ticked_set:
                continue
            seen.add(i)
            status = self.nodes[i].status
            if status is py[i]:
                continue
            py[i] = status
            stopped = True
            if status is Status.INVALID:
                halt(i)
                pending.extend(children[i])
            else:  # set from outside a tick (rare): count it as BT.CPP would
                code = _CODE[status]
                before.setdefault(i, shown[i])
                if shown[i] != code:
                    delta(i)[1] += 1
                    shown[i] = code
                    events.append((i, code))
        # 3. Skips: a decorator that answered without ticking its (idle) child.
        for i in order:
            if self._decorator[i] and not leaf[i]:
                child = children[i][0]
                idle = child not in ticked_set and before.get(child, shown[child]) != RUNNING
                if idle and (self._guard[i] or shown[i] in (SUCCESS, FAILURE)):
                    delta(child)[5] += 1
        # 4. Resets: a finished parent resets its children; a running reactive one
        #    every child but the running one; a running decorator a finished child.
        #    Deepest first: a parent resets a child that has already reset its own.
        for i in reversed(order):
            if leaf[i]:
                continue
            mine = shown[i]
            if mine in (SUCCESS, FAILURE):
                for c in children[i]:
                    reset(c)
            elif mine == RUNNING and (self._reactive[i] or self._decorator[i]):
                for c in children[i]:
                    if shown[c] != RUNNING:
                        reset(c)
        # 5. The tree resets its root after a finished tick.
        reset(0)
        changed = {i: shown[i] for i, was in before.items() if shown[i] != was}
        self._last_ticked = ticked
        self._last_statuses = statuses
        self._steady = not changed and not stopped
        self._deltas = [(i, row) for i, row in deltas.items()]
        self._events = events
        for i, row in self._deltas:
            target = counts[i]
            for k, value in enumerate(row):
                if value:
                    target[k] += value
        if self._listeners:
            for listener, wants in self._listeners:
                if changed or (wants and events):
                    listener(changed, events if wants else ())

    def _keeps(self, i: int) -> bool:
        """Whether node ``i`` keeps a finished child while it runs (BT.CPP's memory
        composites and Parallel do; py_trees' memory Selector resets them itself)."""
        return (
            not self._leaf[i]
            and not self._reactive[i]
            and not self._decorator[i]
            and (self.shown[i] == RUNNING)
        )

    def finish(self, _result: object = None) -> None:
        """Count the halts of the run's end (the runner stops running nodes after the
        last tick); a runner finish hook. Idempotent."""
        if self._finished:
            return
        self._finished = True
        self._flush()
        changed: dict[int, int] = {}
        events: list[tuple[int, int]] = []
        for i, node in enumerate(self.nodes):
            status = node.status
            if status is self._py[i]:
                continue
            self._py[i] = status
            if status is Status.INVALID and self.shown[i] == RUNNING:
                self._counts[i][4] += 1
                self.shown[i] = changed[i] = 10 + RUNNING
                events.append((i, IDLE))
        if changed:
            for listener, wants in self._listeners:
                listener(changed, events if wants else ())
        self.close()

    def close(self) -> None:
        """Take the visitor off the tree (idempotent)."""
        visitors = self.tree.visitors
        if self._visitor in visitors:
            visitors[:] = [v for v in visitors if v is not self._visitor]

    # -- reading

    def coverage(self) -> Coverage:
        """The counts so far."""
        self._flush()
        return Coverage(
            self.name,
            tuple(
                NodeCoverage(
                    self.paths[i],
                    self.ids[i],
                    type(node).__name__,
                    self.kinds[i],
                    *self._counts[i],
                )
                for i, node in enumerate(self.nodes)
            ),
        )


_RECORDERS: weakref.WeakKeyDictionary[Any, CoverageRecorder] = weakref.WeakKeyDictionary()


def coverage_of(runner: Any) -> CoverageRecorder | None:
    """The recorder :func:`attach_coverage` put on ``runner``, if any."""
    return _RECORDERS.get(runner)


def attach_coverage(runner: Any, name: str | None = None) -> CoverageRecorder:
    """Count ``runner``'s coverage: a post-tick hook and a finish hook (once per runner).

    Args:
        runner: A :class:`pirate_bt.runner.Runner` (not yet run); duck-typed
            (``tree``, ``add_post_tick``, ``add_finish``).
        name: The tree's name (default: the root's).

    Returns:
        The recorder (the same one when called again for the same runner).
    """
    recorder = _RECORDERS.get(runner)
    if recorder is None:
        recorder = CoverageRecorder(runner.tree, name)
        _RECORDERS[runner] = recorder
        runner.add_post_tick(recorder.record_tick)
        runner.add_finish(recorder.finish)
    return recorder
