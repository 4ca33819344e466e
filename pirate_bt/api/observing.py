"""Planner code around a run: an ``observe=`` callback attached to its runner.

(A Ctrl-C a node's ``terminate()`` raises as the run ends is the runner's to make safe:
:meth:`pirate_bt.runner.Runner.run` puts the robot in its safe state before it goes on.)
"""

from __future__ import annotations

import inspect
from typing import Any

from pirate_bt.api.options import callback
from pirate_bt.callables import never_runs, uncallable_with
from pirate_bt.errors import ArgumentTypeError, InputError
from pirate_bt.trace.attach import call_observer

__all__ = [
    "attach_only",
    "call_observer",
    "check_callback",
    "check_observer",
    "never_runs",
    "uncallable_with",
]


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
    what = never_runs(observe)
    if what is not None:
        raise InputError(
            f"observe: {name} is {what}, which {shape} would never run (its hooks"
            " never attached); give a plain function"
        )
    signature = uncallable_with(observe, 2)
    if signature is not None:
        raise InputError(
            f"observe: {name}{signature} cannot be called as {shape}, before the run to"
            " attach hooks; give a function of two arguments"[:300]
        )


_COUNTS = {0: "no arguments", 1: "one argument", 2: "two arguments", 3: "three arguments"}


def check_callback(value: Any, option: str, shape: str, count: int) -> None:
    """``value`` is ``None`` or a plain function ``shape`` (``"warn(message)"``) can call
    with ``count`` positional arguments: not an ``async def`` (called, never awaited,
    it would never run), and not one of the wrong arity, which was a bare
    ``TypeError`` from inside once it was called, after work had been done.

    Raises:
        ArgumentTypeError: one line naming ``option``, what it takes and how it is called.
    """
    callback(value, option)
    if value is None:
        return
    name = getattr(value, "__qualname__", None) or type(value).__name__
    name = str(name).rsplit(".", 1)[-1][:60]
    what = never_runs(value)
    if what is not None:
        raise ArgumentTypeError(
            f"{option}: {name} is {what}, which {shape} would call and never run;"
            " give a plain function"
        )
    signature = uncallable_with(value, count)
    if signature is not None:
        signature = signature.replace(return_annotation=inspect.Signature.empty)
        raise ArgumentTypeError(
            f"{option}: {name}{signature} cannot be called as {shape}; give a function of"
            f" {_COUNTS.get(count, f'{count} arguments')}"[:300]
        )


def attach_only(observe: Any) -> Any:
    """``observe`` as the API calls it: to attach hooks to the runner it is given, which
    the API then runs. A ``runner.run()`` called from inside it is refused: it ran the
    whole tree while its hooks were attached, and the API then ran it again (a tree run
    twice, the first result lost; a mission's second run failing on a pipe already
    driven, *map disagreement*). ``None`` stays ``None``.

    Raises:
        InputError: (from ``runner.run()`` inside ``observe``) one line saying so.
    """
    if observe is None:
        return None

    def refuse(*_args: Any, **_kwargs: Any) -> Any:
        raise InputError(
            "observe: it called runner.run(); attach hooks only (runner.add_post_tick,"
            " add_finish, ...): the run starts once observe returns"
        )

    def attaching(runner: Any, other: Any) -> None:
        try:
            runner.run = refuse  # this runner's own, for the call only
        except AttributeError:  # a runner that takes no attribute: as it is
            observe(runner, other)
            return
        try:
            observe(runner, other)
        finally:
            if runner.__dict__.get("run") is refuse:
                del runner.run

    return attaching
