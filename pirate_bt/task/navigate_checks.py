"""A navigator's own parts, read and called as planner code is: its methods read
(a property that raises is its own error, one located line), and its optional
``check_map(map)``, asked before anything connects (:func:`check_navigator_map`: what
:func:`~pirate_bt.api.navigation.navigate` and a campaign ask first).

Split from :mod:`pirate_bt.task.navigators`, which still offers both names.
"""

from __future__ import annotations

import inspect
import logging
from typing import Any

from pirate_bt.callables import never_runs, uncallable_with
from pirate_bt.errors import InputError, said_of
from pirate_bt.pipes import Network
from pirate_bt.task.navigate_planner import call_within, raised_at, raised_on_purpose

__all__ = [
    "REFUSAL_LIMIT",
    "check_navigator_map",
    "check_next_step_shape",
    "navigator_method",
    "shape_problem",
]

_log = logging.getLogger("pirate_bt.task.navigators")

REFUSAL_LIMIT = 600
"""A navigator's refusal (of its map, of its parameters), in characters: its middle is
left out past it."""


def navigator_method(navigator: object, method: str, name: str) -> Any:
    """``navigator``'s attribute ``method`` (``None`` when it has none), read as planner
    code is run: a property or ``__getattr__`` that raises is the navigator's own error,
    one located line, not a bare exception out of ``navigate()`` or a campaign.

    Raises:
        InputError: reading it raised (anything but ``AttributeError``).
    """
    try:
        return getattr(navigator, method, None)
    except (Exception, SystemExit) as exc:  # a sys.exit() there ended `navigate`, exit 0
        _log.debug("navigator %r: reading %s raised", name, method, exc_info=exc)
        where = raised_at(exc)
        raise InputError(
            f"navigator {name!r}: reading its {method} raised {type(exc).__name__}:"
            f" {said_of(exc)[:200]}" + (f" (at {where})" if where else "")
        ) from None


def check_navigator_map(
    navigator: Any, name: str, network: Network | None, deadline_s: float | None = None
) -> None:
    """A navigator's own check of the map it will be given (its optional
    ``check_map(map)``), as bad input, before anything connects: what
    :func:`~pirate_bt.api.navigation.navigate` and a campaign ask first.

    With ``deadline_s`` the check runs on a thread of its own and may take that much
    wall time, as a decision may (``navigate``'s ``deadline``).

    Raises:
        InputError: the navigator refused the map (a ``ValueError``, ``TypeError``
            or ``InputError``: its message), its check failed (any other
            exception: a bug in the navigator, named with the place it was raised,
            its traceback logged at DEBUG), or it took longer than ``deadline_s``;
            nothing has connected.
    """
    check_map = navigator_method(navigator, "check_map", name)
    if not callable(check_map):
        return
    try:
        _check_shape(check_map)  # as next_step's is: a yield, or the wrong arity
        if deadline_s is None:
            answer = check_map(network)
        else:
            done, answer, raised = call_within(
                lambda: check_map(network), deadline_s, f"check_map {name}"
            )
            if not done:
                raise InputError(f"check_map took longer than its {deadline_s:g} s deadline")
            if raised is not None:
                raise raised
        _check_answer(answer)
    except (ValueError, TypeError, InputError) as exc:
        if not isinstance(exc, InputError) and not raised_on_purpose(exc):
            # Python's own error on a line of the check (a bug: 'x' in self.method),
            # not a refusal written as a raise: said as a bug, with its place
            _log.debug("navigator %r: check_map raised", name, exc_info=exc)
            raise InputError(
                f"navigator {name!r}: check_map raised {type(exc).__name__}:"
                f" {said_of(exc)[:200]} (at {raised_at(exc)})"
            ) from None
        # one line, as every error: a check_map's message may hold newlines; a long one
        # keeps its end (route's: "... and the map is 'straight'", cut at 300 characters)
        from pirate_bt.behaviours.foreign import one_line

        said = one_line(f"navigator {name!r}: {said_of(exc)}", REFUSAL_LIMIT)
        raise InputError(said) from None
    except (Exception, SystemExit) as exc:  # the navigator's own error, one located line
        _log.debug("navigator %r: check_map raised", name, exc_info=exc)
        text = said_of(exc)[:200]
        where = raised_at(exc)
        raise InputError(
            f"navigator {name!r}: check_map raised {type(exc).__name__}: {text}"
            + (f" (at {where})" if where else "")
        ) from None


_NEVER_RAN = (
    "and its check never ran; write it as a plain def that raises ValueError to refuse a map"
)


def shape_problem(function: Any) -> str | inspect.Signature | None:
    """What keeps planner code's method (``next_step``, ``check_map``) from being called
    with one argument and run, found before it is called
    (:func:`pirate_bt.callables.never_runs` and ``uncallable_with``): ``"async def"``
    or ``"yields"`` (a coroutine or generator function, its own or a callable object's
    ``__call__``: its body never runs), its signature when it cannot be called with
    one argument, ``None`` when it can (or has no signature to read)."""
    what = never_runs(function)
    if what is not None:
        return "async def" if what == "an async def" else "yields"
    signature = uncallable_with(function, 1)
    if signature is None:
        return None
    return signature.replace(return_annotation=inspect.Signature.empty)


def _check_shape(check_map: Any) -> None:
    """``check_map``'s shape, before it is called, as ``next_step``'s is: an ``async
    def`` or one that yields (its body never runs: a check that raised ``ValueError``
    was taken for one that passed), or one that cannot be called with one argument (it
    was said as a ``TypeError`` raised in this file).

    Raises:
        InputError: which of them, and how to write it.
    """
    problem = shape_problem(check_map)
    if isinstance(problem, str):
        raise InputError(
            f"check_map {'is async def' if problem == 'async def' else problem}, {_NEVER_RAN}"
        )
    if problem is not None:
        raise InputError(
            f"check_map{problem} cannot be called as check_map(map); give it one argument, the map"[
                :300
            ]
        )


def check_next_step_shape(next_step: Any) -> str | None:
    """Why ``next_step`` cannot be called as ``next_step(obs)`` and run (an ``async
    def``, a generator, the wrong arity), in words a message goes on from (*next_step
    yields; ...*), or ``None``."""
    problem = shape_problem(next_step)
    if problem == "async def":
        return (
            "next_step is async def; write it as a plain def that returns a Step, or None when done"
        )
    if problem == "yields":
        return "next_step yields; write it to return a Step, or None when done"
    if problem is not None:
        return (
            f"next_step{problem} cannot be called as next_step(obs); give it one argument,"
            " the observation"
        )
    return None


def _check_answer(answer: object) -> None:
    """What a ``check_map`` returned: ``False`` (NumPy's too) refuses the map (it was
    ignored, and the navigation ran on a map its navigator had said no to), and a coroutine or a
    generator (an ``async def`` check, never awaited; one that yields, never iterated)
    is refused as one that checked nothing."""
    if inspect.isawaitable(answer) or inspect.isgenerator(answer) or inspect.isasyncgen(answer):
        close = getattr(answer, "close", None)
        if callable(close) and not inspect.isasyncgen(answer):
            close()  # no 'coroutine was never awaited' warning
        said = "yields" if inspect.isgenerator(answer) else "is async def"
        raise InputError(f"check_map {said}, {_NEVER_RAN}")
    kind = type(answer)  # NumPy's false too: what a comparison of NumPy numbers gives
    if answer is False or (
        kind.__module__ == "numpy" and kind.__name__ in ("bool", "bool_") and not answer
    ):
        raise InputError(
            "check_map returned False: the map is refused (raise ValueError with the"
            " reason to say why)"
        )
