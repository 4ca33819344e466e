"""The close's e-stop, waited for through the session's own protocol mismatch; an
e-stop the bridge did not take (:class:`EStopNotTaken`).

A session that found the bridge speaking another protocol (``ProtocolMismatch``: three
``STATE`` frames of another layout, an unknown ``ACK`` status for a request in flight,
a refused new session) raises that error from every wait. The e-stop a
:meth:`RobotLink.close <pirate_bt.link.robot_link.RobotLink.close>` sends then went out
but was never waited for: its ``ACK``, which reads the same whatever the layout, was
not read, and the close reported *the e-stop sent after it failed (...): the robot
may still be moving* for a bridge that had taken it (before 2026-11-30).
"""

from __future__ import annotations

import contextlib

from pirate_bt.errors import LinkError, ProtocolMismatch
from pirate_bt.link.requests import Outcome, Request
from pirate_bt.link.session import Session

__all__ = ["EStopNotTaken", "RequestsFailed", "estop_not_taken", "wait_for_estop"]


class EStopNotTaken(LinkError):
    """The bridge refused (``NACK``) or never answered an ``ESTOP`` on every try, or
    answered it ``STALE``, or acknowledged it, and its ``STATE`` frames show no latch:
    the robot was not stopped by it. A frame that fails the bridge's checks (a stray
    byte, a damaged length) is no command."""


class RequestsFailed(LinkError):
    """Requests the link sent were refused, answered ``STALE`` or never acknowledged (a
    setpoint table sent again as often as it goes and still lost): raised by the next
    ``send`` or, since 2026-12-01, the next ``poll`` (a supervisor's tick), whichever
    comes first."""


def estop_not_taken(request: Request) -> EStopNotTaken:
    """The error for the ``ESTOP`` ``request`` the bridge did not take, in one line."""
    tries = f"{request.tries} tr{'ies' if request.tries != 1 else 'y'}"
    if request.nack is not None:
        how = (
            f"refused it (NACK {request.nack.name}) on {'all ' * (request.tries > 1)}{tries}"
            " (a frame that fails the bridge's checks is no command)"
        )
    elif request.outcome is Outcome.ACKED:
        return EStopNotTaken(
            f"the bridge did not latch the e-stop (ESTOP seq {request.seq}): it acknowledged"
            " it (ACK APPLIED), but the STATEs it sent since show no latch (docs/protocol.md:"
            " an ESTOP latches at once)"
        )
    elif request.outcome is Outcome.STALE:
        how = "answered it STALE, not applied (an ESTOP latches whatever its seq)"
    else:
        how = f"did not answer it in {tries}"
    return EStopNotTaken(
        f"the bridge did not latch the e-stop (ESTOP seq {request.seq}): it {how}, and its"
        " STATEs show no latch"
    )


def wait_for_estop(session: Session, request: Request) -> Request:
    """:meth:`Session.wait` for the e-stop ``request``, reading the line on through a
    protocol mismatch for the session's retry budget.

    Raises:
        ProtocolMismatch: the session's, when the e-stop is still unanswered then.
        LinkError: the link was lost or failed meanwhile.
    """
    try:
        return session.wait(request)
    except ProtocolMismatch as mismatch:
        clock, config = session.clock, session.config
        deadline = clock.now() + config.give_up_s
        while not request.done:
            with contextlib.suppress(ProtocolMismatch):
                session.poll()  # reads and handles what came, then raises the mismatch
            now = clock.now()
            if request.done:
                break
            if now >= deadline:
                raise mismatch from None
            clock.sleep(min(config.poll_step_s, deadline - now))
        return request
