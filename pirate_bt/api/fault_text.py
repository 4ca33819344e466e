"""The ``faults`` option's text: simulator faults and link faults, told apart.

One run's faults are given as one text (or a list of texts) whose items are
separated by ``,``, ``;`` or whitespace: ``motor_stall:bend_3_drive@5s+2s`` is a
simulator fault (it has an ``@``), ``drop=0.05`` a link fault. The API
(:func:`split_faults`) and the command line (``--faults``, which places a bad
item at its column) split it the same way.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

from pirate_bt.errors import InputError, kind_of

__all__ = ["MAX_FAULTS", "MAX_FAULT_TEXT", "split_faults"]

MAX_FAULTS = 1000
"""The most faults one run takes."""

MAX_FAULT_TEXT = 200
"""The longest fault (``motor_stall:bend_3_drive@5s+20s``)."""


def split_faults(faults: str | Iterable[str] | None) -> tuple[list[str], str | None]:
    """Split a fault spec into simulator faults and a link fault spec.

    Items are separated by ``,``, ``;`` or whitespace (or given as a list). An item
    with ``@`` is a simulator fault (``motor_stall:bend_3_drive@5s+2s``); the others
    are link byte faults (``drop=0.05``, ``corrupt=0.01``), joined into one spec.

    Returns:
        ``(simulator faults, link fault spec or None)``.

    Raises:
        InputError: too many faults, or a link fault that does not parse
            (:func:`pirate_bt.link.faults.parse_fault_spec`): found here, where every
            run checks its options, not when the link opens (a mission's output folder
            was made by then, and ``pirate-bt demo`` had drawn the robot).
    """
    items: list[str] = []
    if isinstance(faults, str):
        items = [i for i in re.split(r"[,;\s]+", faults) if i]
    elif faults is not None:
        if isinstance(faults, bytes | bytearray | Mapping) or not isinstance(faults, Iterable):
            raise InputError(
                "faults: give text ('drop=0.05,motor_stall:bend_3_drive@5s') or a list of"
                f" texts, not {kind_of(faults)}"
            )
        for part in faults:
            if not isinstance(part, str):
                raise InputError(f"faults: each item is text, not {kind_of(part)}")
            items += [i for i in re.split(r"[,;\s]+", part) if i]
    if len(items) > MAX_FAULTS or any(len(i) > MAX_FAULT_TEXT for i in items):
        raise InputError(
            f"faults: at most {MAX_FAULTS} faults of at most {MAX_FAULT_TEXT} characters each"
        )
    sim = [i for i in items if "@" in i]
    link = [i for i in items if "@" not in i]
    if link:
        from pirate_bt.link.faults import parse_fault_spec

        parse_fault_spec(",".join(link))
    return sim, (",".join(link) or None)
