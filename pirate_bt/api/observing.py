"""Planner code around a run (an ``observe=`` callback, its nodes' ``terminate``), and
what is made safe or undone when it raises."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

__all__ = ["call_observer", "run_to_rest"]


def call_observer(
    observe: Any, runner: Any, connection: Any, recorder: Any, trace_path: Path | None
) -> None:
    """Call ``observe(runner, connection)``; when it raises (the planner's own error,
    before anything moved), close the trace attached for the run and remove its file
    before the exception goes on: no trace of a run that never ran. It was left empty
    with its file open, one file descriptor lost a call.
    """
    try:
        observe(runner, connection)
    except BaseException:
        if recorder is not None and trace_path is not None:
            with contextlib.suppress(Exception):
                recorder.close("error", reason="the run did not start")
            with contextlib.suppress(OSError):
                trace_path.unlink()
        raise


def run_to_rest(runner: Any, supervisor: Any) -> Any:
    """``runner.run()``; an exception the runner lets out (a ``KeyboardInterrupt``, Ctrl-C,
    raised in a node's ``terminate()`` as the runner stops the running nodes) first puts
    the robot in its safe state, then goes on. It went out with the robot driving, no
    safe state entered, to planner code that caught it inside ``with connect(...)``.
    """
    try:
        return runner.run()
    except BaseException as exc:
        if supervisor is not None:
            what = "interrupted (Ctrl-C)" if isinstance(exc, KeyboardInterrupt) else "stopped"
            supervisor.safe_state(
                f"{what}: {type(exc).__name__} raised while the run ended, out of the runner"
            )
        raise
