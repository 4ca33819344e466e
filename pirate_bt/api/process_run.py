"""One run at a time in a process: py_trees' blackboard is one per process.

The PAB trees keep their working values on py_trees' blackboard (a leg's distance, a
probe's answer), and that blackboard is one per process. Two trees, missions or
navigations ticking at once on two threads read and overwrite each other's values:
four ``simulate_mission("lab.route")`` calls on four threads ended three of them in a
*map disagreement* that was no disagreement of map and pipe, each alone a success.

So every run of the API holds the process's run (:func:`only_run`), on its thread, for
the whole call: a tree, a mission, a navigation or a survey, and a runner of
``connection.runner()`` while it runs. A run asked for on another thread meanwhile is
refused at once, before anything moves, naming the run that holds it; it never waits
(a hook that started a run on a thread and joined it would wait for ever). Calls nested
on the holding thread (a survey's navigation) go on. Runs in parallel go in processes
(``run_campaign``, a ``ProcessPoolExecutor``), each with a blackboard of its own; a
forked child starts with no run held.
"""

from __future__ import annotations

import functools
import os
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

from pirate_bt.errors import InputError

__all__ = ["RunInProcessError", "held_by", "one_run_in_process", "only_run"]

_F = TypeVar("_F", bound=Callable[..., Any])

_lock = threading.Lock()
_holder: tuple[int, str, str] | None = None  # (thread ident, thread name, what runs)
_depth = 0


class RunInProcessError(InputError):
    """A run asked for on one thread while another thread's run ticks in this process."""


def held_by() -> str | None:
    """What holds this process's run (``"simulate_mission on thread 'Thread-1'"``), or
    ``None``."""
    holder = _holder
    return None if holder is None else f"{holder[2]} on thread {holder[1]!r}"


@contextmanager
def only_run(what: str) -> Iterator[None]:
    """Hold this process's run for ``what`` (``"simulate_tree"``) on this thread.

    Raises:
        RunInProcessError: another thread holds it (an ``InputError``, one line).
    """
    global _holder, _depth
    me = threading.current_thread()
    with _lock:
        if _holder is not None and _holder[0] != me.ident:
            raise RunInProcessError(
                f"{what}: {_holder[2]} is running on thread {_holder[1]!r} of this process;"
                " py_trees' blackboard is one per process, and two runs at once read and"
                " overwrite each other's values: run one after another, or in processes"
                " (run_campaign, a ProcessPoolExecutor)"
            )
        if _holder is None:
            _holder = (me.ident or 0, me.name, what)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _holder = None


def one_run_in_process(what: str) -> Callable[[_F], _F]:
    """A decorator: the call holds this process's run (:func:`only_run`) throughout."""

    def decorate(function: _F) -> _F:
        @functools.wraps(function)
        def holding(*args: Any, **kwargs: Any) -> Any:
            with only_run(what):
                return function(*args, **kwargs)

        return holding  # type: ignore[return-value]

    return decorate


def _forked() -> None:
    """In a forked child: no run (the thread that held it is not there)."""
    global _lock, _holder, _depth
    _lock = threading.Lock()
    _holder = None
    _depth = 0


os.register_at_fork(after_in_child=_forked)
