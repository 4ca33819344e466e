"""The built-in simulator: PIRATE in a pipe network, behind the real wire protocol.

- :mod:`pirate_bt.sim.model`: the robot-in-pipe physics (DOMAIN.md's rules), SI units.
- :mod:`pirate_bt.sim.bridge`: the simulated PIRATEbay and PICO boards at the byte level.
- :mod:`pirate_bt.sim.simulator`: :class:`Simulator`, on a shared simulated clock,
  reachable in process as ``sim://NAME``.
- :mod:`pirate_bt.sim.server`: the same bridge on a pty or TCP port, in real time.
- :mod:`pirate_bt.sim.faults`: faults scheduled from a network file or text.

Importing this package registers the ``sim://`` scheme with pyserial.
See ``docs/simulator.md`` for the model, its conventions and its limits.
"""

from __future__ import annotations

from pirate_bt.sim.bridge import SimBridge
from pirate_bt.sim.counters import EventKind, SimCounters, SimEvent
from pirate_bt.sim.faults import FAULT_KINDS, format_fault, parse_fault
from pirate_bt.sim.model import HalfTruth, PipeRobotModel, SensorNoise, SimTruth
from pirate_bt.sim.simulator import SCHEME, Simulator, lookup

__all__ = [
    "FAULT_KINDS",
    "SCHEME",
    "EventKind",
    "HalfTruth",
    "PipeRobotModel",
    "SensorNoise",
    "SimBridge",
    "SimCounters",
    "SimEvent",
    "SimTruth",
    "Simulator",
    "format_fault",
    "lookup",
    "parse_fault",
]
