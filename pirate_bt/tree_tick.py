"""One tick of a tree, and what the runner reads of one: node paths, the behaviour an
exception came from, and what halts a supervised run (split out of
:mod:`pirate_bt.runner`, the tick loop, which re-exports every name here).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from typing import Any

import py_trees
from py_trees.common import Status

from pirate_bt.behaviours.cause import path_of as node_path

__all__ = ["culprit", "exhaust", "halted_by", "link_lost_note", "node_path", "tick_tree"]


def link_lost_note(supervisor: Any) -> str | None:
    """What is true of a robot whose link is lost at the end of a run, or ``None`` while
    the link is up (``supervisor.health().connected``): a run's ``rest_unknown``."""
    if supervisor.health().connected:
        return None
    return (
        "the link is lost: the robot's state at the end of the run is unknown"
        " (the bridge's watchdog stops its motors)"
    )


def halted_by(supervisor: Any, root: py_trees.behaviour.Behaviour | None = None) -> str | None:
    """A runner's ``halted``: ``supervisor.run_halted``, or a step of ``root`` waiting in
    supervised mode for a confirmation no attached operator input could give (the run
    waited out its time limit, 600 s by default, in wall time on a robot)."""
    halt: str | None = supervisor.run_halted
    # every tick: the mode first (a property read), the inputs only in supervised mode
    if halt is not None or supervisor.mode != "supervised" or supervisor.operator_attached:
        return halt
    pending = supervisor.pending_confirmations()
    if not pending:
        return None
    waiting = f"waiting for the operator to confirm {pending[0]!r}"  # the node's feedback
    nodes = [] if root is None else list(root.iterate())
    who = [n for n in nodes if n.status == Status.RUNNING and n.feedback_message == waiting]
    return (
        f"{node_path(who[0]) if who else 'the tree'} waits for an operator to confirm"
        f" {pending[0]!r} (supervised mode), and no operator input is attached: attach"
        " one (supervisor.add_input) or run in autonomous mode"
    )


def tick_tree(tree: py_trees.trees.BehaviourTree) -> None:
    """Tick ``tree`` once, as ``BehaviourTree.tick()`` does, at the cost of what runs.

    py_trees' ``BehaviourTree.tick()`` runs the tree's pre-tick handlers, initialises
    its visitors, ticks the root (showing every ticked node to the visitors that are
    not ``full``), then walks *every* node of the tree for the ``full`` visitors,
    finalises the visitors, runs the post-tick handlers and counts the tick. The
    walk happens even when no visitor is ``full``, so a tick costs the size of the
    tree, not the nodes that ran. This does the same steps through the same public
    attributes (``pre_tick_handlers``, ``visitors``, ``post_tick_handlers``,
    ``count``) and walks the whole tree only when a ``full`` visitor asks for it:
    a user's visitors and handlers see exactly what ``BehaviourTree.tick()``
    would show them. When the tree's one visitor is not ``full`` and has a
    ``collects`` list (the trace's :class:`~pirate_bt.trace.nodes.TickedNodes`, on a
    tree none of whose nodes overrides ``visit``), its visit of a node is appending
    the node to that list, which is done in C as the tick yields each node.
    """
    for handler in tree.pre_tick_handlers:
        handler(tree)
    visitors = tree.visitors
    for visitor in visitors:
        visitor.initialise()
    root = tree.root
    if not visitors:
        exhaust(root.tick())
        collects = None
    elif len(visitors) == 1 and not visitors[0].full:
        collects = getattr(visitors[0], "collects", None)
    else:
        collects = None
    if collects is not None:
        # A visitor (the trace's) whose visit of a ticked node is, by its word, appending
        # the node to this list: the list gathers the nodes as the tick yields them, in C.
        collects.extend(root.tick())
    elif visitors:
        # BehaviourTree.tick() picks the visitors that are not full once per node; once
        # per tick is the same unless a node edits the tree's visitors mid-tick.
        partial = [v for v in visitors if not v.full]
        for node in root.tick():
            for visitor in partial:
                node.visit(visitor)
        full = [v for v in visitors if v.full]
        if full:
            for node in root.iterate():
                for visitor in full:
                    node.visit(visitor)
    for visitor in visitors:
        visitor.finalise()
    for handler in tree.post_tick_handlers:
        handler(tree)
    tree.count += 1


def exhaust(iterator: Iterator[Any]) -> None:
    """Run a generator to its end in C (``collections.deque`` with no room)."""
    deque(iterator, maxlen=0)


def culprit(exc: BaseException, root: py_trees.behaviour.Behaviour) -> str | None:
    """The deepest behaviour of this tree whose method is on the traceback."""
    members = {id(n) for n in root.iterate()}
    found: py_trees.behaviour.Behaviour | None = None
    tb = exc.__traceback__
    while tb is not None:
        candidate = tb.tb_frame.f_locals.get("self")
        if isinstance(candidate, py_trees.behaviour.Behaviour) and id(candidate) in members:
            found = candidate
        tb = tb.tb_next
    return node_path(found) if found is not None else None
