"""Events and counters of the simulated robot: violations, damage, the tally.

:class:`EventsMixin` is the event side of :class:`~pirate_bt.sim.model.PipeRobotModel`:
it appends :class:`~pirate_bt.sim.counters.SimEvent` entries, counts violations
and damage, and builds the physics :class:`~pirate_bt.sim.counters.SimCounters`.
A new physical rule reports through ``_violation``, ``_damage`` or ``_event``.
"""

from __future__ import annotations

import logging
from types import MappingProxyType

from pirate_bt.sim.counters import EventKind, SimCounters, SimEvent
from pirate_bt.sim.model_types import _Tally

__all__ = ["EventsMixin"]

_log = logging.getLogger("pirate_bt.sim.model")


class EventsMixin:
    """The event side of the robot model (mixed into ``PipeRobotModel``)."""

    # set by the model
    time_s: float
    events: list[SimEvent]
    _tally: _Tally

    def _event(self, kind: EventKind, detail: str) -> None:
        self.events.append(SimEvent(self.time_s, kind, detail))

    def _violation(self, kind: str, detail: str) -> None:
        self._tally.violations[kind] = self._tally.violations.get(kind, 0) + 1
        self._event(EventKind.VIOLATION, f"{kind}: {detail}")
        _log.warning("violation %s: %s", kind, detail)

    def _damage(self, kind: str, detail: str) -> None:
        self._tally.damage[kind] = self._tally.damage.get(kind, 0) + 1
        self._event(EventKind.DAMAGE, f"{kind}: {detail}")
        _log.warning("damage %s: %s", kind, detail)

    def record(self, kind: EventKind, detail: str) -> None:
        """Add an event from outside the physics (faults, watchdog)."""
        self._event(kind, detail)

    def counters(self) -> SimCounters:
        """The physics counters (the bridge adds the link counters)."""
        t = self._tally
        return SimCounters(
            violations=MappingProxyType(dict(t.violations)),
            damage=MappingProxyType(dict(t.damage)),
            stuck_events=t.stuck_events,
            slip_events=t.slip_events,
            distance_m=t.distance_m,
            slide_m=t.slide_m,
        )
