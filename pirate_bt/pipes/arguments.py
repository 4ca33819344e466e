"""The arguments of :class:`~pirate_bt.pipes.Network` and
:class:`~pirate_bt.pipes.Path` methods, checked at the boundary.

A distance that is no number raised a ``TypeError`` from a comparison deep in
``Path.index_at``; ``nan`` answered with the first piece's slope and a ``nan``
position; a choice other than ``straight`` or ``branch`` went straight on, as if
nothing was asked; an unknown tee or segment was a bare ``KeyError``.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence

from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    InputError,
    kind_of,
    shown,
)
from pirate_bt.units import plain_number

__all__ = [
    "UnknownSegmentError",
    "check_spec",
    "checked_choices",
    "distance_argument",
    "unknown_segment",
]

_CHOICES = ("straight", "branch")


class UnknownSegmentError(InputError, KeyError):
    """A tee or segment id the network does not have (also a ``KeyError``, as before)."""

    def __str__(self) -> str:  # a KeyError's own str() quotes its message
        return str(self.args[0]) if self.args else ""


def unknown_segment(what: str, name: object, known: Sequence[str]) -> UnknownSegmentError:
    """The error for an id ``name`` that is none of ``known`` (``what``: tee, segment)."""
    listed = ", ".join(known) if len(known) <= 40 else ", ".join([*known[:40], "..."])
    return UnknownSegmentError(f"unknown {what} {shown(name)}; {what}s: {listed or 'none'}")


def check_spec(spec: object, source: object) -> None:
    """Refuse a ``Network(spec)`` whose spec is no ``NetworkSpec`` (``Network("lab")``
    raised *'str' object has no attribute 'segments'*) or whose source is no text."""
    from pirate_bt.pipes.model import NetworkSpec

    if not isinstance(spec, NetworkSpec):
        raise ArgumentTypeError(
            "spec: give a NetworkSpec; a file or a bundled name is loaded with"
            f" load_network(...), plain data with network_from_data(...), not {kind_of(spec)}"
        )
    if not isinstance(source, str):
        raise ArgumentTypeError(
            f"source: give text (where it was loaded from), not {kind_of(source)}"
        )


def distance_argument(s_m: object, option: str = "s_m") -> float:
    """``s_m`` as a distance in metres along a path: a real number, not ``nan``
    (``inf`` is held at the path's end, as any distance beyond it); a 0-d NumPy array
    is the number it holds, as a NumPy number is (it was refused, *not a ndarray*)."""
    s_m = plain_number(s_m)
    if isinstance(s_m, bool) or not isinstance(s_m, numbers.Real):
        raise ArgumentTypeError(
            f"{option}: give a distance along the path in metres (a number), not {kind_of(s_m)}"
        )
    try:
        value = float(s_m)
    except OverflowError:
        raise ArgumentValueError(
            f"{option}: {shown(s_m)} is too large for a distance in metres"
        ) from None
    if value != value:
        raise ArgumentValueError(f"{option}: nan is no distance along the path; give metres")
    return value


def checked_choices(choices: object, tees: Sequence[str]) -> dict[str, str]:
    """``choices`` as a dict of a known tee id to ``straight`` or ``branch``."""
    if choices is None:
        return {}
    if not isinstance(choices, Mapping):
        raise ArgumentTypeError(
            "choices: give a mapping of tee ids to 'straight' or 'branch'"
            f" (such as {{'tee-1': 'branch'}}), not {kind_of(choices)}"
        )
    out: dict[str, str] = {}
    for tee, choice in choices.items():
        if tee not in tees:
            raise unknown_segment("tee", tee, tees)
        if not isinstance(choice, str) or choice not in _CHOICES:
            raise ArgumentValueError(
                f"choices: tee {tee!r}: {shown(choice)} is no way through a tee;"
                " give 'straight' or 'branch'"
            )
        out[tee] = choice
    return out
