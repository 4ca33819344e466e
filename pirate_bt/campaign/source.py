"""Where a campaign spec came from: a file (its key paths as ``file:line:column``) or data.

A :class:`SpecSource` words later errors about a spec at the key they concern; the
loaders of :mod:`pirate_bt.campaign.spec` :func:`remember` it beside the (frozen,
compared-by-value) model, and :func:`spec_source` finds it again. Split from
:mod:`pirate_bt.campaign.spec`.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from pirate_bt.errors import InputError, LocatedError, ValidationFailed
from pirate_bt.yamlfile import Locator

__all__ = ["SpecSource", "remember", "spec_source"]

_SpecT = TypeVar("_SpecT")


@dataclass(frozen=True)
class SpecSource:
    """Where a spec came from, to word later errors about it.

    Attributes:
        name: The file, or ``campaign spec`` for one given as data.
        base: The folder relative file names resolve against first (the file's
            folder; the working folder for data).
        locator: Where each key was written (files only).
    """

    name: str
    base: Path
    locator: Locator | None = None

    def where(self, path: Sequence[str | int]) -> str:
        """``file:line:column`` of a key path, or ``campaign spec: runs[0].tree`` for data."""
        if self.locator is not None:
            return str(self.locator.locate(path))
        return f"{self.name}: {_dotted(path)}" if path else self.name

    def error(self, path: Sequence[str | int], message: str) -> InputError:
        """One problem at a key path: a :class:`LocatedError` for a file."""
        if self.locator is not None:
            return self.locator.error(path, message)
        # A message that names its key already is not given it twice
        # ("campaign spec: runs: runs: ...").
        dotted = _dotted(path)
        if dotted and message.startswith((f"{dotted} ", f"{dotted}:")):
            return InputError(f"{self.name}: {message}")
        key = path[-1] if path else None
        if isinstance(key, str) and message.startswith(f"{key}: "):
            message = message[len(key) + 2 :]
        return InputError(f"{self.where(path)}: {message}")

    def errors(self, problems: Sequence[tuple[Sequence[str | int], str]]) -> InputError:
        """Several problems as one error (one line each)."""
        found = [self.error(path, message) for path, message in problems]
        located = [e for e in found if isinstance(e, LocatedError)]
        if located and len(located) == len(found):
            return found[0] if len(found) == 1 else ValidationFailed(located)
        return found[0] if len(found) == 1 else InputError("\n".join(map(str, found)))


def _dotted(path: Sequence[str | int]) -> str:
    out = ""
    for element in path:
        out += f"[{element}]" if isinstance(element, int) else f".{element}"
    return out.lstrip(".")


# Where each spec came from, beside the (frozen, compared-by-value) model itself.
_SOURCES: dict[int, SpecSource] = {}


def remember(spec: _SpecT, source: SpecSource) -> _SpecT:
    _SOURCES[id(spec)] = source
    weakref.finalize(spec, _SOURCES.pop, id(spec), None)
    return spec


def spec_source(spec: object) -> SpecSource | None:
    """Where ``spec`` was loaded from (:func:`load_campaign`, :func:`campaign_from_data`).

    ``None`` for a model built some other way.
    """
    return _SOURCES.get(id(spec))
