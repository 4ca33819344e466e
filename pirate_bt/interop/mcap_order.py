"""The order of an MCAP file's messages as a trace's records need them: one log time's
messages put back in order (each channel's by ``sequence``, the run's header first and
its end last), for :mod:`pirate_bt.interop.mcap_trace` (split from it, no change of
behaviour)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from pirate_bt.interop.foxglove_schemas import END, RUN

__all__: list[str] = []  # mcap_trace's helpers (it re-exports them)

_Timed = tuple[int, int, int, str, dict[str, Any]]
"""A message as it is read: ``(log_time, channel, sequence, topic, message)``."""


def _by_sequence(items: Iterator[_Timed]) -> Iterator[tuple[int, str, dict[str, Any]]]:
    """``items`` (those of one log time side by side) as ``(log_time, topic, message)``,
    one channel's messages of one log time in the order of their ``sequence``
    (:func:`_sequenced`)."""
    group: list[_Timed] = []
    try:
        for item in items:
            if group and item[0] != group[0][0]:
                for log_time, _, _, topic, message in _sequenced(group):
                    yield log_time, topic, message
                group = []
            group.append(item)
    except Exception:  # what came before the damage, then the damage
        for log_time, _, _, topic, message in _sequenced(group):
            yield log_time, topic, message
        raise
    for log_time, _, _, topic, message in _sequenced(group):
        yield log_time, topic, message


def _sequenced(group: list[_Timed]) -> list[_Timed]:
    """One log time's messages, each channel's in the order of their ``sequence``.

    MCAP's ``sequence`` is the publisher's counter: where it is not 0 it is unique per
    channel and increases over time. pirate_bt's writers fill it; a tool that rewrites
    the file (a merge, a sort, a filter) keeps it but may write the messages of one log
    time in any order, and two commands of one tick, written in reverse, were read in
    reverse. Each channel's messages of one time are put back in sequence order in the
    places that channel's messages held among that time's (the other channels' keep
    theirs); a channel with a message whose sequence is 0 (not filled) keeps its file
    order.
    """
    if len(group) < 2 or len({item[1] for item in group}) == len(group):
        return group  # no channel with two messages: nothing to order
    places: dict[int, list[int]] = {}
    for place, item in enumerate(group):
        places.setdefault(item[1], []).append(place)
    ordered = list(group)
    for held in places.values():
        if len(held) > 1 and all(group[place][2] for place in held):
            by_sequence = sorted(held, key=lambda place: group[place][2])
            for place, source in zip(held, by_sequence, strict=True):
                ordered[place] = group[source]
    return ordered


_RANK = {RUN: 0, END: 2}
"""Where a message goes among those of one log time: the header first, the end last."""


def _in_order(timed: Iterator[_Timed]) -> Iterator[tuple[str, Any]]:
    """The messages in the order of the records they rebuild, whatever the order of those
    that share a log time.

    MCAP does not order messages of equal log time, and another tool (the ``mcap``
    library's ``Writer``, a merge, a recorder sorting by time) may write them in any
    order: a run's header shares its log time with its first tick, its end with its last
    tick. Read in file order, a file that put the first tick's messages before the header
    was refused (*the first record is no header*), and one that put the end before the
    last tick's messages read a tick after the end. Each run of messages of one log time
    is put in order by what they are: the header, then the ticks' messages by tick number
    (in file order within a tick, one channel's by sequence: :func:`_sequenced`), then
    the end. Messages of different log times keep their file order.
    """
    group: list[_Timed] = []
    time = None
    for item in timed:
        if item[0] != time and group:
            yield from _one_time_in_order(group)
            group = []
        time = item[0]
        group.append(item)
    yield from _one_time_in_order(group)


def _one_time_in_order(group: list[_Timed]) -> Iterator[tuple[str, Any]]:
    """One log time's messages as :func:`_in_order` gives them."""
    keyed: list[tuple[int, int, int, str, dict[str, Any]]] = []
    for _, _, _, topic, message in _sequenced(group):
        rank = _RANK.get(topic, 1)
        n = message.get("n")
        tick = n if rank == 1 and isinstance(n, int) and not isinstance(n, bool) else 0
        keyed.append((rank, tick, len(keyed), topic, message))
    keyed.sort()  # (rank, tick, place): stable by place
    for *_, name, data in keyed:
        yield name, data
