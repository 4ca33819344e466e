"""Questions a planner asks of a trace, as methods of :class:`~pirate_bt.trace.Trace`.

Nodes are named by their *path* of names from the root (``straight/pass
straight/hold/hold/clamp rear``), by a tail of that path (``clamp rear``,
``hold/clamp rear``), by their path id (``0.0.0.0.0``) or by a glob
(``*/clamp rear``). Statuses are the words ``"SUCCESS"``, ``"FAILURE"``,
``"RUNNING"`` and ``"INVALID"`` (the trace stores them as ``S``/``F``/``R``/``I``);
any letter case, a one-letter code or a py_trees ``Status`` is accepted as input.

A trace stores changes only, so these queries report changes: a node that
succeeds tick after tick without another status in between turned SUCCESS once.

Example::

    trace = read_trace("run.jsonl")
    trace.nodes("*clamp*")                       # ['straight/.../clamp rear', ...]
    trace.first_tick("clamp rear half", "SUCCESS")  # 21, or None if it never succeeded
    trace.status_at("drive straight", 50)        # 'RUNNING'
    first = trace.failures()[0]                  # the first node that failed, and why
    print(first.tick, first.path, first.feedback)
    trace.outcome, trace.why                     # ('failure', 'tree failed after 203 ticks')
"""

from __future__ import annotations

import difflib
import operator
from bisect import bisect_right
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any, NamedTuple

import py_trees

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, InputError, shown
from pirate_bt.trace.records import STATUS_CODE
from pirate_bt.trace.structure import NodeInfo, TreeStructure

__all__ = [
    "STATUS_WORDS",
    "Failure",
    "FeedbackChange",
    "NodeLookupError",
    "StatusChange",
    "TraceQueries",
    "status_code",
]

STATUS_WORDS: Mapping[str, str] = {"S": "SUCCESS", "F": "FAILURE", "R": "RUNNING", "I": "INVALID"}
"""Status code as stored in a trace -> the word the queries use."""

_WORD_CODES = {word: code for code, word in STATUS_WORDS.items()}
_GLOB = frozenset("*?[")
_MAX_QUERY = 4096
"""The longest node name, path or glob asked for (a glob's regular expression grows
with it)."""


def _query_text(value: object, option: str, what: str) -> str:
    if not isinstance(value, str):
        raise ArgumentTypeError(f"{option}: give {what}, not {shown(value)}")
    if len(value) > _MAX_QUERY:
        raise ArgumentValueError(
            f"{option}: {len(value)} characters is longer than a node's path may be"
            f" (at most {_MAX_QUERY})"
        )
    return value


NodeRef = str | NodeInfo
"""A node: its path (or a tail of it), its name, its id, a glob, or its NodeInfo."""


def status_code(status: str | py_trees.common.Status) -> str:
    """The trace's one-letter code for ``status``.

    Accepts ``"SUCCESS"``/``"success"``/``"S"`` (and so on) or a py_trees ``Status``.

    Raises:
        ArgumentValueError: not a status (an :class:`~pirate_bt.errors.InputError` and a
            ``ValueError``).
    """
    if isinstance(status, py_trees.common.Status):
        return STATUS_CODE[status]
    if isinstance(status, str) and len(status) <= 16:
        text = status.strip().upper()
        if text in STATUS_WORDS:
            return text
        if text in _WORD_CODES:
            return _WORD_CODES[text]
    raise ArgumentValueError(
        f"status: not a status: {shown(status)}; use one of {', '.join(_WORD_CODES)}"
    )


class StatusChange(NamedTuple):
    """A node's status changed at the end of a tick."""

    tick: int
    time_s: float
    status: str
    """``SUCCESS``, ``FAILURE``, ``RUNNING`` or ``INVALID``."""


class FeedbackChange(NamedTuple):
    """A node's feedback message changed at the end of a tick."""

    tick: int
    time_s: float
    message: str


@dataclass(frozen=True, slots=True)
class Failure:
    """A node finished with FAILURE.

    Attributes:
        tick: The tick it failed in.
        time_s: Seconds since the run started, at that tick.
        path: The node's path of names from the root.
        feedback: Its feedback message at the end of that tick (often the reason).
        node: The node.
    """

    tick: int
    time_s: float
    path: str
    feedback: str
    node: NodeInfo


class NodeLookupError(InputError, KeyError):
    """No node, or more than one, answers to a name.

    Attributes:
        query: What was asked for.
        matches: The paths of the nodes that matched (several) or came close (none).
    """

    def __init__(self, message: str, query: str, matches: Sequence[str]) -> None:
        super().__init__(message)
        self.query = query
        self.matches = list(matches)

    def __str__(self) -> str:
        return str(self.args[0])


