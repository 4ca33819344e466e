"""Behaviours written outside pirate_bt and py_trees, held to what a run promises.

A run ticks whatever ``py_trees`` behaviour a planner gives it. py_trees itself lets a
planner's own class break a run in ways that name nothing:

- ``update()`` returning something that is no ``Status`` (``None`` from a missing
  ``return``, ``"SUCCESS"``, ``True``): py_trees logs an error on every tick and sets the
  node INVALID, and the run went on to its time limit, its why naming neither the node
  nor what it returned;
- a method raising what is no ``Exception`` (``SystemExit`` from ``sys.exit()``,
  ``GeneratorExit``, a bare ``BaseException``): it went past the runner, which then
  stopped a run for an ``Exception`` only, and out of ``simulate_tree`` with the robot
  still driving and the trace empty (the runner holds them itself now, for every
  ``Runner``; here they are also named by the method that raised them);
- ``StopIteration`` (``next()`` on an empty iterator): the parent's tick generator
  turned it into *RuntimeError: generator raised StopIteration*, naming the parent or
  nothing;
- a ``tick()`` of its own setting a status that is no ``Status``: the trace's coverage
  failed on it (*KeyError: 'WEIRD'*), naming nothing.

:func:`hold_to_contract` wraps such a node's ``setup``, ``initialise``, ``update``, ``terminate``
(and an overridden ``tick``) on the instance so that each of these raises an ordinary
exception naming the method and what it did; the runner then ends the run as for any
behaviour that raises (the node's path in ``failing_node`` and the why, the robot left in
its safe state, the trace complete). ``KeyboardInterrupt`` passes unchanged (a Ctrl-C).
pirate_bt's own nodes and py_trees' are left as they are: their ticks cost nothing more.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from typing import Any

import py_trees
from py_trees.common import Status

__all__ = [
    "WHY_LIMIT",
    "BehaviourBroke",
    "as_text",
    "blocked_ticks",
    "contain_handlers",
    "contain_hooks",
    "contained",
    "hold_to_contract",
    "let_go",
    "one_line",
]

_STATUSES = frozenset(Status)
_OWN = ("pirate_bt.", "py_trees.")
_MARK = "_pirate_bt_held"
_TICKS = {
    py_trees.behaviour.Behaviour.tick,
    py_trees.composites.Composite.tick,
    py_trees.composites.Sequence.tick,
    py_trees.composites.Selector.tick,
    py_trees.composites.Parallel.tick,
    py_trees.decorators.Decorator.tick,
}


class BehaviourBroke(RuntimeError):
    """A planner's behaviour did what no behaviour may (see the module's text)."""


def _foreign(node: py_trees.behaviour.Behaviour) -> bool:
    module = type(node).__module__ or ""
    return not module.startswith(_OWN)


def _what(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _escaped(what: str, exc: BaseException) -> BehaviourBroke:
    text = _said(exc)
    said = f": {text}" if text else ""
    if text is None:
        hint = "whose str() raised: it cannot say what went wrong"
    elif isinstance(exc, StopIteration | StopAsyncIteration):
        hint = "an iterator ran out; catch StopIteration where it is called"
    else:
        hint = "to end a run, raise an Exception or return Status.FAILURE"
    return BehaviourBroke(f"{what} raised {type(exc).__name__}{said} ({hint})")


def _said(exc: BaseException) -> str | None:
    """``str(exc)``, or ``None`` when the exception's own ``__str__`` raises."""
    try:
        return str(exc)
    except Exception:
        return None


def _passes(exc: BaseException) -> bool:
    """True for what goes on as raised: a Ctrl-C, and every Exception but StopIteration
    that can be said (the runner's message is ``f"{exc}"``: one whose ``__str__`` raised
    went out of the runner, the robot driving)."""
    if isinstance(exc, KeyboardInterrupt):
        return True
    if not isinstance(exc, Exception) or isinstance(exc, StopIteration | StopAsyncIteration):
        return False
    return _said(exc) is not None


def _checked(
    what: str, call: Callable[..., Any], returns_status: bool, node: object = None
) -> Callable[..., Any]:
    @functools.wraps(call)
    def checked(*args: Any, **kwargs: Any) -> Any:
        self = node  # noqa: F841 - the runner names the deepest behaviour called ``self``
        try:
            value = call(*args, **kwargs)
        except BaseException as exc:
            if _passes(exc):
                raise
            raise _escaped(what, exc) from exc
        if returns_status and value not in _STATUSES:
            raise BehaviourBroke(
                f"{what} returned {_what(value)}, not a py_trees Status"
                " (Status.RUNNING, Status.SUCCESS or Status.FAILURE)"
            )
        return value

    return checked


def contained(what: str, call: Callable[..., Any]) -> Callable[..., Any]:
    """``call`` (a planner's hook, say) raising an ordinary exception for what no code
    run by a tick may raise (``SystemExit``, ``GeneratorExit``, ``StopIteration``...),
    named ``what`` (*a post-tick hook raised SystemExit: ...*)."""
    if getattr(call, _MARK, False):
        return call
    checked = _checked(what, call, False)
    setattr(checked, _MARK, True)
    return checked


def _checked_tick(node: py_trees.behaviour.Behaviour) -> Callable[[], Iterator[Any]]:
    tick = node.tick

    @functools.wraps(tick)
    def checked_tick() -> Iterator[Any]:
        self = node  # the runner names the deepest behaviour called ``self`` on a traceback
        try:
            yield from tick()
        except BaseException as exc:
            if _passes(exc) or isinstance(exc, GeneratorExit):  # closed: not its doing
                raise
            raise _escaped("tick()", exc) from exc
        if self.status not in _STATUSES:
            left = self.status
            self.status = Status.INVALID  # what the trace and the runner's stop can read
            raise BehaviourBroke(f"tick() left its status {_what(left)}, not a py_trees Status")

    return checked_tick


