"""The seam between the link and everything above it.

:class:`RobotPort` is what the protective layer (and only the protective layer)
holds: the latest :class:`~pirate_bt.robot.state.RobotState`, a way to send
:class:`~pirate_bt.robot.commands.MotorCommand` objects, the e-stop, and link
health as figures. ``pirate_bt.link`` implements it over a real or simulated
bridge; tests implement it with fakes. Everything crossing it is in SI units.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState

__all__ = ["LinkHealth", "RobotPort", "unheard_text"]


def unheard_text(how_long: str, line_noise: str) -> str:
    """The bridge unheard for ``how_long`` seconds (``"0.510"``, ``"over 0.5"``), for
    people: silence, or the bytes that came and made no good frame (``line_noise``), so
    that a flooded line is not taken for a silent bridge. The link's ``LinkLost`` and
    the supervisor's safe-state cause say it alike."""
    if line_noise:
        return f"no good frame from the bridge for {how_long} s: {line_noise}"
    return f"nothing heard from the bridge for {how_long} s"


@dataclass(frozen=True, slots=True)
class LinkHealth:
    """Link figures at one moment.

    Attributes:
        connected: The handshake succeeded and the link has not been declared lost.
        last_heard_s: Clock time of the last valid frame from the bridge (``-inf`` if never).
        rtt_s: Smoothed request/response round-trip time (``nan`` before the first ack).
        loss_ratio: Share of requests that needed a retry or failed, recent window.
        crc_errors: Frames rejected for a bad CRC or framing, since connect.
        retries: Requests sent again after an ack timeout, since connect.
        failed: Requests given up on after all retries, since connect.
        duplicates: Duplicate or out-of-date frames ignored, since connect.
        estopped: The bridge reports its e-stop latched.
        estop_input: The bridge reports its hardware e-stop input pressed, or that the
            input latched the e-stop (protocol 1.2; a 1.1 bridge never says so).
        bridge_resets: Bridge resets seen in the middle of the session (a bridge
            boots latched, and the host does not release that latch).
        bus_fault: The bridge reports ``BUS_FAULT``: no board answered its last whole
            RS485 poll cycle.
        faulted_boards: Ids of the boards whose latest status has ``FAULT`` (an
            H-bridge fault or over-current: the board cannot drive its motors).
        states_refused: ``STATE`` frames the link refused since the last one it took,
            as (reason, count) pairs (``("with a bad CRC", 12)``); before the session's
            first STATE was taken, empty while there are fewer than a few (a lossy
            line's damaged frames, made up for by the next); after it, every one.
        line_noise: What came from the bridge since its last good frame that made no
            good frame, for people (``"204 unreadable frames (cobs 153, oversize 51) in
            15963 bytes"``), so that a flooded line is not taken for a silent bridge;
            ``""`` when nothing came (or a port that cannot tell).
        latch_kept: Why the e-stop latch the bridge had when the link opened is still
            latched, for people (``"the release of its boot latch was refused (NACK
            NOT_READY) with board 22 reporting FAULT"``); ``""`` when the link
            released it, or found none.
    """

    connected: bool
    last_heard_s: float = -math.inf
    rtt_s: float = math.nan
    loss_ratio: float = 0.0
    crc_errors: int = 0
    retries: int = 0
    failed: int = 0
    duplicates: int = 0
    estopped: bool = False
    estop_input: bool = False
    bridge_resets: int = 0
    bus_fault: bool = False
    faulted_boards: tuple[int, ...] = ()
    states_refused: tuple[tuple[str, int], ...] = ()
    line_noise: str = ""
    latch_kept: str = ""

    def silent_for(self, now_s: float) -> float:
        """Seconds since the bridge was last heard."""
        return now_s - self.last_heard_s

    def silence_text(self, silent_s: float) -> str:
        """The bridge unheard for ``silent_s`` seconds, for people: *nothing heard from
        the bridge for 0.510 s*, or, when bytes came that made no good frame, *no good
        frame from the bridge for 0.510 s: 204 unreadable frames (...) in 15963 bytes*."""
        return unheard_text(f"{silent_s:.3f}", self.line_noise)

    def states_refused_text(self) -> str:
        """:attr:`states_refused` for people (``"STATE frames arrived but all 15 were
        refused (12 with a bad CRC, 3 out of sequence)"``), or ``""`` when none was."""
        total = sum(n for _, n in self.states_refused)
        counts = ", ".join(f"{n} {why}" for why, n in self.states_refused)
        if total == 1:
            return f"a STATE frame arrived but was refused ({counts})"
        if total == 2:
            return f"two STATE frames arrived but both were refused ({counts})"
        return f"STATE frames arrived but all {total} were refused ({counts})" if total else ""


@runtime_checkable
class RobotPort(Protocol):
    """A connected robot (real or simulated), seen in SI units."""

    @property
    def robot(self) -> RobotDescription:
        """The description the link was opened with."""
        ...

    def poll(self) -> None:
        """Process pending input and due retries/heartbeats without blocking.

        Raises:
            LinkLost: nothing valid heard for longer than the configured time.
        """
        ...

    def state(self) -> RobotState | None:
        """The latest state snapshot, or ``None`` before the first state frame."""
        ...

    def send(self, commands: Sequence[MotorCommand]) -> None:
        """Send setpoints (acked and retried by the link; idempotent on the bridge).

        Raises:
            LinkError: the link is lost or the commands could not be delivered.
        """
        ...

    def estop(self) -> None:
        """Send an e-stop ahead of every queue; never raises for a busy link."""
        ...

    def reset_estop(self) -> None:
        """Release a latched e-stop on the bridge (operator action)."""
        ...

    def health(self) -> LinkHealth:
        """Current link figures."""
        ...

    def close(self) -> None:
        """Stop drives if possible, then release the transport."""
        ...
