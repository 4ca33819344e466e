"""The ``bridge`` fixture: every bridge implementation the conformance suite runs against.

Add an implementation here (one entry in ``BRIDGES``): a factory that takes the
robot description and returns a :class:`~conformance.bridge.BridgeUnderTest`.
The firmware in simavr, on a pty in real time, plugs in the same way.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from conformance.bridge import BridgeUnderTest, InProcessSimBridge, PtySimBridge
from conformance.simavr_bridge import SimavrBridge, available
from pirate_bt.robot import load_robot
from pirate_bt.robot.description import RobotDescription

BRIDGES: dict[str, Callable[[RobotDescription], BridgeUnderTest]] = {
    "sim": InProcessSimBridge,
    "sim-pty": PtySimBridge,
}
if available() is None:  # the AVR build in simavr (firmware/simavr), where it can run
    BRIDGES["firmware-simavr"] = SimavrBridge


@pytest.fixture(params=sorted(BRIDGES))
def bridge(request: pytest.FixtureRequest) -> Iterator[BridgeUnderTest]:
    """A freshly booted bridge for the default robot."""
    under_test = BRIDGES[request.param](load_robot())
    try:
        yield under_test
    finally:
        under_test.close()


@pytest.fixture
def virtual_bridge(bridge: BridgeUnderTest) -> BridgeUnderTest:
    """The bridge, for tests that need hours of virtual time (skipped in real time)."""
    if not bridge.virtual_time:
        pytest.skip(f"{bridge.name} runs in real time only; this test needs virtual hours")
    return bridge
