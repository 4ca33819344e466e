"""Planner code called as the navigation calls it: on a thread of its own within a
deadline (:func:`call_within`), and its exception told apart: where it was raised
(:func:`raised_at`), and whether by a ``raise`` of its own, a refusal, or by Python on
a line of it, a bug (:func:`raised_on_purpose`).

Split from :mod:`pirate_bt.task.navigation`, which still offers these names.
"""

from __future__ import annotations

import linecache
import threading
from collections.abc import Callable
from typing import Any

__all__ = ["call_within", "import_failure", "raised_at", "raised_on_purpose"]


def raised_at(exc: BaseException) -> str | None:
    """``file:line`` of the frame that raised ``exc`` (the innermost of its traceback)."""
    tb = exc.__traceback__
    if tb is None:
        return None
    while tb.tb_next is not None:
        tb = tb.tb_next
    return f"{tb.tb_frame.f_code.co_filename}:{tb.tb_lineno}"


def import_failure(exc: BaseException, limit: int = 300) -> str:
    """Why a plug-in's module did not import, in one line: the exception's type, its
    words and where it was raised in a file outside Python's import machinery and
    pirate_bt (a ``SyntaxError`` at its line and column). Python's words alone where no
    such file is to blame (the plug-in's module is not there) and for a ``sys.exit()``
    (its code). It said the words alone (*name 'speed' is not defined*): no type, no
    place."""
    import importlib
    import os

    from pirate_bt.errors import said_of

    words = said_of(exc, limit) or type(exc).__name__
    if isinstance(exc, SystemExit):
        return words
    if isinstance(exc, SyntaxError) and exc.filename and exc.lineno:
        column = f":{exc.offset}" if exc.offset else ""
        return f"SyntaxError: {exc.msg} (at {exc.filename}:{exc.lineno}{column})"[:limit]
    ours = (
        os.path.dirname(importlib.__file__) + os.sep,
        os.path.dirname(os.path.dirname(__file__)) + os.sep,  # pirate_bt's own
    )
    at = None
    tb = exc.__traceback__
    while tb is not None:
        name = tb.tb_frame.f_code.co_filename
        if not name.startswith("<") and not name.startswith(ours):
            at = f"{name}:{tb.tb_lineno}"
        tb = tb.tb_next
    return words if at is None else f"{type(exc).__name__}: {words} (at {at})"


def raised_on_purpose(exc: BaseException) -> bool:
    """Whether the innermost frame of ``exc``'s traceback is a ``raise`` statement: a
    refusal written as one, not Python's own error on a line of the planner's code
    (``'run-d' in self.find``: a ``TypeError`` from a bug), told by the instruction that
    raised (``if m is None: raise ValueError(...)`` too, once said as a bug), else by
    its line (true when the source cannot be read)."""
    import dis

    tb = exc.__traceback__
    if tb is None:
        return True
    while tb.tb_next is not None:
        tb = tb.tb_next
    code, at = tb.tb_frame.f_code, tb.tb_lasti
    op = next((i.opname for i in dis.get_instructions(code) if i.offset == at), None)
    if op is not None:
        return op in ("RAISE_VARARGS", "RERAISE")
    line = linecache.getline(code.co_filename, tb.tb_lineno)
    return not line.strip() or line.lstrip().startswith("raise")


def call_within(
    call: Callable[[], Any], deadline_s: float, name: str
) -> tuple[bool, Any, BaseException | None]:
    """Run planner code (a navigator's decision, its map check) on a daemon thread of
    its own, for at most ``deadline_s`` of wall time: ``(True, value, None)`` when it
    returned, ``(True, None, exception)`` when it raised (anything, handed to the
    caller's thread), ``(False, None, None)`` when it is still running (left to run:
    it holds nothing of ours)."""
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["value"] = call()
        except BaseException as exc:  # planner code's error is the caller's to judge
            box["error"] = exc

    thread = threading.Thread(target=run, name=name, daemon=True)
    thread.start()
    thread.join(deadline_s)
    if thread.is_alive():
        return False, None, None
    return True, box.get("value"), box.get("error")
