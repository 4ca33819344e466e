"""The link's health (:class:`~pirate_bt.robot.port.LinkHealth`) from the session's
figures: which figures, and the refused ``STATE`` frames as (reason, count) pairs.

Split out of :mod:`pirate_bt.link.robot_link`, whose ``RobotLink.health`` uses them.
"""

from __future__ import annotations

from operator import attrgetter

from pirate_bt.link.inbound import STATE_REFUSALS
from pirate_bt.link.session import SessionStats
from pirate_bt.robot.port import LinkHealth

__all__ = ["HEALTH_FIGURES", "REFUSED_STATES_REPORTED", "health_of", "refusals"]

# The session figures health() is made of, read in one C call. ``completed`` is there
# because every request that enters the loss window also bumps it, so the loss ratio
# (a sum over the window) is only recomputed when it moved.
HEALTH_FIGURES = attrgetter(
    "_lost",
    "_closed",
    "_last_heard_s",
    "_rtt_s",
    "crc_errors",
    "retries",
    "failed",
    "duplicates",
    "completed",
    "_flags",
    "bridge_resets",
    "_faulted",
    "_refused",
)


REFUSED_STATES_REPORTED = 5
"""STATE frames refused in a row before ``LinkHealth.states_refused`` reports them while
the session has taken no ``STATE`` yet (the connect): until one is taken nothing says the
bridge speaks this protocol, and a bridge at another baud rate makes the odd frame whose
damaged type byte says ``STATE``. Once one was taken, every refused frame since the
last one taken is reported: only the supervisor asks why, when no ``STATE`` was taken
for its staleness limit, and then one or two refused frames are part of the answer
(before 2026-11-30 they were left out, and the why said *the last frame heard ... held
no state*)."""


def refusals(counts: tuple[int, ...], *, taken: bool) -> tuple[tuple[str, int], ...]:
    """The session's refused STATE counts as (reason, count) pairs, zeros left out; none
    below :data:`REFUSED_STATES_REPORTED` in all unless a ``STATE`` was ``taken`` in the
    session. (``taken`` only turns true as a frame is taken, which sets the counts to
    zero: a health cached on the counts stays right.)"""
    total = sum(counts)
    if not total or (total < REFUSED_STATES_REPORTED and not taken):
        return ()
    return tuple((why, n) for why, n in zip(STATE_REFUSALS, counts, strict=True) if n)


def health_of(
    s: SessionStats,
    faulted: tuple[int, ...],
    refused: tuple[int, ...],
    latch_kept: str,
    *,
    taken: bool,
) -> LinkHealth:
    """The health of a threaded session, from its locked snapshot ``s``."""
    return LinkHealth(
        connected=s.connected,
        last_heard_s=s.last_heard_s,
        rtt_s=s.rtt_s,
        loss_ratio=s.loss_ratio,
        crc_errors=s.crc_errors,
        retries=s.retries,
        failed=s.failed,
        duplicates=s.duplicates,
        estopped=s.estopped,
        estop_input=s.estop_input,
        bridge_resets=s.bridge_resets,
        bus_fault=s.bus_fault,
        faulted_boards=faulted,
        states_refused=refusals(refused, taken=taken),
        line_noise=s.line_noise,
        latch_kept=latch_kept,
    )
