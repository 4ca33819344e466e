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
  in its safe state, when known), else the deepest leaf that ended FAILURE. A
  failure in a selector's fallback gives way to the failure of the way the
  selector tried first (:func:`explaining_stamp`): a straight PAB's hold times out
  on a clamp, and its fallback, which asks whether the front half is over an
  opening, fails too (it is not), later; the clamp is the cause. A failure a
  selector recovered from (a later child of it succeeded: :func:`recovered`) explains
  nothing and is passed over: each of probe-tee's probes ends in a drive that fails
  after its whole probe, which is how a probe says "straight on"; when no side turned,
  the PAB's own reason (its safe state's) is the cause, not the last probe's drive.

The layers above (a run's result, a mission's per-PAB outcome) add what only
they know: an exception, the supervisor's own stop, a time limit, a map that
disagrees with the pipe.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import py_trees
from py_trees.common import Status

__all__ = [
    "FailureCause",
    "explaining_stamp",
    "failure_cause",
    "failures",
    "path_of",
    "recovered",
]


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


def _stamp(n: py_trees.behaviour.Behaviour) -> tuple[float, str] | None:
    """(clock time, reason) of a primitive's, a confirmation point's or a timeout's
    recorded failure (a :class:`~pirate_bt.behaviours.primitives.Confirm` keeps
    ``denied_at_s``, a :class:`~pirate_bt.behaviours.basic.Timeout` ``timed_out_at_s``;
    read by name, as :mod:`~pirate_bt.behaviours.primitives` imports this module)."""
    from pirate_bt.behaviours.primitive import Primitive

    if isinstance(n, Primitive):
        return (n.failed_at_s, n.failure_reason) if n.failed_at_s is not None else None
    denied = getattr(n, "denied_at_s", None)
    if isinstance(denied, float):
        return denied, n.feedback_message
    timed_out = getattr(n, "timed_out_at_s", None)  # a timeout decorator's
    if isinstance(timed_out, float):
        return timed_out, n.feedback_message
    return None


def failures(node: py_trees.behaviour.Behaviour) -> list[FailureCause]:
    """Every failure recorded under ``node`` (itself included), time-stamped ones first
    in time order, then leaves that ended FAILURE (deepest first)."""
    stamped: list[FailureCause] = []
    plain: list[FailureCause] = []
    for n in node.iterate():
        stamp = _stamp(n)
        if stamp is not None:
            stamped.append(FailureCause(path_of(n), stamp[1], stamp[0], _depth(n)))
        elif n.status == Status.FAILURE and _fails_itself(n):
            message = n.feedback_message or f"{n.name} failed"
            plain.append(FailureCause(path_of(n), message, None, _depth(n)))
    stamped.sort(key=lambda c: c.time_s if c.time_s is not None else 0.0)
    plain.sort(key=lambda c: -c.depth)
    return [*stamped, *plain]


def _fails_itself(n: py_trees.behaviour.Behaviour) -> bool:
    """A leaf, or a decorator that failed while its child did not (a guard whose
    condition no longer held, a timeout, a status converter): the failure is its own."""
    if not n.children:
        return True
    return isinstance(n, py_trees.decorators.Decorator) and n.decorated.status != Status.FAILURE


def recovered(n: py_trees.behaviour.Behaviour, root: py_trees.behaviour.Behaviour) -> bool:
    """Did a selector at or under ``root`` recover from ``n``'s failure? One above
    ``n`` that ended SUCCESS through a later child than the one ``n`` is under (its
    fallback succeeded). Statuses as they are now: a selector ticked again since,
    running or failed, has recovered from nothing yet."""
    child = n
    while child is not root and child.parent is not None:
        parent = child.parent
        if isinstance(parent, py_trees.composites.Selector) and parent.status == Status.SUCCESS:
            current = parent.current_child
            children = parent.children
            if current in children and children.index(current) > children.index(child):
                return True
        child = parent
    return False


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
        The latest time-stamped failure (within ``before_s``; a selector's first way
        rather than its fallback, see :func:`explaining_stamp`), else the deepest leaf
        that ended FAILURE; failures a selector recovered from are passed over
        (:func:`recovered`).
    """
    found = explaining_stamp(node, before_s=before_s)
    if found is not None:
        time_s, n, reason = found
        return FailureCause(path_of(n), reason, time_s, _depth(n))
    plain = [
        FailureCause(path_of(n), n.feedback_message or f"{n.name} failed", None, _depth(n))
        for n in node.iterate()
        if _stamp(n) is None
        and n.status == Status.FAILURE
        and _fails_itself(n)
        and not recovered(n, node)
    ]
    plain.sort(key=lambda c: -c.depth)
    return plain[0] if plain else None


_Stamped = tuple[float, py_trees.behaviour.Behaviour, str]


def explaining_stamp(
    node: py_trees.behaviour.Behaviour, *, before_s: float | None = None
) -> _Stamped | None:
    """The time-stamped failure under ``node`` that explains its end: ``(time, node,
    reason)``, or ``None`` when none is recorded (within ``before_s``).

    The latest one not recovered from (:func:`recovered`), unless it lies in a
    selector's fallback (a child after the
    first) and the failure before it (the latest one recorded up to the moment the
    failed node started) lies under a child the selector tried before: then that one,
    and so on up the tree. The fallback was tried *because* that child failed; its
    own failure comes later and says less. (Statuses cannot tell this: a selector
    with memory resets the children before the one it resumes to INVALID.)
    """
    stamped: list[_Stamped] = []
    for n in node.iterate():
        stamp = _stamp(n)
        if stamp is None or (before_s is not None and stamp[0] > before_s + 1e-9):
            continue
        if not recovered(n, node):
            stamped.append((stamp[0], n, stamp[1]))
    if not stamped:
        return None
    stamped.sort(key=lambda s: s[0])  # stable: the last of equal times stays last
    chosen = stamped[-1]
    while True:
        earlier = _tried_before(node, chosen, stamped)
        if earlier is None:
            return chosen
        chosen = earlier


def _tried_before(
    root: py_trees.behaviour.Behaviour, chosen: _Stamped, stamped: list[_Stamped]
) -> _Stamped | None:
    """The failure that led a selector above ``chosen`` to the fallback ``chosen`` is in."""
    from pirate_bt.behaviours.primitive import Primitive

    node = chosen[1]
    started = node._start_s if isinstance(node, Primitive) else chosen[0]
    before = [s for s in stamped if s[1] is not node and s[0] <= started + 1e-9]
    if not before or math.isnan(started):
        return None
    previous = before[-1]
    child = node
    while child is not root and child.parent is not None:
        parent = child.parent
        if isinstance(parent, py_trees.composites.Selector):
            tried = parent.children[: parent.children.index(child)]
            if any(_under(previous[1], sibling) for sibling in tried):
                return previous
        child = parent
    return None


def _under(n: py_trees.behaviour.Behaviour, top: py_trees.behaviour.Behaviour) -> bool:
    current: py_trees.behaviour.Behaviour | None = n
    while current is not None:
        if current is top:
            return True
        current = current.parent
    return False
