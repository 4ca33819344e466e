"""What a callable planner code hands in is, read before it is called.

Shared by the API's callback checks (:mod:`pirate_bt.api.observing`: ``observe=``,
``warn=``, a campaign's ``on_record``) and the navigators' method checks
(:mod:`pirate_bt.task.navigate_checks`: ``next_step``, ``check_map``), which sit in
layers that cannot import each other: an ``async def`` or a generator function, whose
body a call never runs, and a function of the wrong arity, which was a bare
``TypeError`` from inside once called, after work had been done.
"""

from __future__ import annotations

import inspect
from typing import Any

__all__ = ["never_runs", "uncallable_with"]


def never_runs(function: Any) -> str | None:
    """What ``function`` is when calling it runs none of its body: ``"an async def"``
    (a coroutine, never awaited) or ``"a generator function (it yields)"`` (a generator,
    never iterated: an ``observe`` with a ``yield`` in it attached no hook, the run went
    on unobserved and nothing said so); ``None`` for a plain function. A callable
    object is judged by its own ``__call__``."""
    try:
        call = None if inspect.isroutine(function) else inspect.getattr_static(function, "__call__")
    except AttributeError:
        call = None
    for each in (function, call):
        if inspect.iscoroutinefunction(each) or inspect.isasyncgenfunction(each):
            return "an async def"
        if inspect.isgeneratorfunction(each):
            return "a generator function (it yields)"
    return None


def uncallable_with(function: Any, count: int) -> inspect.Signature | None:
    """``function``'s signature when it cannot be called with ``count`` positional
    arguments (planner code's callback or method of the wrong arity, found before the
    run, not as a bare ``TypeError`` once it is called); ``None`` when it can, or when
    it has no signature to read (a builtin: called as it is)."""
    try:
        signature = inspect.signature(function)
    except Exception:  # a builtin without one, or its own __signature__ that raises
        return None
    try:
        signature.bind(*[None] * count)
    except TypeError:
        return signature
    return None
