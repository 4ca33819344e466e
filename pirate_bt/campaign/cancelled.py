"""Cases the executor dropped without running them: the campaign stops, not a row.

A Dask client whose scheduler went away cancels every case it had not yet handed
back (``concurrent.futures.CancelledError``). Those cases never ran: recorded as
``error`` rows (``worker lost: ``, with an empty reason) they read as the robot's
errors in the report, and ``--resume`` would never run them. They are counted
instead, the cases still out are waited for, and the campaign stops with one line
that says how many rows it keeps, so that a resume runs the rest.
"""

from __future__ import annotations

import logging
from pathlib import Path

from pirate_bt.campaign.paths import RESUME
from pirate_bt.errors import InputError

__all__ = ["CasesNotRun", "LostSchedulerNoise", "not_run"]


class CasesNotRun(InputError):
    """The executor cancelled cases before they ran (its Dask scheduler is gone?).

    Attributes:
        kept: Rows the campaign has (old and new); ``None`` when not told.
        total: Its cases (``None``: not told).
        rest: What the message says after the cancelled cases: how many rows the
            results file keeps and what to run next.
    """

    kept: int | None = None
    total: int | None = None
    rest: str = ""


def not_run(results: Path | None, unrun: int, kept: int, total: int) -> CasesNotRun:
    """The error a campaign stops with when the executor cancelled ``unrun`` cases.

    Args:
        results: The results file, or ``None`` (no output folder).
        unrun: Cases cancelled before they ran.
        kept: Rows the campaign has (old and new).
        total: Its cases.
    """
    what = (
        f"the executor cancelled {unrun} of the {total} cases before they ran"
        " (its Dask scheduler went away?)"
    )
    if results is None:
        rest = f"{kept} cases ran"
    else:
        rest = (
            f"{results} keeps {kept} of its {total} cases: run again with {RESUME}"
            f" to run the other {total - kept}"
        )
    error = CasesNotRun(f"{what}; {rest}")
    error.kept, error.total, error.rest = kept, total, rest
    return error


class LostSchedulerNoise(logging.Filter):
    """Keeps Dask's client from logging a lost scheduler as tracebacks.

    A client whose scheduler went away logs *Failed to reconnect to scheduler* and
    then the ``CancelledError`` tracebacks of its own closing (26 lines on standard
    error, before the campaign's line). The campaign says it in one line
    (:class:`CasesNotRun`); what else the client logs passes.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        """False for the lost scheduler's records."""
        if record.exc_info is not None or record.exc_text:
            return False
        return not str(record.msg).startswith("Failed to reconnect to scheduler")
