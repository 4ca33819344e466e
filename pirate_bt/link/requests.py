"""What a session tracks: its timing, its requests and their outcomes, its figures.

:class:`SessionConfig` derives every timeout from the robot's bridge settings
(``docs/protocol.md``, Timing); a :class:`Request` is one tracked host request and
ends in exactly one :class:`Outcome`; :class:`SessionStats` is a snapshot of the
session's figures.
"""

from __future__ import annotations

import enum
import logging
import math
from dataclasses import dataclass, replace

from pirate_bt.link.framing import (
    MAX_WIRE_BYTES,
    PROTOCOL_MINOR_MAX,
    frame_time_s,
)
from pirate_bt.link.messages import (
    AckStatus,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    Heartbeat,
    Hello,
    NackCode,
    Setpoint,
)
from pirate_bt.robot.description import RobotDescription

__all__ = [
    "HEARTBEATS_PER_WATCHDOG",
    "SESSION_RENEW_GAP",
    "Outcome",
    "Request",
    "SessionConfig",
    "SessionStats",
    "Tracked",
]

_log = logging.getLogger(__name__)

HEARTBEATS_PER_WATCHDOG = 10
"""Host heartbeat period = watchdog / this (docs/protocol.md, Timing)."""

Tracked = Setpoint | BulkSetpoints | Heartbeat | EStop | EStopReset | CountersRequest | Hello

SESSION_RENEW_GAP = 16384
"""The host starts a new session before its ordered counter runs this far ahead of the
last seq the bridge answered (docs/protocol.md, Sequence numbers)."""


@dataclass(frozen=True, slots=True)
class SessionConfig:
    """Timing of a session; :meth:`from_robot` derives it from the bridge settings.

    Attributes:
        ack_timeout_s: Wait for an ack before a retry.
        max_retries: Retries after the first try (so ``max_retries + 1`` tries in all).
        heartbeat_period_s: Send a heartbeat when no frame was sent for this long; keep
            it well below the bridge watchdog (default: a tenth of it), because every
            frame may be lost and the bridge trips when all frames of one watchdog
            period are.
        link_timeout_s: Declare the link lost when nothing valid was heard for this long.
        poll_step_s: Sleep between polls while a caller waits.
        loss_window: Requests over which the loss ratio is computed.
        protocol_minor: The protocol minor version the host asks for in HELLO: 2
            (default: to be told of the bridge's hardware e-stop input,
            ``BridgeFlags.ESTOP_INPUT``; docs/protocol.md, Versions) or 1.
            :func:`~pirate_bt.link.open_link` asks once more for 1.1 when a bridge
            refuses 1.2 (a 1.1 bridge), and the session then speaks 1.1.
    """

    ack_timeout_s: float = 0.06
    max_retries: int = 3
    heartbeat_period_s: float = 0.025
    link_timeout_s: float = 0.5
    poll_step_s: float = 0.001
    loss_window: int = 100
    protocol_minor: int = PROTOCOL_MINOR_MAX

    @classmethod
    def from_robot(cls, robot: RobotDescription, **overrides: float) -> SessionConfig:
        """Timing from the robot's bridge settings (see docs/protocol.md, Timing).

        Args:
            robot: The robot description.
            **overrides: Field values to use instead of the derived ones.

        Returns:
            The configuration.
        """
        bridge = robot.bridge
        ack = 2 * frame_time_s(MAX_WIRE_BYTES, bridge.baud) + bridge.state_period + 0.005
        base = cls(
            ack_timeout_s=ack,
            heartbeat_period_s=bridge.watchdog / HEARTBEATS_PER_WATCHDOG,
            link_timeout_s=max(0.5, 2 * bridge.watchdog),
        )
        return replace(base, **overrides)  # type: ignore[arg-type]

    def heeding(self, watchdog_ms: int) -> SessionConfig:
        """This timing, with heartbeats frequent enough for a bridge's own watchdog.

        The heartbeat period comes from the robot description, but a bridge built with
        a shorter watchdog (it reports it in ``HELLO_REPLY``) would trip between
        heartbeats; for such a bridge the period becomes its watchdog / 10. A longer
        or unreported (0) watchdog changes nothing.

        Args:
            watchdog_ms: The watchdog the bridge reported, in ms.

        Returns:
            This configuration, or a copy with the shorter heartbeat period.
        """
        period = watchdog_ms / 1000 / HEARTBEATS_PER_WATCHDOG
        # a relative margin: the same watchdog, once in ms and once in s, may differ
        # in the last bit
        if watchdog_ms <= 0 or period >= self.heartbeat_period_s * (1 - 1e-9):
            return self
        _log.warning(
            "the bridge's watchdog is %d ms: heartbeats every %.1f ms instead of %.1f ms",
            watchdog_ms,
            period * 1000,
            self.heartbeat_period_s * 1000,
        )
        return replace(self, heartbeat_period_s=period)

    def __post_init__(self) -> None:
        if not 1 <= self.protocol_minor <= PROTOCOL_MINOR_MAX:
            raise ValueError(
                f"protocol_minor {self.protocol_minor}: this host speaks 1.1 to "
                f"1.{PROTOCOL_MINOR_MAX}"
            )

    @property
    def give_up_s(self) -> float:
        """Longest time a request stays in flight before it fails."""
        return self.ack_timeout_s * (self.max_retries + 1)


