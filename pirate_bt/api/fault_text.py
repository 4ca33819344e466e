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

from pirate_bt.errors import InputError, kind_of, shown

__all__ = ["MAX_FAULTS", "MAX_FAULT_TEXT", "check_link_faults", "fault_items", "split_faults"]

MAX_FAULTS = 1000
"""The most faults one run takes."""

MAX_FAULT_TEXT = 200
"""The longest fault (``motor_stall:bend_3_drive@5s+20s``)."""


# An item runs to the next ',', ';' or whitespace, but a number and its time unit
# written apart ('@2 s', 'delay=20 ms') stay one item: split there, '2' was told it
# "needs a unit" and 's' that it "is not key=value". So do a simulator fault's '@' and
# '+' with spaces around them ('link_loss@2s + 1s', as parse_fault reads it): split
# there, '+' was told it was a link fault that "is not key=value".
_ITEM = re.compile(
    r"(?:[^,;\s]|(?<=\d)\s+(?=(?:ns|us|µs|ms|s|min|h)(?:[,;+\s]|$))"
    r"|(?<=[^,;\s])\s+(?=[@+])|(?<=[@+])\s+(?=[^,;\s]))+"
)


def fault_items(text: str) -> list[tuple[int, str]]:
    """The items of one fault text, each with its column (1-based).

    Items are separated by ``,``, ``;`` or whitespace, except that a number and its
    time unit may stand apart (``motor_stall:bend_1_drive@2 s+1 s``), and so may a
    simulator fault's ``@`` and ``+`` from their neighbours (``link_loss@2s + 1s``).
    """
    return [(m.start() + 1, m.group()) for m in _ITEM.finditer(text)]


def split_faults(faults: str | Iterable[str] | None) -> tuple[list[str], str | None]:
    """Split a fault spec into simulator faults and a link fault spec.

    Items are separated by ``,``, ``;`` or whitespace (or given as a list); a number
    and its time unit may stand apart (``@2 s``, ``delay=20 ms``). An item
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
    from pirate_bt.pipes import FaultSpec

    items: list[str] = []
    if isinstance(faults, str):
        items = [item for _, item in fault_items(faults)]
    elif faults is not None:
        if isinstance(faults, bytes | bytearray | Mapping | FaultSpec) or not isinstance(
            faults, Iterable
        ):  # a FaultSpec is iterable (its fields): it was 'each item is text, not a tuple'
            raise InputError(
                "faults: give text ('drop=0.05,motor_stall:bend_3_drive@5s') or a list of"
                f" texts, not {kind_of(faults)}{_as_text(faults)}"
            )
        for part in faults:
            if not isinstance(part, str):
                raise InputError(f"faults: each item is text, not {kind_of(part)}{_as_text(part)}")
            items += [item for _, item in fault_items(part)]
            if len(items) > MAX_FAULTS:  # an endless iterator is refused, not read for ever
                break
    if len(items) > MAX_FAULTS or any(len(i) > MAX_FAULT_TEXT for i in items):
        raise InputError(
            f"faults: at most {MAX_FAULTS} faults of at most {MAX_FAULT_TEXT} characters each"
        )
    sim = [i for i in items if "@" in i]
    link = [i for i in items if "@" not in i]
    if link:
        check_link_faults(",".join(link))
    return sim, (",".join(link) or None)


def _as_text(value: object) -> str:
    """For a ``FaultSpec`` given where its text is wanted, that text as a hint."""
    from pirate_bt.pipes import FaultSpec

    if not isinstance(value, FaultSpec):
        return ""
    from pirate_bt.sim.faults import format_fault

    return f" (write it as text: {format_fault(value)!r})"


def check_link_faults(spec: str, option: str = "faults") -> None:
    """Parse a link fault spec (``drop=0.05,corrupt=0.01``) for its errors only: the
    command line's ``--faults`` places them at an item's column without reaching the
    link itself (nothing above the protective layer imports it).

    Raises:
        InputError: an unknown key, a value out of range, a key given twice; the
            message starts with ``option`` when it is not empty.
    """
    from pirate_bt.link.faults import parse_fault_spec

    prefix = f"{option}: " if option else ""
    for item in spec.split(","):
        problem = _simulator_fault_without_time(item.strip())
        if problem:
            raise InputError(prefix + problem)
    parse_fault_spec(spec, option=option)


# A target each kind of simulator fault takes, for the examples (the bundled robot's).
_NO_TIME = re.compile(r"(?P<kind>[A-Za-z_]+)(?::(?P<target>[^+=@]*))?(?:\+(?P<duration>.*))?")


def _simulator_fault_without_time(item: str) -> str | None:
    """What a simulator fault written without its ``@AT`` lacks, with an example; None
    for an item that is no simulator fault (a link fault, right or wrong). Without an
    ``@`` it is taken for a link fault, and was told it "is not key=value"."""
    from pirate_bt.sim.faults import FAULT_KINDS, NO_TARGET_KINDS, write_fault

    key, equals, _ = item.partition("=")
    if equals:  # board_reset=22: a simulator fault's kind as a link fault's key
        kind = key.strip()
        if kind not in FAULT_KINDS:
            return None
        how = write_fault(kind)
        return f"{shown(item)} is a simulator fault, not a link fault (KEY=VALUE): {how}"
    match = _NO_TIME.fullmatch(item)
    if match is None or match["kind"] not in FAULT_KINDS:
        return None
    kind, target, duration = match["kind"], match["target"], match["duration"]
    then = f"+{duration}" if duration else ""
    if kind in NO_TARGET_KINDS:
        return f"simulator fault {shown(item)} lacks its time: {write_fault(kind, then)}"
    if not target:
        how = write_fault(kind, then)
        return f"simulator fault {shown(item)} lacks its target and its time: {how}"
    written = f"{kind}:{target}"
    return (
        f"simulator fault {shown(item)} lacks its time: write {written}@AT{then or '[+DURATION]'},"
        f" e.g. {written}@5s{then}"
    )
