"""What a tree file becomes: node specs, blackboard declarations, the loaded tree.

The data the reader (:mod:`pirate_bt.treefile.reader`) produces and the loader
(:mod:`pirate_bt.treefile.loader`) builds from, plus the keys each part of a
tree file allows.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import py_trees
from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from pirate_bt.behaviours.base import NodeMixin
from pirate_bt.errors import LocatedError, SourceLocation, UnitError, shown
from pirate_bt.treefile.params import SI_UNITS
from pirate_bt.units import parse_quantity
from pirate_bt.yamlvalidate import close_matches

__all__ = [
    "BLACKBOARD_TYPES",
    "COMPOSITES",
    "MAX_TREE_DEPTH",
    "MAX_TREE_NODES",
    "BlackboardDecl",
    "LoadedTree",
    "NodeSpec",
    "PathKey",
]

PathKey = tuple[str | int, ...]

COMPOSITES: Final = ("sequence", "selector", "parallel")
MAX_TREE_DEPTH: Final = 100
"""The deepest nesting of nodes, subtrees included (a real tree is a dozen deep);
deeper trees would meet Python's recursion limit when they are built or ticked."""
MAX_TREE_NODES: Final = 100_000
"""The most nodes a tree may expand to, subtrees included (a subtree used twice
by a subtree used twice ... doubles at each level)."""
_COMMON_KEYS: Final = frozenset({"type", "name", "description"})
_STRUCT_KEYS: Final[dict[str, frozenset[str]]] = {
    "sequence": frozenset({"memory", "children"}),
    "selector": frozenset({"memory", "children"}),
    "parallel": frozenset({"policy", "synchronise", "selected", "children"}),
    "eternal_guard": frozenset({"conditions", "child"}),
    "subtree": frozenset({"ref", "params"}),
}
_TOP_KEYS: Final = frozenset({"name", "description", "params", "blackboard", "root", "subtrees"})
_SUBTREE_KEYS: Final = frozenset({"description", "params", "root"})
BLACKBOARD_TYPES: Final = ("any", *SI_UNITS, "number", "integer", "boolean", "string")
"""The types a blackboard key is declared with: ``any`` (the default), a quantity's
(as a parameter's: ``length``, ``duration``, ...) or a plain one."""


