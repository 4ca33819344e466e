"""A supervisor on a fake port, the rear half clamped: the protective layer's test rig.

Shared by the safety probes' test modules (``from safety_rig import rig``).
"""

from __future__ import annotations

from typing import Any

from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Supervisor
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


def rig(**options: Any) -> tuple[Supervisor, FakePort, SimClock]:
    """A :class:`Supervisor` (``options`` passed on) over a :class:`FakePort` of the
    default robot with its rear half clamped, on a simulated clock at 100 s."""
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    return Supervisor(port, clock, **options), port, clock
