"""py_trees behaviours for PIRATE: the node contract, generic leaves, guards and primitives.

:mod:`pirate_bt.behaviours.base` defines the contract every node type follows so
that YAML trees (through the registry of :mod:`pirate_bt.treefile.registry`) and
planner code build the same behaviours. :mod:`pirate_bt.behaviours.basic` holds
generic leaves and decorators that need no robot.
"""

from pirate_bt.behaviours.base import (
    ALL_OUTCOMES,
    BuildContext,
    GuardDecorator,
    Leaf,
    NodeKind,
    NodeMixin,
    NodeParams,
    NoParams,
    Outcome,
)

__all__ = [
    "ALL_OUTCOMES",
    "BuildContext",
    "GuardDecorator",
    "Leaf",
    "NoParams",
    "NodeKind",
    "NodeMixin",
    "NodeParams",
    "Outcome",
]
