"""Nodes built without a robot, bound to a run's connection for that run only."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import py_trees

__all__ = ["unbinder"]


def unbinder(tree: Any) -> Callable[[Any], None]:
    """A finish hook that gives the nodes of ``tree`` built without a supervisor the
    contexts they have now, once the run that binds them to its connection has ended.

    Call before the run binds them. A tree built once without a robot (a
    ``load_tree(...).root``, its ``behaviour_tree()``) and run again was refused, *built
    with another connection's context()*: the first run had bound it for good, to a
    connection since closed.
    """
    from pirate_bt.behaviours.base import BuildContext

    if isinstance(tree, py_trees.trees.BehaviourTree):
        tree = tree.root
    unbound = []
    if isinstance(tree, py_trees.behaviour.Behaviour):  # else built afresh for each run
        for node in tree.iterate():
            context = getattr(node, "context", None)
            if isinstance(context, BuildContext) and context.supervisor is None:
                unbound.append((node, context))

    def unbind(_result: Any) -> None:
        for node, context in unbound:
            node.context = context  # type: ignore[attr-defined]

    return unbind
