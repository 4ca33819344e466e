"""The shape of a tree, with node ids that survive a restart.

py_trees gives every behaviour a fresh UUID each time a tree is built, so two
runs of the same tree file would not share a single id. A trace, a diagram and
a reader must agree on which node is which, so nodes are named here by their
*path*: the root is ``0``, its second child ``0.1``, that child's first child
``0.1.0``. The same tree file always yields the same ids, the ids are short
(they are repeated in every tick record), and a diagram drawn from a tree file
can be coloured from a trace of that tree.

Every node also gets a *kind*, which diagrams and text views style apart:

- ``composite``: sequences, selectors, parallels (children run in some order);
- ``decorator``: one child, changes its result (py_trees decorators);
- ``guard``: a decorator that protects its child (a timeout, a precondition
  watched while the child runs): a decorator whose class sets
  ``trace_kind = "guard"`` (or ``is_guard = True``), lives in
  ``pirate_bt.behaviours.guards``, or is a ``Timeout`` or ``EternalGuard``;
- ``leaf``: actions and conditions.

A behaviour class may set ``trace_kind`` to override the guess, expose its
parameters as a mapping or pydantic model in a ``parameters`` or ``params``
attribute (registered nodes keep their validated ``params``), and
set ``pab_step = True`` to mark itself as a PAB step for plots (otherwise the
children of the root are the steps).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import py_trees

from pirate_bt.trace.sink import nonfinite_text

__all__ = [
    "NODE_KINDS",
    "NodeInfo",
    "TreeStructure",
    "iter_with_ids",
    "jsonable",
    "node_kind",
    "node_parameters",
    "tree_structure",
]

NODE_KINDS = ("composite", "decorator", "guard", "leaf")

_GUARD_TYPE_NAMES = frozenset({"Timeout", "EternalGuard"})
_GUARD_MODULE = "pirate_bt.behaviours.guards"


@dataclass(frozen=True, slots=True)
class NodeInfo:
    """One node of a tree, as recorded in a trace header.

    Attributes:
        id: Path id (``0.1.2``), stable across builds of the same tree.
        name: The behaviour's name.
        type: The behaviour's class name (``Sequence``, ``Timeout``, ``Clamp``).
        kind: One of :data:`NODE_KINDS`.
        parent: The parent's id, or ``None`` for the root.
        children: The children's ids, in order.
        params: Parameters worth showing (JSON values).
        step: The node is explicitly marked as a PAB step.
    """

    id: str
    name: str
    type: str
    kind: str
    parent: str | None
    children: tuple[str, ...] = ()
    params: Mapping[str, Any] = field(default_factory=dict)
    step: bool = False

    @property
    def depth(self) -> int:
        """0 for the root, 1 for its children, and so on."""
        return self.id.count(".")

    def to_json(self) -> dict[str, Any]:
        """The node as a JSON object (the header's ``tree.nodes`` items)."""
        out: dict[str, Any] = {
            "id": self.id,
            "name": self.name,
            "type": self.type,
            "kind": self.kind,
            "parent": self.parent,
            "children": list(self.children),
        }
        if self.params:
            out["params"] = dict(self.params)
        if self.step:
            out["step"] = True
        return out

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> NodeInfo:
        """The inverse of :meth:`to_json`."""
        return cls(
            id=str(data["id"]),
            name=str(data["name"]),
            type=str(data.get("type", "")),
            kind=str(data.get("kind", "leaf")),
            parent=None if data.get("parent") is None else str(data["parent"]),
            children=tuple(str(c) for c in data.get("children", ())),
            params=dict(data.get("params", {})),
            step=bool(data.get("step", False)),
        )


@dataclass(frozen=True)
class TreeStructure:
    """A tree's nodes in depth-first order (root first), by path id.

    Attributes:
        name: The tree's name (the root's name unless given).
        nodes: Every node, depth first.
    """

    name: str
    nodes: tuple[NodeInfo, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_id", {n.id: n for n in self.nodes})

    @property
    def root(self) -> NodeInfo:
        return self.nodes[0]

    def node(self, node_id: str) -> NodeInfo:
        """The node with ``node_id`` (``KeyError`` if there is none)."""
        by_id: dict[str, NodeInfo] = self._by_id  # type: ignore[attr-defined]
        return by_id[node_id]

    def __contains__(self, node_id: object) -> bool:
        by_id: dict[str, NodeInfo] = self._by_id  # type: ignore[attr-defined]
        return node_id in by_id

    def __iter__(self) -> Iterator[NodeInfo]:
        return iter(self.nodes)

    def __len__(self) -> int:
        return len(self.nodes)

    def steps(self) -> list[NodeInfo]:
        """The PAB steps: nodes marked ``step``, else the root's children."""
        marked = [n for n in self.nodes if n.step]
        if marked:
            return marked
        return [self.node(c) for c in self.root.children]

    def to_json(self) -> dict[str, Any]:
        """The header's ``tree`` object."""
        return {"name": self.name, "nodes": [n.to_json() for n in self.nodes]}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> TreeStructure:
        """The inverse of :meth:`to_json`."""
        nodes = tuple(NodeInfo.from_json(n) for n in data["nodes"])
        if not nodes:
            raise ValueError("a tree has at least one node")
        return cls(name=str(data.get("name", nodes[0].name)), nodes=nodes)


def node_kind(behaviour: py_trees.behaviour.Behaviour) -> str:
    """The kind of ``behaviour``: one of :data:`NODE_KINDS`."""
    declared = getattr(behaviour, "trace_kind", None)
    if isinstance(declared, str) and declared in NODE_KINDS:
        return declared
    if isinstance(behaviour, py_trees.composites.Composite):
        return "composite"
    if isinstance(behaviour, py_trees.decorators.Decorator):
        cls = type(behaviour)
        if (
            getattr(behaviour, "is_guard", False) is True
            or cls.__name__ in _GUARD_TYPE_NAMES
            or cls.__module__.startswith(_GUARD_MODULE)
        ):
            return "guard"
        return "decorator"
    return "leaf"


def jsonable(value: Any) -> Any:
    """``value`` as plain JSON data; anything unusual becomes its ``repr``.

    Non-finite floats become the strings ``"nan"``, ``"inf"``, ``"-inf"``, since
    strict JSON has no spelling for them.
    """
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else nonfinite_text(value)
    if isinstance(value, Enum):
        return jsonable(value.value)
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        items = sorted(value, key=repr) if isinstance(value, set | frozenset) else value
        return [jsonable(v) for v in items]
    dump = getattr(value, "model_dump", None)
    if callable(dump):
        return jsonable(dump(mode="json"))
    return repr(value)


def recordable(value: Any) -> Any:
    """:func:`jsonable`, or a note saying why not: a planner's blackboard value that
    cannot be spelled (a list that holds itself, an object whose ``repr`` raises) is
    recorded as ``"<list: not recorded: RecursionError: ...>"``; before 2026-11-30 it
    ended the run on its first tick, naming neither the key nor the node."""
    try:
        return jsonable(value)
    except Exception as exc:  # what the planner's own __repr__ or model_dump raised
        said = str(exc)[:120]
        return f"<{type(value).__name__}: not recorded: {type(exc).__name__}: {said}>"


def node_parameters(behaviour: py_trees.behaviour.Behaviour) -> dict[str, Any]:
    """Parameters worth showing for ``behaviour`` (JSON values, possibly empty)."""
    for attribute in ("parameters", "params"):
        declared = getattr(behaviour, attribute, None)
        if declared is not None and not callable(declared):
            value = jsonable(declared)
            if isinstance(value, dict):
                return value
    params: dict[str, Any] = {}
    if isinstance(behaviour, py_trees.composites.Sequence | py_trees.composites.Selector):
        params["memory"] = behaviour.memory
    elif isinstance(behaviour, py_trees.composites.Parallel):
        params["policy"] = type(behaviour.policy).__name__
    elif isinstance(behaviour, py_trees.decorators.Timeout):
        params["duration_s"] = jsonable(behaviour.duration)
    elif isinstance(behaviour, py_trees.decorators.Retry):
        params["num_failures"] = behaviour.num_failures
    elif isinstance(behaviour, py_trees.decorators.Repeat):
        params["num_success"] = behaviour.num_success
    return params


def _root_of(tree: py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour) -> Any:
    return tree.root if isinstance(tree, py_trees.trees.BehaviourTree) else tree


def iter_with_ids(
    tree: py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour,
) -> Iterator[tuple[str, py_trees.behaviour.Behaviour]]:
    """Every behaviour of ``tree`` with its path id, depth first."""
    stack: list[tuple[str, py_trees.behaviour.Behaviour]] = [("0", _root_of(tree))]
    while stack:
        node_id, node = stack.pop()
        yield node_id, node
        children = list(node.children)
        for index in range(len(children) - 1, -1, -1):
            stack.append((f"{node_id}.{index}", children[index]))


def tree_structure(
    tree: py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour,
    name: str | None = None,
) -> TreeStructure:
    """The structure of a py_trees tree (or of the tree under a root behaviour).

    Args:
        tree: A ``BehaviourTree`` or its root behaviour.
        name: The tree's name; defaults to the root's name.
    """
    nodes: list[NodeInfo] = []
    for node_id, node in iter_with_ids(tree):
        parent = node_id.rpartition(".")[0] or None
        nodes.append(
            NodeInfo(
                id=node_id,
                name=str(node.name),
                type=type(node).__name__,
                kind=node_kind(node),
                parent=parent,
                children=tuple(f"{node_id}.{i}" for i in range(len(node.children))),
                params=node_parameters(node),
                step=getattr(node, "pab_step", False) is True,
            )
        )
    return TreeStructure(name=name or nodes[0].name, nodes=tuple(nodes))
