"""Why a tree failed: the deepest cause a behaviour recorded, and where.

A tree that fails says little at its root (``tree failed after 127 ticks``): the
reason lives in the leaf that failed first - a primitive's ``stall: bend_3_drive
draws 1.50 A ...``, an operator's denial, a guard that no longer holds. These
functions read it back from a tree after (or during) a run, without the tree
having to cooperate:

- :func:`failures` lists every recorded failure under a node with its clock
  time, node path and reason (primitives and confirmation points keep theirs
  with a time stamp; other leaves that ended FAILURE give their feedback);
- :func:`failure_cause` picks the one that explains the end: the latest
  time-stamped failure at or before ``before_s`` (the moment the robot was put
  in its safe state, when known), else the deepest leaf that ended FAILURE.

The layers above (a run's result, a mission's per-PAB outcome) add what only
they know: an exception, the supervisor's own stop, a time limit, a map that
disagrees with the pipe.
"""

from __future__ import annotations

from dataclasses import dataclass

import py_trees
from py_trees.common import Status

__all__ = ["FailureCause", "failure_cause", "failures", "path_of"]


@dataclass(frozen=True, slots=True)
class FailureCause:
    """One recorded failure.

    Attributes:
        node: The node's path from the root (``bend/pass bend/front into turn``).
        reason: What it said, for people (``stall: bend_3_drive draws 1.50 A ...``).
        time_s: Clock time it failed (``None`` when the node keeps no time stamp).
        depth: How deep the node sits (the root is 0).
    """

    node: str
    reason: str
    time_s: float | None
    depth: int


def path_of(node: py_trees.behaviour.Behaviour) -> str:
    """The node's path from the root, names joined by ``/``."""
    names: list[str] = []
    current: py_trees.behaviour.Behaviour | None = node
    while current is not None:
        names.append(current.name)
        current = current.parent
    return "/".join(reversed(names))


def _depth(node: py_trees.behaviour.Behaviour) -> int:
    depth = 0
    while node.parent is not None:
        node = node.parent
        depth += 1
    return depth


def failures(node: py_trees.behaviour.Behaviour) -> list[FailureCause]:
    """Every failure recorded under ``node`` (itself included), time-stamped ones first
    in time order, then leaves that ended FAILURE (deepest first)."""
    from pirate_bt.behaviours.primitive import Primitive
    from pirate_bt.behaviours.primitives import Confirm

    stamped: list[FailureCause] = []
    plain: list[FailureCause] = []
    for n in node.iterate():
        if isinstance(n, Primitive) and n.failed_at_s is not None:
            stamped.append(FailureCause(path_of(n), n.failure_reason, n.failed_at_s, _depth(n)))
        elif isinstance(n, Confirm) and n.denied_at_s is not None:
            stamped.append(FailureCause(path_of(n), n.feedback_message, n.denied_at_s, _depth(n)))
        elif not n.children and n.status == Status.FAILURE:
            message = n.feedback_message or f"{n.name} failed"
            plain.append(FailureCause(path_of(n), message, None, _depth(n)))
    stamped.sort(key=lambda c: c.time_s if c.time_s is not None else 0.0)
    plain.sort(key=lambda c: -c.depth)
    return [*stamped, *plain]


def failure_cause(
    node: py_trees.behaviour.Behaviour, *, before_s: float | None = None
) -> FailureCause | None:
    """The failure that explains why ``node`` failed, or ``None`` if none was recorded.

    Args:
        node: The root of the (sub)tree.
        before_s: Only time-stamped failures at or before this clock time count (the
            moment the robot entered its safe state: what failed after it failed
            *because* of it). ``None``: any time.

    Returns:
        The latest time-stamped failure (within ``before_s``), else the deepest leaf
        that ended FAILURE.
    """
    found = failures(node)
    stamped = [
        c
        for c in found
        if c.time_s is not None and (before_s is None or c.time_s <= before_s + 1e-9)
    ]
    if stamped:
        return stamped[-1]
    plain = [c for c in found if c.time_s is None]
    return plain[0] if plain else None
