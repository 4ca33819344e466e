"""Appending the campaign's rows to ``results.jsonl``: whole lines, or none.

A row is written with one unbuffered append and its line end, so a reader (a
resume, ``campaign report``) never meets half a row the campaign left while it
went on. A write the file system refuses (a full disk, a quota) is undone to the
last whole line and stops the campaign with one line naming the file; the rows
written before it stay for ``--resume``. (Through a buffered text stream, the
8 kB the buffer held went out cut mid-row, and the command said only
``No space left on device``.)
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path
from typing import Any

from pirate_bt.campaign.paths import RESUME
from pirate_bt.errors import InputError

__all__ = ["RowSink"]


class RowSink:
    """``results.jsonl`` open for appending rows (a context manager).

    Args:
        path: The results file (it exists: the campaign wrote it as it started).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd = os.open(path, os.O_WRONLY | os.O_APPEND)

    def __enter__(self) -> RowSink:
        return self

    def __exit__(self, *_exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the file (the rows are written already: nothing is buffered)."""
        if self._fd >= 0:
            fd, self._fd = self._fd, -1
            os.close(fd)

    def write(self, record: dict[str, Any]) -> None:
        """Append ``record`` as one JSON line.

        Raises:
            InputError: the file system refused it; the file ends at its last whole
                row again. Or the case's trace met a full disk (``no_room``): not
                written, so that a resume runs the case again.
        """
        if record.get("no_room"):  # its trace met a full disk: the disk's, not a row
            raise InputError(
                f"{record['no_room']}: cannot write case {record.get('id')}'s trace; the"
                f" rows before it stay: make room, then run again with {RESUME}"
            )
        data = (json.dumps(record, allow_nan=False, default=str) + "\n").encode("utf-8")
        end = os.lseek(self._fd, 0, os.SEEK_END)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(self._fd, view) :]
        except OSError as exc:
            with contextlib.suppress(OSError):
                os.ftruncate(self._fd, end)  # no cut row left behind
            raise InputError(
                f"{self.path}: cannot write case {record.get('id')}'s row:"
                f" {exc.strerror or exc}; the rows before it stay: make room,"
                f" then run again with {RESUME}"
            ) from None
