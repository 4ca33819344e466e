"""The checks a trace's records pass as they are read, whoever reads them.

A trace header holds a tree (``tree.nodes``: ids, ``parent`` and ``children``),
and everything that reads a trace walks it: coverage looks parents up, the
summary and plots find the steps, the exporters walk it child by child. A
header written by hand (or damaged) could hold a tree that is none: a node
that is its own ancestor made an exporter loop for ever, a parent that is no
node a ``KeyError`` deep inside a summary. :func:`tree_problem` says what is
wrong with such a tree in time linear in its size, and :func:`checked_iteration`
makes every format reader's records pass it (and the tick records pass the
reader's own check), so that :func:`~pirate_bt.trace.reader.read_trace`, the
exporters that read records one by one and a plugin format's reader all refuse
the same file with the same located line.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, Final, Protocol, TypeVar

from pirate_bt.errors import LocatedError, SourceLocation, shown
from pirate_bt.trace import record_values as values
from pirate_bt.trace.records import end_problem

__all__ = ["Pairs", "TickCheck", "checked_iteration", "tree_problem", "unchecked"]

_SHOWN: Final = 60
"""Characters of an id shown in a message (an id may be any text of a hand-made file)."""

Pairs = Iterator[tuple[int, dict[str, Any]]]
"""A format reader's records, numbered from 1: ``(line, record)``."""

TickCheck = Callable[[Mapping[str, Any], int, Path], object]
"""Checks one tick record ``(record, line, path)``, raising a located error if it is bad."""


class _Reader(Protocol):
    path: Path


_R = TypeVar("_R", bound=_Reader)


def _id(value: object) -> str:
    return shown(value, _SHOWN)


def tree_problem(tree: Mapping[str, Any]) -> str | None:
    """What is wrong with a header's ``tree`` as a tree, or ``None`` if it is one.

    The nodes must be JSON objects with a text ``id`` (no two alike), a ``name``,
    a ``parent`` that is ``null`` or a node's id and ``children`` that is a list
    of node ids; each node must be listed once, by the node its ``parent``
    names, none may be its own ancestor, and exactly one node (the first) has no
    parent: the root. Linear in the number of nodes and children.
    """
    nodes = tree.get("nodes")
    if not isinstance(nodes, list):
        return "tree.nodes is not a list"
    if not nodes:
        return "tree.nodes is empty"
    parent_of: dict[str, str | None] = {}
    children_of: dict[str, list[str]] = {}
    for index, node in enumerate(nodes):
        if not isinstance(node, Mapping):
            return f"node {index} of tree.nodes is not a JSON object"
        node_id = node.get("id")
        if not isinstance(node_id, str):
            return f"node {index} of tree.nodes has no text id (its id: {_id(node_id)})"
        if node_id in parent_of:
            return f"node id {_id(node_id)} is given to two nodes"
        if "name" not in node:
            return f"node {_id(node_id)} has no name"
        if not isinstance(node.get("params", {}), Mapping):
            return f"node {_id(node_id)}: params is not a JSON object"
        parent = node.get("parent")
        if parent is not None and not isinstance(parent, str):
            return f"node {_id(node_id)}: parent {_id(parent)} is neither null nor an id"
        children = node.get("children", [])
        if not isinstance(children, list) or not all(isinstance(c, str) for c in children):
            return f"node {_id(node_id)}: children is not a list of ids"
        parent_of[node_id] = parent
        children_of[node_id] = children
    for node_id, parent in parent_of.items():
        if parent is not None and parent not in parent_of:
            return f"node {_id(node_id)} names parent {_id(parent)}, which is not a node"
    listed_by: dict[str, str] = {}
    for node_id, children in children_of.items():
        for child in children:
            if child not in parent_of:
                return f"node {_id(node_id)} lists child {_id(child)}, which is not a node"
            if listed_by.get(child) == node_id:
                return f"node {_id(node_id)} lists child {_id(child)} twice"
            if child in listed_by:
                return (
                    f"node {_id(node_id)} lists child {_id(child)}, which node"
                    f" {_id(listed_by[child])} lists already"
                )
            listed_by[child] = node_id
    roots = [node_id for node_id, parent in parent_of.items() if parent is None]
    if len(roots) != 1:
        return _roots_problem(roots)
    first = nodes[0]["id"]
    return (
        _cycle_problem(listed_by)
        or _cycle_problem(parent_of)
        or _agreement_problem(parent_of, listed_by)
        or (None if roots[0] == first else f"the root {_id(roots[0])} is not the first node")
    )


