"""The built-in simulator: PIRATE in a pipe network, behind the real wire protocol."""

from __future__ import annotations

from pirate_bt.sim.counters import EventKind, SimCounters, SimEvent
from pirate_bt.sim.model import HalfTruth, PipeRobotModel, SensorNoise, SimTruth

__all__ = [
    "EventKind",
    "HalfTruth",
    "PipeRobotModel",
    "SensorNoise",
    "SimCounters",
    "SimEvent",
    "SimTruth",
]