class BlackboardDecl(BaseModel):
    """A blackboard key a tree file uses."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    type: str = Field(
        "any", description="informative type (boolean, number, integer, string, angle, ...)"
    )
    default: Any = Field(None, description="value written before the first tick")
    external: bool = Field(False, description="written by planner code, not by the tree")
    description: str = ""

    @field_validator("type")
    @classmethod
    def _known(cls, value: str) -> str:
        """A type that exists: ``type: nope`` (or ``lenght``) was taken until 2026-12-01,
        and its key's default and comparisons went unchecked."""
        if value not in BLACKBOARD_TYPES:
            close = close_matches(value, BLACKBOARD_TYPES, n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(
                f"type: {shown(value)} is not a blackboard type (one of"
                f" {', '.join(BLACKBOARD_TYPES)}){hint}"
            )
        return value

    @field_validator("default")
    @classmethod
    def _checked(cls, value: Any, info: ValidationInfo) -> Any:
        """A number in the default is finite (NaN: every comparison with it is false);
        the default of a quantity (``type: length``) is its SI value, as nodes write and
        compare quantities: ``default: 1 m`` is 1.0 (it was the text '1 m'); a bare
        number is SI, as it always was here (and as the XML export writes it)."""
        _finite(value)
        kind = info.data.get("type")
        wanted = _PLAIN_KINDS.get(str(kind))
        if wanted is not None and value is not None and not wanted[0](value):
            # a boolean key holding 'maybe' never equals true, nor '5' the number 5
            hint = "; a default takes no $parameter" if str(value).startswith("$") else ""
            raise ValueError(
                f"default: {shown(value)} is not {wanted[1]} (the key is {kind}){hint}"
            )
        if kind in SI_UNITS and value is not None:
            try:
                return parse_quantity(value, SI_UNITS[kind][0], require_unit=False)
            except UnitError as exc:
                raise ValueError(f"default: {exc}") from None
        return value


_PLAIN_KINDS: dict[str, tuple[Callable[[Any], bool], str]] = {
    "boolean": (lambda v: isinstance(v, bool), "true or false"),
    "integer": (lambda v: isinstance(v, int) and not isinstance(v, bool), "a whole number"),
    "number": (lambda v: isinstance(v, int | float) and not isinstance(v, bool), "a number"),
    "string": (lambda v: isinstance(v, str), "text"),
}
"""What a blackboard default of a plain type must be, and that in words."""


def _finite(value: Any) -> None:
    """Refuse a NaN or an infinity anywhere in ``value``."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, float) and not math.isfinite(item):
            raise ValueError(f"a number in the default must be finite, not {item}")
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, list | tuple):
            stack.extend(item)


@dataclass
class NodeSpec:
    """A validated node, before it is built.

    Attributes:
        node_type: The node type (``sequence``, ``wait``, ...).
        name: The node's name (unique among its siblings).
        location: Where the node is written.
        cls: The registered class (``None`` for structural nodes).
        params: Validated parameters (registered nodes) or structural options.
        children: Child specs (composites, decorators, guards).
        conditions: Guard conditions of an ``eternal_guard``.
        explicit_name: The name was written in the file.
        called_at: For the root of an included subtree, where the ``subtree`` node
            that included it is written (the outermost call, when a subtree's root
            is itself a call); ``None`` for any other node. Problems among its
            siblings (a duplicate name) are the caller's and are reported there.
    """

    node_type: str
    name: str
    location: SourceLocation
    cls: type[NodeMixin] | None = None
    params: Any = None
    children: list[NodeSpec] = field(default_factory=list)
    conditions: list[NodeSpec] = field(default_factory=list)
    explicit_name: bool = False
    called_at: SourceLocation | None = None

    def walk(self) -> Iterator[NodeSpec]:
        """This spec and all below it, depth first."""
        stack = [self]
        while stack:  # not recursive: nested generators cost O(depth) per node
            spec = stack.pop()
            yield spec
            stack.extend(reversed((*spec.conditions, *spec.children)))


@dataclass
class LoadedTree:
    """A tree loaded from YAML (or a dict) and built.

    Attributes:
        name: The tree's name.
        root: The root behaviour.
        spec: The validated spec tree (for drawing and analysis).
        params: The resolved top-level parameters (substituted values).
        blackboard: Declared blackboard keys of every file used.
        warnings: Located warnings (children that can never run, ...).
        files: Every file read, the tree file first.
        needs_robot: Some node talks to the robot.
        source: What it was loaded from: the tree file's path, or the mapping
            (``None`` for a tree put together otherwise). The Groot2 server exports
            it again to show the tree with its subtrees.
    """

    name: str
    root: py_trees.behaviour.Behaviour
    spec: NodeSpec
    params: dict[str, Any]
    blackboard: dict[str, BlackboardDecl]
    warnings: list[LocatedError]
    files: list[str]
    needs_robot: bool
    source: Path | Mapping[str, Any] | None = field(default=None, repr=False)

    def blackboard_defaults(self) -> dict[str, Any]:
        """Declared keys with a default value."""
        return {k: d.default for k, d in self.blackboard.items() if d.default is not None}

    def write_blackboard_defaults(self) -> None:
        """Write every declared default to the py_trees blackboard."""
        for key, value in self.blackboard_defaults().items():
            py_trees.blackboard.Blackboard.set(f"/{key}", value)

    def behaviour_tree(self) -> py_trees.trees.BehaviourTree:
        """A fresh ``py_trees.trees.BehaviourTree`` over :attr:`root`."""
        return py_trees.trees.BehaviourTree(self.root)
