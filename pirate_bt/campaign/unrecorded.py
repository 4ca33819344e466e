"""Traces of cases a stopped campaign did not record: taken away as it stops.

A campaign stopped by Ctrl-C or ``SIGTERM`` records no row for the cases in flight
(nor for those that finished as it stopped), but their traces were left under
``OUT/traces/``: some cut where the case was killed, none named by a row, until a
``--resume`` wrote them again. :func:`drop_unrecorded_traces` removes the trace of
every case of the campaign that has no row, and nothing else (only the names this
campaign's cases would have: ``traces/ID.jsonl`` or the folder ``traces/ID``).
"""

from __future__ import annotations

import contextlib
import json
import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from pirate_bt.campaign.paths import RESULTS_NAME

__all__ = ["drop_unrecorded_traces"]


def _recorded(results: Path) -> set[str]:
    ids: set[str] = set()
    with contextlib.suppress(OSError):
        for line in results.read_bytes().splitlines():
            with contextlib.suppress(ValueError, RecursionError):
                row = json.loads(line)
                if isinstance(row, dict) and isinstance(row.get("id"), str):
                    ids.add(row["id"])
    return ids


def drop_unrecorded_traces(folder: Path, cases: Iterable[dict[str, Any]]) -> None:
    """Remove ``folder/traces/ID.jsonl`` and ``folder/traces/ID`` of each of ``cases``
    that ``folder/results.jsonl`` has no row for; never raises."""
    traces = folder / "traces"
    if not traces.is_dir():
        return
    recorded = _recorded(folder / RESULTS_NAME)
    for case in cases:
        ident = case.get("id")
        if not isinstance(ident, str) or ident in recorded:
            continue
        with contextlib.suppress(OSError):
            (traces / f"{ident}.jsonl").unlink(missing_ok=True)
        shutil.rmtree(traces / ident, ignore_errors=True)
