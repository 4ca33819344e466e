"""What the simulator counts, so tests and traces can assert on physics and on the link.

:class:`SimCounters` is an immutable snapshot; the simulator keeps its own
mutable tally and hands out snapshots. Every event is also kept as a
:class:`SimEvent` with its simulated time, so a test can say not only *that* the
robot got stuck but *where* and *when*.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType

__all__ = ["EventKind", "SimCounters", "SimEvent"]

_EMPTY: Mapping[str, int] = MappingProxyType({})


class EventKind(StrEnum):
    """Kinds of simulator events."""

    VIOLATION = "violation"
    """A safety violation: ``sliding`` or ``uncontrolled_rotation``."""
    DAMAGE = "damage"
    """A damage event: ``over_torque:<motor>`` or ``front_pressed``."""
    STUCK = "stuck"
    """A half could not enter a turn (detail: ``<half>:<segment>``)."""
    SLIP = "slip"
    """The wheels turned but traction was too low to move the robot."""
    TEE = "tee"
    """The front half passed the middle of a tee (detail: ``<tee>:straight|branch``)."""
    FAULT = "fault"
    """An injected fault started or ended."""
    WATCHDOG = "watchdog"
    """The bridge watchdog tripped: drives stopped, clamps held."""
    BOARD_AWAY = "board_away"
    """The bridge had not heard a board for 100 ms (a ``board_reset``): drives stopped,
    clamps held."""


@dataclass(frozen=True, slots=True)
class SimEvent:
    """One event at simulated time ``time_s``."""

    time_s: float
    kind: EventKind
    detail: str


@dataclass(frozen=True)
class SimCounters:
    """Counters since the simulator started.

    Attributes:
        violations: Safety violations by kind (``sliding``, ``uncontrolled_rotation``).
        damage: Damage events by kind (``over_torque:<motor>``, ``front_pressed``).
        stuck_events: Times a half got stuck at a turn (each episode once).
        slip_events: Times the wheels started slipping (each episode once).
        distance_m: Distance travelled along the pipe, both directions counted.
        slide_m: Distance slid back while unclamped.
        frames_received: Intact frames decoded from the host.
        frames_rejected: Frames refused: bad CRC or framing, or NACKed requests.
        frames_dropped: Host frames lost to an injected link loss (a request for a board
            in ``board_reset`` is refused, ``NACK BUS_ERROR``: in ``frames_rejected``).
        commands_executed: Motor setpoints applied to the model.
        state_frames_sent: STATE frames sent to the host.
        watchdog_trips: Times the bridge watchdog stopped the drives.
    """

    violations: Mapping[str, int] = field(default_factory=lambda: _EMPTY)
    damage: Mapping[str, int] = field(default_factory=lambda: _EMPTY)
    stuck_events: int = 0
    slip_events: int = 0
    distance_m: float = 0.0
    slide_m: float = 0.0
    frames_received: int = 0
    frames_rejected: int = 0
    frames_dropped: int = 0
    commands_executed: int = 0
    state_frames_sent: int = 0
    watchdog_trips: int = 0

    @property
    def violation_count(self) -> int:
        return sum(self.violations.values())

    @property
    def damage_count(self) -> int:
        return sum(self.damage.values())