def _cycle_problem(up: Mapping[str, str | None]) -> str | None:
    """A node that is its own ancestor, going ``up`` (each node has at most one above
    it: its parent, or the node that lists it), in one pass over the nodes."""
    walk_of: dict[str, int] = {}  # node -> the walk that met it first
    for walk, start in enumerate(up):
        node: str | None = start
        while node is not None and node not in walk_of:
            walk_of[node] = walk
            node = up.get(node)
        if node is not None and walk_of[node] == walk:  # met again on this very walk
            return f"node {_id(node)} is its own ancestor"
    return None


def _agreement_problem(
    parent_of: Mapping[str, str | None], listed_by: Mapping[str, str]
) -> str | None:
    """A child listed by a node its parent field does not name, or a node whose
    parent does not list it."""
    for child, node_id in listed_by.items():
        parent = parent_of[child]
        if parent != node_id:
            named = "no parent" if parent is None else f"parent {_id(parent)}"
            return f"node {_id(node_id)} lists child {_id(child)}, whose parent field names {named}"
    for node_id, parent in parent_of.items():
        if parent is not None and node_id not in listed_by:
            return f"node {_id(node_id)} names parent {_id(parent)}, which does not list it"
    return None


def _roots_problem(roots: list[str]) -> str:
    """No root, or more than one."""
    if not roots:
        return "no root: every node names a parent"
    named = ", ".join(_id(r) for r in roots[:3]) + (", ..." if len(roots) > 3 else "")
    return f"more than one root: {len(roots)} nodes have no parent ({named})"


def _checked(pairs: Iterable[tuple[int, dict[str, Any]]], where: Path, tick: TickCheck) -> Pairs:
    last_tick = first_end = header = 0  # lines of the end record and the header
    for line, record in pairs:
        kind = record.get("type") if isinstance(record, dict) else None
        if kind == "header":
            if (problem := values.version_problem(record.get("version"))) is not None:
                raise LocatedError(problem, SourceLocation(str(where), line))
            tree = record.get("tree")
            if isinstance(tree, Mapping) and tree.get("nodes"):
                problem = tree_problem(tree)
                if problem is not None:
                    raise LocatedError(
                        f"bad tree in header: {problem}", SourceLocation(str(where), line)
                    )
            if header:  # a second run's, whole (as checked)
                raise LocatedError(values.stray_record("header"), SourceLocation(str(where), line))
            header = line
        elif kind == "tick":
            tick(record, line, where)
            problem = values.order_problem(record["n"], last_tick, first_end)  # n: whole
            if problem is not None:  # .mcap and bag exports wrote what no reader reads
                raise LocatedError(problem, SourceLocation(str(where), line))
            last_tick = record["n"]
        elif kind == "end":
            problem = end_problem(record) or values.end_values_problem(record, last_tick, first_end)
            if problem is not None:
                raise LocatedError(problem, SourceLocation(str(where), line))
            first_end = line
        elif header and kind is not None:  # as read_trace refuses it: the exports wrote
            # a bag of it (a .mcap export said "cannot convert", without the column)
            raise LocatedError(values.stray_record(kind), SourceLocation(str(where), line))
        yield line, record


def checked_iteration(raw: Callable[[_R], Pairs], tick: TickCheck) -> Callable[[_R], Pairs]:
    """A format reader's ``__iter__`` whose records are checked as they pass.

    A header's tree must pass :func:`tree_problem`, a tick record ``tick``; either
    failing is a :class:`~pirate_bt.errors.LocatedError` naming the file and line.
    :class:`~pirate_bt.trace.reader.TraceFormatReader` wraps its own ``__iter__``
    and every subclass's with it, so whatever iterates a reader gets only records
    that read back.
    """

    def __iter__(self: _R) -> Pairs:
        return _checked(raw(self), self.path, tick)

    __iter__.__doc__ = raw.__doc__
    __iter__.__unchecked__ = raw  # type: ignore[attr-defined]
    return __iter__


def unchecked(reader: Iterable[tuple[int, dict[str, Any]]]) -> Iterable[tuple[int, dict[str, Any]]]:
    """The records of ``reader`` without :func:`checked_iteration`'s checks, for a
    caller that makes the same checks itself (and so makes them once)."""
    raw = getattr(type(reader).__iter__, "__unchecked__", None)
    return raw(reader) if raw is not None else reader
