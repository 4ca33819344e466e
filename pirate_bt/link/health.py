"""The link's health (:class:`~pirate_bt.robot.port.LinkHealth`) from the session's
figures: which figures, and the refused ``STATE`` frames as (reason, count) pairs.

Split out of :mod:`pirate_bt.link.robot_link`, whose ``RobotLink.health`` uses them.
"""

from __future__ import annotations

from operator import attrgetter

from pirate_bt.link.inbound import STATE_REFUSALS
from pirate_bt.link.session import Session, SessionStats
from pirate_bt.robot.port import LinkHealth

__all__ = [
    "HEALTH_FIGURES",
    "REFUSED_STATES_REPORTED",
    "health_of",
    "lossy_text",
    "refusals",
]

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


def lossy_text(session: Session, marks: tuple[int, int, int]) -> str:
    """What the line lost since ``marks`` (a request's ``marks``: the session's
    unreadable frames, heartbeats sent and answered at its first send), said after a
    request not acknowledged on any try: ``""`` unless the bridge answered some of the
    host's heartbeats meanwhile (it hears the host) while others went unanswered or
    frames from it were unreadable. A request lost on every try of a lossy line is
    then named as loss, not as a bridge that may not hear the host."""
    garbled0, sent0, answered0 = marks
    sent = session.heartbeats_sent - sent0
    answered = session.heartbeats_answered - answered0
    garbled = session.crc_errors - garbled0
    if answered <= 0 or (answered >= sent and garbled <= 0):
        return ""
    lost = [f"{sent - answered} of the host's {sent} heartbeats went unanswered"]
    if answered >= sent:
        lost = []
    if garbled > 0:
        lost.append(f"{garbled} frame{'s' * (garbled != 1)} from the bridge were unreadable")
    return (
        f": the link loses frames (meanwhile {' and '.join(lost)}; the bridge answered"
        f" {answered}, so it hears the host): each try was lost on the line"
    )
