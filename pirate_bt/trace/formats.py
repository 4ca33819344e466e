"""Trace formats by file suffix, and how formats that live elsewhere join in.

A trace file's format is chosen by its suffix from two tables: format writers
(:data:`pirate_bt.trace.WRITERS`) and format readers
(:data:`pirate_bt.trace.READERS`). This package fills them with its own JSON
Lines formats. Formats that live in a package above this one (MCAP, in
:mod:`pirate_bt.interop.mcap_trace`) or in another distribution *register
themselves*: this package never imports them.

- From Python: :func:`pirate_bt.trace.register_writer` and
  :func:`pirate_bt.trace.register_reader` add a row.
- From a distribution's metadata: an entry point in the group
  ``pirate_bt.trace_formats`` names a function with no arguments that
  registers the distribution's formats. The group is read once, lazily, the
  first time a suffix is asked for that no row matches::

      [project.entry-points."pirate_bt.trace_formats"]
      mcap = "pirate_bt.interop.mcap_trace:register"

A suffix nobody registered is an :class:`~pirate_bt.errors.InputError` that
lists the suffixes known; a suffix that an optional part of pirate_bt provides
but that is not installed (``.mcap`` without entry points, as when running a
source tree that was never installed) says what to install.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Mapping, MutableMapping
from importlib.metadata import entry_points
from pathlib import Path
from typing import TypeVar

from pirate_bt.errors import ConfigurationError, InputError

__all__ = [
    "ENTRY_POINT_GROUP",
    "load_format_entry_points",
    "register_format",
    "suffix_of",
]

logger = logging.getLogger(__name__)

ENTRY_POINT_GROUP = "pirate_bt.trace_formats"
"""The entry-point group whose functions register trace formats."""

_INSTALL_HINTS: dict[str, str] = {
    ".mcap": "MCAP needs pirate-bt installed with its foxglove extra:"
    " pip install 'pirate-bt[foxglove]' (in a source tree: pip install -e '.[foxglove]')",
}
"""Suffixes an optional part of pirate_bt registers through its entry points, and
what to install when none did."""

_lock = threading.RLock()
_loaded = False
_failures: dict[str, str] = {}
"""Entry point name -> why it could not be loaded."""

F = TypeVar("F", bound=Callable[..., object])


def _normalise(suffix: str) -> str:
    if not isinstance(suffix, str) or not suffix.startswith(".") or len(suffix) < 2:
        raise ValueError(f"a trace format suffix starts with a dot, such as '.jsonl': {suffix!r}")
    return suffix.lower()


def register_format(
    table: MutableMapping[str, F], suffix: str, factory: F, *, replace: bool = False
) -> None:
    """Add ``suffix -> factory`` to a table of formats.

    Registering the same factory again is a no-op, so a module may register on
    import and again from its entry point.

    Raises:
        ValueError: ``suffix`` does not start with a dot, or it is taken by another
            factory (unless ``replace``).
    """
    key = _normalise(suffix)
    if not callable(factory):
        raise ValueError(f"the format for {key!r} must be callable, not {factory!r}")
    with _lock:
        current = table.get(key)
        if current is not None and current != factory and not replace:
            name = getattr(current, "__qualname__", repr(current))
            raise ValueError(
                f"trace format {key!r} is already registered ({name}); pass replace=True"
            )
        table[key] = factory


def load_format_entry_points(*, reload: bool = False) -> dict[str, str]:
    """Call every function of the ``pirate_bt.trace_formats`` entry-point group, once.

    An entry point that cannot be loaded or fails is logged and skipped (the
    error for its suffix then says why).

    Args:
        reload: Read the group again even if it was read already.

    Returns:
        The entry points that failed: name -> reason.
    """
    global _loaded
    with _lock:
        if _loaded and not reload:
            return dict(_failures)
        _loaded = True
        _failures.clear()
        for ep in entry_points(group=ENTRY_POINT_GROUP):
            try:
                hook = ep.load()
                hook()
            except Exception as exc:  # a broken plugin must not break the built-in formats
                _failures[ep.name] = f"{type(exc).__name__}: {exc}"
                logger.warning(
                    "trace format entry point %r (%s) failed: %s", ep.name, ep.value, exc
                )
        return dict(_failures)


def _match(name: str, table: Mapping[str, object]) -> str | None:
    for suffix in sorted(table, key=len, reverse=True):
        if name.endswith(suffix):
            return suffix
    return None


def suffix_of(path: str | Path, table: Mapping[str, object]) -> str:
    """The longest suffix in ``table`` that ``path`` ends with.

    When none matches, the ``pirate_bt.trace_formats`` entry points are loaded
    (once) and the table is looked at again.

    Raises:
        InputError: no suffix in the table matches; the message lists those known.
        ConfigurationError: the suffix belongs to a part of pirate_bt that is not
            installed (``.mcap`` without the foxglove extra's entry point).
    """
    name = Path(path).name.lower()
    found = _match(name, table)
    if found is not None:
        return found
    failures = load_format_entry_points()
    found = _match(name, table)
    if found is not None:
        return found
    known = ", ".join(sorted(table))
    failed = "".join(f"; entry point {n!r} failed: {why}" for n, why in sorted(failures.items()))
    for suffix, hint in _INSTALL_HINTS.items():
        if name.endswith(suffix):
            raise ConfigurationError(
                f"{path}: {hint}; the trace formats known are: {known}{failed}"
            )
    raise InputError(f"{path}: unknown trace format; name it with one of: {known}{failed}")


def refuse_folder(path: str | Path) -> None:
    """A folder given as a trace is named as one, with the traces it holds (a campaign
    row's ``trace`` of a route or navigator case, a mission's ``--output``), where it
    was an *unknown trace format*.

    Raises:
        InputError: ``path`` is a folder.
    """
    try:
        if not Path(path).is_dir():
            return
        found = sorted(p.name for p in Path(path).glob("*.jsonl*") if p.name != "navigation.jsonl")
    except OSError:  # a name too long, a folder not to be listed: read as before
        return
    held = f"; the traces in it: {', '.join(found[:3])}{', ...' if len(found) > 3 else ''}"
    held = held if found else ""
    raise InputError(f"{path}: cannot read trace: it is a folder, not a file{held}")
