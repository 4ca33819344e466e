"""A run's trace: its options checked before anything connects, and its writer attached.

Split from :mod:`pirate_bt.api.running` (which re-exports :func:`check_run_options`
and :func:`check_trace`); the same checks and messages.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pirate_bt.api.observing import check_observer
from pirate_bt.api.options import flag, output_path

__all__ = ["attach_run_trace", "check_run_options", "check_trace"]


def check_run_options(
    *, trace: Any = None, realtime: Any = False, live: Any = False, observe: Any = None
) -> None:
    """Check a run's ``trace`` (a file to write, of a known format), ``realtime`` and
    ``live`` (True or False) and ``observe`` (a function or None), before anything
    connects.

    Raises:
        InputError: the first that is wrong, named.
    """
    flag(realtime, "realtime")
    flag(live, "live")
    check_observer(observe)
    if trace is not None:
        check_trace(trace)


def check_trace(trace: Any, option: str = "trace", inputs: Mapping[str, Any] | None = None) -> Path:
    """A trace file to write: a file name with a known suffix, not a directory, a pipe
    or a device, and not one of the run's ``inputs`` (what each is, to what was given).

    Raises:
        InputError: a bad name, an unknown suffix (the known ones listed), a directory,
            a pipe or device, an input of the run, or a file another run is writing.
    """
    from pirate_bt.errors import InputError
    from pirate_bt.trace.formats import suffix_of
    from pirate_bt.trace.recorder_args import TraceWriteError, check_free
    from pirate_bt.trace.writer import WRITERS

    path = output_path(trace, option, inputs)
    try:
        suffix_of(str(path), WRITERS)
    except InputError as exc:
        raise InputError(f"{option}: {exc}") from None
    try:
        check_free(path)  # another run writing it now: say so before anything connects
    except TraceWriteError as exc:
        raise InputError(f"{option}: cannot write {path}: {exc.strerror}") from None
    return path


def attach_run_trace(
    runner: Any,
    path: Path,
    connection: Any,
    robot: Any,
    meta: Mapping[str, Any] | None,
    why: Callable[[Any], str],
) -> Any:
    from pirate_bt.trace import attach_trace, supervised_extras

    extras = None
    if connection is not None:
        sim = connection.simulator
        extras = supervised_extras(
            connection.supervisor, counters=sim.counters if sim is not None else None
        )
    from pirate_bt.errors import InputError

    options: dict[str, Any] = {}
    if meta:
        options["meta"] = dict(meta)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return attach_trace(
            runner,
            path,
            extras=extras,
            why=why,
            robot=robot,
            scenario=connection.target if connection is not None else None,
            seed=connection.seed if connection is not None else None,
            **options,
        )
    except OSError as exc:  # before the run: nothing has moved
        raise InputError(f"trace: cannot write {path}: {exc.strerror or exc}") from None
