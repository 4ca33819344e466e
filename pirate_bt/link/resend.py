"""A setpoint table lost on every try is sent again, as a new ``BULK_SETPOINTS``.

A ``BULK_SETPOINTS`` carries the host's whole table of absolute setpoints, so applying
it twice changes nothing: one that went unanswered on all of its tries (lost on a lossy
line, "may or may not have been applied") can go again with a new seq, where any other
request's failure is reported. Until 2026-12-01 the link reported it, and the run
stopped: the T-joint PAB at ``drop=0.2,corrupt=0.05,dup=0.05`` (seed 17) ended *link
error while sending: ... BulkSetpoints seq 137 not acknowledged after 4 tries, though
the bridge's STATE frames still arrive (does it hear the host?)*, after its tree had
waited 8 s for a rotation whose setpoint the bridge never had, and one run in a thousand
of the docs' campaign did so.

The table goes again at most :data:`MAX_BULK_RESENDS` times in a row (a row ends when a
``STATE``'s ``ack_seq`` reaches the table sent again): a bridge that never acknowledges a
bulk (one that does not hear the host, or does not follow docs/protocol.md) is still
reported, after that many more tries. While the bridge's ``STATE`` reports its
watchdog tripped it has heard nothing from the host (deaf, or every frame lost): the
table goes again only once a ``STATE`` shows it hears the host again, and a deaf
bridge's bulk is reported at the next send, as before (the link is lost after
``link_timeout_s`` of such reports). One that answered meanwhile requests the host never
made does not follow the protocol: its bulk is reported, as before.
"""

from __future__ import annotations

import logging

from pirate_bt.link.framing import seq_newer
from pirate_bt.link.requests import Outcome, Request
from pirate_bt.link.session import Session

__all__ = ["MAX_BULK_RESENDS", "BulkResends"]

_log = logging.getLogger("pirate_bt.link")

MAX_BULK_RESENDS = 2
"""Times in a row a table lost on every try goes again (each with the request's tries):
three bulks of four tries all lost is about one in 17 million on a line losing a quarter
of the host's frames."""


class BulkResends:
    """Whether the newest bulk, failed unanswered, is to go again (:meth:`due`)."""

    def __init__(self) -> None:
        self.in_a_row = 0
        self._judged: Request | None = None  # the last bulk judged: judged once
        self._resent: Request | None = None  # the last table sent again

    def due(self, session: Session, bulk: Request | None) -> bool:
        """Whether ``bulk`` (the newest one sent) went unanswered on every try and its
        table should go again; if so its failure is taken out of the session's list
        (:meth:`~pirate_bt.link.session.Session.take_failures`): it is not reported."""
        if self._resent is not None and _applied(session, self._resent, bulk):
            self.in_a_row = 0
            self._resent = None
        if bulk is None or bulk is self._judged:
            return False
        if bulk.outcome is not Outcome.FAILED or bulk.tries == 0:
            return False  # answered, still tried, or never sent (a session ended)
        stats = session.stats()
        if stats.watchdog and stats.connected:
            # it heard nothing from the host for its watchdog period (a deaf bridge, or
            # every frame lost): judged again once a STATE shows it hears the host again
            return False
        self._judged = bulk
        if (
            self.in_a_row >= MAX_BULK_RESENDS
            or not stats.connected
            or stats.estopped
            or session.answers_unasked_since(bulk.first_sent_s)  # it answers, but not this
        ):
            return False
        if not session.forget_failure(bulk):
            return False  # already reported
        self.in_a_row += 1
        _log.warning(
            "%r: unanswered on every try (the line lost it?): the table goes again (%d of %d)",
            bulk,
            self.in_a_row,
            MAX_BULK_RESENDS,
        )
        return True

    def waiting(self, session: Session, bulk: Request | None) -> bool:
        """Whether ``bulk`` (the newest one sent) failed unanswered while the bridge's
        watchdog is tripped, so is judged only once a ``STATE`` shows it hears the host
        again (:meth:`due`): its failure is not yet to be reported."""
        if bulk is None or bulk is self._judged or bulk.outcome is not Outcome.FAILED:
            return False
        stats = session.stats()
        return stats.watchdog and stats.connected

    def sent(self, bulk: Request) -> None:
        """``bulk`` carries the table sent again."""
        self._resent = bulk


def _applied(session: Session, resent: Request, newest: Request | None) -> bool:
    """Whether the bridge applied ``resent`` or a later bulk: acknowledged, or the newest
    ``STATE``'s ``ack_seq`` from its seq to the ``newest`` bulk's (an ``ack_seq`` past
    what the host sent acknowledges nothing: a bridge that made it up does not end a
    row)."""
    if resent.outcome is Outcome.ACKED:
        return True
    latest = session.latest_state()
    if latest is None:
        return False
    ack = latest[0].ack_seq
    last = resent.seq if newest is None else newest.seq
    return (ack == resent.seq or seq_newer(ack, resent.seq)) and not seq_newer(ack, last)
