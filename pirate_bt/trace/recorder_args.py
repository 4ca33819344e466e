"""The arguments of :class:`~pirate_bt.trace.writer.TraceRecorder`, checked before
anything is opened.

A tree of ``None`` was found wrong only after the trace file had been created (empty:
*empty trace (no header)* when read) and its writer process started, which then ran
on with nothing to write; a destination of ``None`` raised *expected str, bytes or
os.PathLike object*, a folder named ``run.jsonl`` an ``IsADirectoryError``, and a
place that cannot be written (``/proc/x.jsonl``) a ``FileNotFoundError``.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import py_trees

from pirate_bt.errors import ArgumentTypeError, InputError, kind_of, shown
from pirate_bt.trace.sink_formats import BUSY, TraceBusyError, held

__all__ = [
    "TraceFolderError",
    "TraceWriteError",
    "check_destination",
    "check_free",
    "check_options",
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


def check_free(destination: str | os.PathLike[str]) -> None:
    """Refuse a trace file that another run is writing now, before a run connects.

    The recorder refuses it anyway, when it is made (see
    :func:`pirate_bt.trace.sink_formats.claim`); this says so before anything moves.

    Raises:
        TraceWriteError: another writer holds the file (its ``strerror`` is the reason).
    """
    if held(destination):
        raise unwritable(destination, TraceBusyError(errno.EWOULDBLOCK, BUSY))


def unwritable(destination: object, exc: OSError) -> TraceWriteError:
    """The one-line error for a trace file that cannot be created or written.

    Its ``strerror`` is the reason alone, for a caller that names the file itself.
    """
    reason = exc.strerror or str(exc)
    error = TraceWriteError(f"{destination}: cannot write trace: {reason}")
    error.strerror = reason
    return error


_FLAGS = ("full_state", "readings", "every_tick", "blackboard", "sync")
_OPTIONAL_FLAGS = ("background", "track_nodes")


def check_options(options: Mapping[str, Any]) -> None:
    """Refuse an option of the wrong type, naming it, before anything is opened.

    ``full_state="no"`` recorded every value (``"no"`` is true) and wrote ``"no"`` into
    the header, where a reader expects ``true`` or ``false``; ``meta=[1]`` raised a bare
    ``TypeError`` after the file had been created, leaving it empty (*empty trace (no
    header)* when read).
    """
    for name in _FLAGS + _OPTIONAL_FLAGS:
        value = options.get(name)
        if not isinstance(value, bool) and not (value is None and name in _OPTIONAL_FLAGS):
            allowed = "True or False" + (" or None" if name in _OPTIONAL_FLAGS else "")
            raise ArgumentTypeError(f"{name}: give {allowed}, not {shown(value)}")
    meta = options.get("meta")
    if meta is not None and not isinstance(meta, Mapping):
        raise ArgumentTypeError(
            f"meta: give a mapping of names to values or None, not {kind_of(meta)}"
        )
    seed = options.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise ArgumentTypeError(f"seed: give a whole number or None, not {kind_of(seed)}")
    scenario = options.get("scenario")
    if scenario is not None and not isinstance(scenario, str):
        raise ArgumentTypeError(f"scenario: give text or None, not {kind_of(scenario)}")
