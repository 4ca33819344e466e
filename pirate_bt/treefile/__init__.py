"""Behaviour trees as YAML files: format, registry, static checks, build to py_trees.

A tree file names node types from an allow-list (:mod:`.registry`), gives their
parameters in units, includes subtrees from the same or another file with
typed parameters, and declares the blackboard keys it uses. :func:`load_tree`
reads a file (or the same structure as a mapping, for planner code), reports
every problem at ``file:line:column``, and returns a :class:`LoadedTree` whose
``root`` is an ordinary ``py_trees`` behaviour. The format is in ``docs/trees.md``.

Planner code can also build trees directly from the same node classes::

    from pirate_bt.behaviours.basic import Wait, WaitParams
    wait = Wait.from_params("pause", WaitParams(duration=2.0), context)
"""

from pirate_bt.treefile.loader import (
    BlackboardDecl,
    LoadedTree,
    NodeSpec,
    build,
    load_tree,
    validate_tree_file,
)
from pirate_bt.treefile.registry import (
    BUILTIN_NODES,
    ENTRY_POINT_GROUP,
    Registry,
    UnknownNode,
    default_registry,
)
from pirate_bt.treefile.schema import tree_schema

__all__ = [
    "BUILTIN_NODES",
    "ENTRY_POINT_GROUP",
    "BlackboardDecl",
    "LoadedTree",
    "NodeSpec",
    "Registry",
    "UnknownNode",
    "build",
    "default_registry",
    "load_tree",
    "tree_schema",
    "validate_tree_file",
]
