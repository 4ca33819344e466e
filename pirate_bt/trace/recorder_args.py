"""The arguments of :class:`~pirate_bt.trace.writer.TraceRecorder`, checked before
anything is opened.

A tree of ``None`` was found wrong only after the trace file had been created (empty:
*empty trace (no header)* when read) and its writer process started, which then ran
on with nothing to write; a destination of ``None`` raised *expected str, bytes or
os.PathLike object*, a folder named ``run.jsonl`` an ``IsADirectoryError``, and a
place that cannot be written (``/proc/x.jsonl``) a ``FileNotFoundError``.
"""

from __future__ import annotations

import os
from pathlib import Path

import py_trees

from pirate_bt.errors import ArgumentTypeError, InputError, kind_of

__all__ = [
    "TraceFolderError",
    "TraceWriteError",
    "check_destination",
    "check_tree",
    "unwritable",
]


class TraceWriteError(InputError, OSError):
    """A trace file that cannot be created or written (an ``OSError``, as before)."""


class TraceFolderError(InputError, IsADirectoryError):
    """A trace destination that is a folder (an ``IsADirectoryError``, as before)."""


def check_tree(tree: object) -> None:
    """Refuse a ``tree`` that is no py_trees tree nor behaviour, naming it."""
    if not isinstance(tree, py_trees.trees.BehaviourTree | py_trees.behaviour.Behaviour):
        raise ArgumentTypeError(
            f"tree: give a py_trees BehaviourTree or its root behaviour, not {kind_of(tree)}"
        )


def check_destination(destination: object) -> None:
    """Refuse a file ``destination`` that is no file name, or is a folder."""
    if not isinstance(destination, str | os.PathLike) or not isinstance(
        os.fspath(destination), str
    ):
        raise ArgumentTypeError(
            "destination: give a trace file name (text or a Path) or a format writer,"
            f" not {kind_of(destination)}"
        )
    if Path(destination).is_dir():
        raise TraceFolderError(f"{destination}: cannot write trace: it is a folder, not a file")


def unwritable(destination: object, exc: OSError) -> TraceWriteError:
    """The one-line error for a trace file that cannot be created or written."""
    return TraceWriteError(f"{destination}: cannot write trace: {exc.strerror or exc}")
