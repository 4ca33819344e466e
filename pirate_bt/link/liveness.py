"""When the session's link is lost (a mixin of :class:`~pirate_bt.link.session.Session`).

Nothing valid heard for the link timeout, or every frame heard for that long reporting
the bridge's watchdog tripped while the host kept sending (it hears nothing from the
host); and what the lost link's error says: silence, or the bytes that came and made no
good frame (docs/protocol.md, Timing and Bad frames). Split out of
:mod:`pirate_bt.link.session` with behaviour unchanged.
"""

from __future__ import annotations

import logging
from typing import NoReturn

from pirate_bt.errors import LinkError, LinkLost
from pirate_bt.link.codec import BridgeFlags
from pirate_bt.link.requests import Request, SessionConfig
from pirate_bt.robot.port import unheard_text

__all__ = ["LivenessMixin"]

_log = logging.getLogger("pirate_bt.link.session")
_WATCHDOG = int(BridgeFlags.WATCHDOG)


class LivenessMixin:
    """Link loss and its words, for the session."""

    # set by the session
    config: SessionConfig
    _flags: BridgeFlags
    _hello: Request | None
    _feed_until_s: float
    _last_sent_s: float
    _last_heard_s: float
    _deaf_from_s: float
    _lost: bool
    _lost_why: str
    _closed: bool
    _protocol_error: LinkError | None

    # the rest of the session
    def _fail_all(self, now: float) -> None:
        raise NotImplementedError

    def line_noise(self) -> str:
        raise NotImplementedError

    def _check_heard(self, now: float) -> None:
        """Declare the link lost when the bridge has reported its watchdog tripped in every
        poll for over the link timeout while the host kept sending (not in a handshake, nor
        while the host sent nothing: no poll, or the dead man's handle holding back)."""
        cfg = self.config
        if (
            not int(self._flags) & _WATCHDOG
            or self._hello is not None
            or now >= self._feed_until_s
            or now - self._last_sent_s > 2 * cfg.heartbeat_period_s
        ):
            self._deaf_from_s = now
        elif now - self._deaf_from_s > self.config.link_timeout_s:
            self._lost = True
            self._lost_why = (
                f"the bridge reports its watchdog tripped for over {self.config.link_timeout_s}"
                " s: it hears nothing from the host (the line toward the bridge is down?)"
            )
            _log.error("link lost: %s", self._lost_why)
            self._fail_all(now)
            raise LinkLost(self._lost_why)

    def _check_alive(self) -> None:
        if self._lost:
            raise LinkLost(self._lost_why or self._unheard(f"over {self.config.link_timeout_s}"))
        if self._closed:
            raise LinkError("session closed")
        if self._protocol_error is not None:
            raise self._protocol_error

    def _lose(self, now: float) -> NoReturn:
        """Declare the link lost (nothing valid heard for the link timeout) and fail all."""
        self._lost = True
        silent = now - self._last_heard_s
        why = self._unheard(f"{silent:.3f}")
        if why.startswith("nothing"):
            _log.error("link lost: bridge silent for %.3f s", silent)
        else:
            _log.error("link lost: %s", why)
        self._fail_all(now)
        raise LinkLost(why)

    def _unheard(self, how_long: str) -> str:
        """Why the link is lost, for ``how_long`` seconds: silence, or bytes that made no
        good frame (named, so that a flooded line is not taken for a silent bridge)."""
        return unheard_text(how_long, self.line_noise())