_HELD = ("setup", "initialise", "update", "terminate", "tick")


def hold_to_contract(root: py_trees.behaviour.Behaviour) -> None:
    """Wrap every node under ``root`` whose class is a planner's own (idempotent);
    :func:`let_go` undoes it."""
    for node in root.iterate():
        if not _foreign(node) or _MARK in vars(node):
            continue
        attrs = vars(node)
        kept = {name: attrs[name] for name in _HELD if name in attrs}
        attrs["setup"] = _checked("setup()", node.setup, False, node)
        attrs["initialise"] = _checked("initialise()", node.initialise, False, node)
        attrs["update"] = _checked("update()", node.update, True, node)
        attrs["terminate"] = _checked("terminate()", node.terminate, False, node)
        if type(node).tick not in _TICKS:
            attrs["tick"] = _checked_tick(node)
        attrs[_MARK] = kept


def let_go(root: py_trees.behaviour.Behaviour) -> None:
    """Undo :func:`hold_to_contract` at the end of a run: the planner's nodes as they
    were (a copy made of them later calls its own methods, not the wrappers' nodes)."""
    for node in root.iterate():
        attrs = vars(node)
        kept = attrs.pop(_MARK, None)
        if kept is None:
            continue
        for name in _HELD:
            attrs.pop(name, None)
        attrs.update(kept)


def contain_hooks(runner: Any) -> None:
    """Every hook of ``runner`` (a :class:`~pirate_bt.runner.Runner`) :func:`contained`:
    a planner's hooks (``simulate_tree(observe=...)``) that raise ``SystemExit`` and the
    like end the run named as hooks (*a post-tick hook raised SystemExit: ...*). The
    runner holds such an end too, the robot left safe and the trace written, but
    without saying where it came from: a hook is no node of the tree."""
    runner.pre_tick[:] = [contained("a pre-tick hook", h) for h in runner.pre_tick]
    runner.post_tick[:] = [contained("a post-tick hook", h) for h in runner.post_tick]
    runner.finish[:] = [contained("a finish hook", h) for h in runner.finish]


WHY_LIMIT = 1000
"""The most characters of a run's why: a planner's feedback message or node name can be
any text (100 kB, several lines); the why stays one line a terminal can print."""


def as_text(value: Any) -> str:
    """``value`` (a why made of a planner's feedback message: ``42``, an object) as text."""
    if isinstance(value, str):
        return value
    try:
        return str(value)
    except Exception as exc:  # a planner's feedback object whose __str__ raises
        return f"<{type(value).__name__}: its str() raised {type(exc).__name__}>"


def one_line(text: Any, limit: int = WHY_LIMIT) -> str:
    """``text`` as one printable line of at most about ``limit`` characters: line breaks
    and other control characters escaped (``\\n``), text that is no UTF-8 (a lone
    surrogate) escaped, the middle of a longer one left out (saying how much). Not text (a feedback
    message of ``42``): its ``str``."""
    said = as_text(text)
    if said.isprintable() and len(said) <= limit:
        return said  # the usual why, as it was
    flat = "".join(c if c.isprintable() else repr(c)[1:-1] for c in said)
    flat = flat.encode("utf-8", "backslashreplace").decode("utf-8")
    if len(flat) > limit:  # the middle left out: a long node name comes before its cause
        half = limit // 2
        flat = f"{flat[:half]}...({len(flat) - 2 * half} characters)...{flat[-half:]}"
    return flat


def contain_handlers(tree: py_trees.trees.BehaviourTree) -> None:
    """A planner's ``BehaviourTree`` handed to a run: its pre- and post-tick handlers
    :func:`contained` (one that called ``sys.exit()`` went out of the run with the robot
    driving), as :func:`contain_hooks` does for a runner's hooks."""
    tree.pre_tick_handlers[:] = [
        contained("a pre-tick handler of the tree", h) for h in tree.pre_tick_handlers
    ]
    tree.post_tick_handlers[:] = [
        contained("a post-tick handler of the tree", h) for h in tree.post_tick_handlers
    ]


BLOCKED_TICK_S = 1.0
"""A tick longer than this (wall time) is named in the run's why."""


def blocked_ticks(loop: Any) -> str:
    """For a run (the runner's result) one of whose ticks took longer than
    :data:`BLOCKED_TICK_S`, a clause saying so (``""`` otherwise): a behaviour that
    sleeps or waits in its ``update`` holds the whole tick, the supervisor's checks with
    it, and on a robot the drives keep their setpoints meanwhile."""
    longest = float(getattr(loop, "max_tick_s", 0.0))
    if longest <= BLOCKED_TICK_S:
        return ""
    ticks = [o for o in getattr(loop, "overruns", ()) if o.duration_s > BLOCKED_TICK_S]
    count = max(len(ticks), 1)
    first = f" (the first, tick {ticks[0].tick})" if ticks else ""
    many = f"{count} ticks" if count > 1 else "a tick"
    return (
        f"; {many} took more than {BLOCKED_TICK_S:g} s{first}, the longest {longest:.1f} s:"
        " a behaviour held the tree, and nothing was checked meanwhile (on a robot the"
        " drives keep their setpoints)"
    )