class Outcome(enum.Enum):
    """How a request ended."""

    PENDING = "pending"
    ACKED = "acked"
    """The bridge acknowledged it (see :attr:`Request.ack_status`)."""
    NACKED = "nacked"
    """The bridge refused it (see :attr:`Request.nack`); it had no effect."""
    FAILED = "failed"
    """No ack after every retry; it may or may not have been applied, and at most once."""
    SUPERSEDED = "superseded"
    """A newer bulk setpoint (a superset of it) replaced it before it was acked."""
    STALE = "stale"
    """The bridge answered ``ACK STALE``: older than a request it handled, **not applied**."""
    CANCELLED = "cancelled"
    """An e-stop went out before it was acknowledged; the bridge will not apply it."""


class Request:
    """One tracked request and its fate. Read it; only the session changes it."""

    __slots__ = (
        "ack_status",
        "acked_at_s",
        "created_s",
        "first_sent_s",
        "marks",
        "msg",
        "nack",
        "outcome",
        "reply",
        "sent_at_s",
        "tries",
        "wire",
    )

    def __init__(self, msg: Tracked, created_s: float, wire: bytes | None = None) -> None:
        self.msg = msg
        self.wire = wire  # the frame's bytes, once encoded (every try sends the same)
        self.created_s = created_s
        self.sent_at_s = math.nan
        self.first_sent_s = math.nan
        # the session's unreadable frames, heartbeats sent and heartbeats answered at
        # the first send: what the line lost while this request was tried
        self.marks = (0, 0, 0)
        self.acked_at_s = math.nan
        self.tries = 0
        self.outcome = Outcome.PENDING
        self.ack_status: AckStatus | None = None
        self.nack: NackCode | None = None
        self.reply: Counters | None = None

    @property
    def seq(self) -> int:
        """The request's sequence number."""
        return self.msg.seq

    def next_try_s(self, ack_timeout_s: float) -> float:
        """When the next try (or the give-up) is due: the schedule is anchored at the first
        send, so a late poll does not push every later retry back (``nan``: not sent)."""
        return self.first_sent_s + self.tries * ack_timeout_s

    @property
    def done(self) -> bool:
        """The request has an outcome."""
        return self.outcome is not Outcome.PENDING

    def __repr__(self) -> str:
        return f"Request({type(self.msg).__name__} seq={self.seq} {self.outcome.value})"


@dataclass(frozen=True, slots=True)
class SessionStats:
    """Session figures at one moment (raw counts; ``RobotLink.health`` maps them).

    Attributes:
        connected: Not declared lost and not closed.
        last_heard_s: Clock time of the last valid frame (``-inf`` if never).
        rtt_s: Smoothed round-trip time of first-try acks (``nan`` before one).
        loss_ratio: Share of the recent requests that needed a retry or failed.
        crc_errors: Bad frames of every reason (oversize, cobs, short, crc, version,
            type, length, value), not only CRC mismatches.
        retries: Requests sent again.
        failed: Requests given up.
        duplicates: Duplicate or out-of-date frames ignored.
        superseded: Bulk setpoints replaced by a newer one before their ack.
        sent: Requests completed (any outcome).
        estopped: The bridge reports its e-stop latched.
        watchdog: The bridge reports its watchdog tripped.
        bridge_resets: Bridge resets seen in the middle of the session.
        sessions: Sessions started (the connect's included).
        stale: Requests the bridge answered ``STALE`` (not applied).
        cancelled: Requests cancelled by an e-stop.
        estop_input: The bridge reports its hardware e-stop input pressed, or that the
            input latched the e-stop (protocol 1.2 sessions only; always false in 1.1).
        bus_fault: The bridge reports ``BUS_FAULT``: its last whole RS485 poll cycle
            failed (no board answered).
        faulted: Positions, in the STATE frame's board order (ascending id), of the
            boards whose status has ``FAULT`` (an H-bridge fault or over-current) in
            the latest STATE.
        line_noise: What came since the last good frame that made no good frame
            (``Session.line_noise``; ``""``: nothing).
    """

    connected: bool
    last_heard_s: float
    rtt_s: float
    loss_ratio: float
    crc_errors: int
    retries: int
    failed: int
    duplicates: int
    superseded: int
    sent: int
    estopped: bool
    watchdog: bool
    bridge_resets: int = 0
    sessions: int = 1
    stale: int = 0
    cancelled: int = 0
    estop_input: bool = False
    bus_fault: bool = False
    faulted: tuple[int, ...] = ()
    line_noise: str = ""