class _Index:
    """Per-node status and feedback changes, built from the tick records.

    It remembers which ticks it read (the list, how many of it, and the last one), so
    that a query can tell in a few comparisons whether it still answers for
    ``trace.ticks``: a list replaced or cut (``trace.ticks = trace.ticks[:10]``) is read
    again, one that grew (ticks appended to it) is read on from where it stopped.
    """

    def __init__(self, structure: TreeStructure, ticks: Sequence[Any]) -> None:
        self.structure = structure
        self.paths: dict[str, str] = {}
        for node in structure:
            parent = self.paths.get(node.parent) if node.parent is not None else None
            self.paths[node.id] = f"{parent}/{node.name}" if parent is not None else node.name
        self.by_path: dict[str, list[str]] = {}
        for node_id, path in self.paths.items():
            self.by_path.setdefault(path, []).append(node_id)
        self.status: dict[str, list[StatusChange]] = {n.id: [] for n in structure}
        # each node's first tick with each status: first_tick without a scan
        self.first: dict[str, dict[str, int]] = {n.id: {} for n in structure}
        self.feedback: dict[str, list[FeedbackChange]] = {n.id: [] for n in structure}
        self._last_status = {n.id: "I" for n in structure}
        self._last_feedback = {n.id: "" for n in structure}
        self.ticks: Sequence[Any] = ticks
        self.read = 0
        self.last_read: Any = None
        self.read_on()
        # Within a tick a child finishes before its parent, an earlier sibling before
        # a later one: post-order.
        self.finish_order: dict[str, int] = {}
        stack: list[tuple[str, bool]] = [(structure.root.id, False)]
        while stack:
            node_id, expanded = stack.pop()
            if expanded:
                self.finish_order[node_id] = len(self.finish_order)
                continue
            stack.append((node_id, True))
            for child in reversed(structure.node(node_id).children):
                stack.append((child, False))

    def answers_for(self, structure: TreeStructure, ticks: Sequence[Any]) -> bool | None:
        """``True``: it holds every change of ``ticks``; ``None``: it holds a start of
        them (they grew since), :meth:`read_on` completes it; ``False``: other ticks."""
        read = self.read
        if structure is not self.structure or ticks is not self.ticks or len(ticks) < read:
            return False
        if read and ticks[read - 1] is not self.last_read:
            return False  # the list was changed in place
        return True if len(ticks) == read else None

    def read_on(self) -> None:
        """Take in the ticks after the last one read."""
        last_status, last_feedback = self._last_status, self._last_feedback
        ticks = self.ticks
        for at in range(self.read, len(ticks)):
            tick = ticks[at]
            for node_id, code in tick.status.items():
                if node_id in last_status and last_status[node_id] != code:
                    last_status[node_id] = code
                    word = STATUS_WORDS.get(code, code)
                    self.status[node_id].append(StatusChange(tick.n, tick.t_s, word))
                    self.first[node_id].setdefault(word, tick.n)
            for node_id, message in tick.feedback.items():
                if node_id in last_feedback and last_feedback[node_id] != message:
                    last_feedback[node_id] = message
                    self.feedback[node_id].append(FeedbackChange(tick.n, tick.t_s, message))
        self.read = len(ticks)
        self.last_read = ticks[-1] if ticks else None


