"""A campaign given as Python data, in the plain values a YAML file loads into.

``run_campaign({...})`` takes a mapping "as the YAML would load"; from Python it
often holds values of the same meaning in other types: a NumPy integer
(``seeds: {count: np.int64(20)}`` was refused as *must be a whole number, not
np.int64(20)*, while a NumPy float rate was taken) or a :class:`~pathlib.Path`
(``tree: Path("trees/x.yaml")`` was refused as *must be text, not PosixPath(...)*).
:func:`plain` turns those into ``int`` and ``str`` before the spec is checked; any
other value is left for the check to name.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Mapping
from typing import Any

from pirate_bt.errors import InputError

__all__ = ["plain"]


_SCALARS = frozenset({str, int, float, bool, type(None)})
"""Types a YAML file loads into that need nothing done: passed by their exact type,
without the abstract checks below (a list of a million of them took seconds)."""

_MANY = 100_000
"""A list longer than any list a spec may hold is left as it is: the check refuses it
by its length, and walking it first only made the refusal slow."""


def _plain(value: Any) -> Any:
    kind = type(value)
    if kind in _SCALARS:
        return value
    if kind is list or kind is tuple:
        if len(value) > _MANY:
            return value
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return value if len(value) > _MANY else [_plain(v) for v in value]
    if isinstance(value, os.PathLike):
        path = os.fspath(value)
        return path if isinstance(path, str) else value
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, int)):
        return int(value)  # NumPy's bool is no Integral: left for the check to refuse
    return value


def plain(data: Mapping[str, Any], name: str = "campaign spec") -> dict[str, Any]:
    """``data`` with NumPy integers as ``int`` and paths as ``str``, at every depth.

    Raises:
        InputError: nested past Python's stack (no spec is).
    """
    try:
        return {k: _plain(v) for k, v in data.items()}
    except RecursionError:
        raise InputError(f"{name}: nested too deep to be a campaign") from None
