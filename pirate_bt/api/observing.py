"""Planner code around a run: an ``observe=`` callback attached to its runner.

(A Ctrl-C a node's ``terminate()`` raises as the run ends is the runner's to make safe:
:meth:`pirate_bt.runner.Runner.run` puts the robot in its safe state before it goes on.)
"""

from __future__ import annotations

import inspect
from typing import Any

from pirate_bt.api.options import callback
from pirate_bt.errors import InputError
from pirate_bt.trace.attach import call_observer

__all__ = ["call_observer", "check_observer"]


def check_observer(observe: Any, shape: str = "observe(runner, connection)") -> None:
    """``observe`` is ``None`` or a function ``shape`` can call: two positional
    arguments, not an ``async def`` (called, never awaited, its hooks never attached).

    Raises:
        InputError: one line naming ``observe``, what it takes and how it is called.
    """
    callback(observe, "observe")
    if observe is None:
        return
    name = getattr(observe, "__qualname__", None) or type(observe).__name__
    name = name.rsplit(".", 1)[-1][:60]
    # a callable object's own __call__ (an async one never runs either)
    call = None if inspect.isroutine(observe) else inspect.getattr_static(observe, "__call__")
    if inspect.iscoroutinefunction(observe) or inspect.iscoroutinefunction(call):
        raise InputError(
            f"observe: {name} is an async def, which {shape} would never run (its hooks"
            " never attached); give a plain function"
        )
    try:
        signature = inspect.signature(observe)
    except (TypeError, ValueError):  # a builtin without one: called as it is
        return
    try:
        signature.bind(None, None)
    except TypeError:
        raise InputError(
            f"observe: {name}{signature} cannot be called as {shape}, before the run to"
            " attach hooks; give a function of two arguments"[:300]
        ) from None