class TraceQueries:
    """The query methods of :class:`~pirate_bt.trace.Trace` (a mixin).

    See :mod:`pirate_bt.trace.query` for how nodes and statuses are named.
    """

    path: Path
    structure: TreeStructure
    ticks: list[Any]  # the reader's TickRecords (not imported: no circle)
    end: Mapping[str, Any] | None
    _query_index: _Index | None = None

    @property
    def last_tick(self) -> int:  # provided by Trace
        raise NotImplementedError

    def tick_number(self, tick: object, option: str = "tick") -> int:
        """``tick`` checked: a whole number from 0 to :attr:`last_tick`.

        Raises:
            ArgumentTypeError: not a whole number (a float, a bool, text), named by
                ``option``.
            ArgumentValueError: out of the trace's ticks (an ``InputError`` and a
                ``ValueError``, as every refused value).
        """
        if isinstance(tick, bool):
            raise ArgumentTypeError(f"{option}: give a tick's number, not {tick!r}")
        try:
            number = operator.index(tick)  # type: ignore[arg-type]
        except TypeError:
            kind = "None" if tick is None else type(tick).__name__
            raise ArgumentTypeError(
                f"{option}: give a tick's number (a whole number), not {shown(tick)} ({kind})"
            ) from None
        if not 0 <= number <= self.last_tick:
            raise ArgumentValueError(
                f"{self.path}: no tick {shown(number)}; the trace has ticks 0 to {self.last_tick}"
            )
        return number

    def _index(self) -> _Index:
        # Built once, and again only when the ticks (or the tree) are not the ones it
        # read: a trace whose ticks were replaced, cut or appended to answered from the
        # old ticks (a node that failed in an appended tick had never failed).
        index = self._query_index
        ticks = self.ticks
        if index is not None:
            fits = index.answers_for(self.structure, ticks)
            if fits:
                return index
            if fits is None:  # grown: read on
                index.read_on()
                return index
        index = self._query_index = _Index(self.structure, ticks)
        return index

    # --- nodes ---------------------------------------------------------------------

    def nodes(self, pattern: str | None = None) -> list[str]:
        """The paths of the tree's nodes, root first (depth first), optionally filtered.

        Args:
            pattern: A glob on the whole path when it holds ``*``, ``?`` or ``[``
                (``"*/clamp rear"``: every node named ``clamp rear``), else a
                substring of the path (``"clamp"``). Case-sensitive.

        Example::

            >>> trace.nodes("*/clamp rear*")
            ['straight/pass straight/hold/hold/clamp rear',
             'straight/pass straight/hold/hold/clamp rear/clamp rear half']
        """
        if pattern is not None:
            pattern = _query_text(pattern, "pattern", "text (a glob or part of a path) or None")
        paths = list(self._index().paths.values())
        if pattern is None:
            return paths
        if _GLOB.intersection(pattern):
            return [p for p in paths if fnmatchcase(p, pattern)]
        return [p for p in paths if pattern in p]

    def node_path(self, node: NodeRef) -> str:
        """The path of names from the root to ``node`` (see :meth:`node`).

        Example::

            >>> trace.node_path("0.0.1.0")
            'straight/pass straight/confirm drive/drive straight'
        """
        return self._index().paths[self.node(node).id]

    def node(self, path_or_name: NodeRef) -> NodeInfo:
        """The node that answers to ``path_or_name``.

        Tried in turn: a :class:`NodeInfo` of this tree, a path id (``0.1.2``), a
        whole path, a tail of a path that ends at a node (``clamp rear`` or
        ``hold/clamp rear``), and a glob (``*/clamp r*``). The first of these
        that matches anything decides.

        Example::

            >>> trace.node("drive straight").type
            'Drive'

        Raises:
            NodeLookupError: (an :class:`~pirate_bt.errors.InputError` and a
                ``KeyError``) no node matches (the message suggests close
                matches), or several do (the message lists them).
        """
        index = self._index()
        if isinstance(path_or_name, NodeInfo):
            if path_or_name.id in self.structure and self.structure.node(path_or_name.id) == (
                path_or_name
            ):
                return path_or_name
            query = path_or_name.id
            raise NodeLookupError(
                f"{self.path}: node {query} ({path_or_name.name!r}) is not in this trace's tree",
                query,
                [],
            )
        query = _query_text(
            path_or_name, "node", "a node's path, name, id or glob (text) or a NodeInfo"
        )
        if query in self.structure:
            return self.structure.node(query)
        ids = index.by_path.get(query, [])
        if not ids:
            ids = [i for i, p in index.paths.items() if p.endswith("/" + query)]
        if not ids and _GLOB.intersection(query):
            ids = [i for i, p in index.paths.items() if fnmatchcase(p, query)]
        if len(ids) == 1:
            return self.structure.node(ids[0])
        if ids:
            listed = "; ".join(f"{index.paths[i]} ({i})" for i in ids)
            raise NodeLookupError(
                f"{self.path}: {shown(query)} matches {len(ids)} nodes: {listed};"
                " give more of the path, or the id",
                query,
                [index.paths[i] for i in ids],
            )
        names = {n.name for n in self.structure}
        candidates = sorted(names | set(index.paths.values()))
        close = difflib.get_close_matches(query, candidates, n=5, cutoff=0.6)
        if not close:
            close = [p for p in candidates if query.lower() in p.lower()][:5]
        hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        if not close and len(names) <= 30:
            listed = ", ".join(sorted(names))
            hint = f"; its nodes are: {listed if len(listed) <= 240 else listed[:240] + '...'}"
        raise NodeLookupError(
            f"{self.path}: no node {shown(query)} in tree {self.structure.name!r}{hint}",
            query,
            close,
        )

    # --- statuses ------------------------------------------------------------------

    def statuses(self, node: NodeRef) -> list[StatusChange]:
        """Every change of ``node``'s status over the run, in order.

        Each change is a ``(tick, time_s, status)`` named tuple. Every node is
        INVALID before tick 1; that is not listed.

        Example::

            >>> trace.statuses("clamp rear half")
            [StatusChange(tick=1, time_s=0.0, status='RUNNING'),
             StatusChange(tick=21, time_s=1.0, status='SUCCESS')]
        """
        return list(self._index().status[self.node(node).id])

    def status_at(self, node: NodeRef, tick: int) -> str:
        """``node``'s status at the end of ``tick`` (0 is before the first tick).

        (:meth:`~pirate_bt.trace.Trace.statuses_at` gives every node at once, as
        py_trees statuses by id.)

        Example::

            >>> trace.status_at("drive straight", 60)
            'RUNNING'

        Raises:
            InputError: ``tick`` is not a whole number, negative or beyond the last tick.
            NodeLookupError: see :meth:`node`.
        """
        tick = self.tick_number(tick)
        # a search, not a copy and a walk of every change: a loop over a run's 100,000
        # ticks took minutes, each call as long as the node's history
        changes = self._index().status[self.node(node).id]
        at = bisect_right(changes, tick, key=operator.attrgetter("tick"))
        return changes[at - 1].status if at else "INVALID"

    def first_tick(self, node: NodeRef, status: str | py_trees.common.Status) -> int | None:
        """The first tick at whose end ``node`` had ``status``; ``None`` if it never did.

        ``INVALID`` is tick 0 (every node is INVALID before the first tick).

        Example::

            >>> trace.first_tick("drive straight", "success")
            107
            >>> trace.first_tick("report failure", "FAILURE") is None
            True
        """
        code = status_code(status)
        node_id = self.node(node).id
        if code == "I":
            return 0
        return self._index().first[node_id].get(STATUS_WORDS[code])

    def feedback(self, node: NodeRef) -> list[FeedbackChange]:
        """Every change of ``node``'s feedback message, in order.

        Each change is a ``(tick, time_s, message)`` named tuple; empty if the
        node never set one (or the trace did not record them).

        Example::

            >>> trace.feedback("clamp rear half")[-1].message
            'timeout: not done after 5 s (clamping rear: ...)'
        """
        return list(self._index().feedback[self.node(node).id])

    def failures(self) -> list[Failure]:
        """Every time a node finished with FAILURE, the first failure first.

        Within a tick, children come before their parents (a child fails first,
        and its failure fails the parent), so ``failures()[0]`` is where the run
        first went wrong. A node that fails again in the next tick, with no other
        status in between, is listed once (a trace stores changes).

        Example::

            >>> first = trace.failures()[0]
            >>> first.tick, first.path, first.feedback
            (102, 'straight/pass straight/hold/hold/clamp rear/clamp rear half',
             'timeout: not done after 5 s (clamping rear: ...)')
        """
        index = self._index()
        found: list[tuple[int, int, Failure]] = []
        for node_id, changes in index.status.items():
            messages = index.feedback[node_id]
            message_ticks = [fb.tick for fb in messages]
            for change in changes:
                if change.status != "FAILURE":
                    continue
                at = bisect_right(message_ticks, change.tick)
                message = messages[at - 1].message if at else ""
                failure = Failure(
                    change.tick,
                    change.time_s,
                    index.paths[node_id],
                    message,
                    self.structure.node(node_id),
                )
                found.append((change.tick, index.finish_order[node_id], failure))
        found.sort(key=lambda item: item[:2])
        return [failure for _, _, failure in found]

    # --- the end ---------------------------------------------------------------------

    @property
    def why(self) -> str | None:
        """Why the run ended, from the end record (``None`` without one, or without a reason).

        A crash adds the node that raised and the exception. The failure that
        started it all is ``failures()[0]``.

        Example::

            >>> trace.outcome, trace.why
            ('success', 'tree succeeded after 107 ticks')
        """
        if self.end is None:
            return None
        reason = self.end.get("reason")
        parts = [str(reason)] if reason else []
        error = self.end.get("error")
        if isinstance(error, Mapping):
            node_id = error.get("node")
            where = ""
            if isinstance(node_id, str) and node_id in self.structure:
                where = f"{self._index().paths[node_id]}: "
            exception = error.get("exception")
            if (exception or where) and not _said_in(exception, reason):
                parts.append(f"{where}{exception or 'error'}")
        return "; ".join(parts) or None


def _said_in(exception: object, reason: object) -> bool:
    """Whether the end's reason already says the exception (``ValueError in plain:
    plain broke`` for ``ValueError: plain broke``), so ``why`` says it once."""
    if not isinstance(exception, str) or not isinstance(reason, str) or not exception:
        return False
    kind, _, message = exception.partition(": ")
    # the run's line folds the message's whitespace (errors.said_of): a message with a
    # line break was said twice, `... plain broke second line; b: ...: plain broke\nsecond`
    return kind in reason and " ".join(message.split()) in " ".join(reason.split())
