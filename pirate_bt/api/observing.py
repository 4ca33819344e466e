"""An ``observe=`` callback called before a run, and what is undone when it raises."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

__all__ = ["call_observer"]


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
