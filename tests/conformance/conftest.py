"""The ``bridge`` fixture: every bridge implementation the conformance suite runs against.

Add an implementation here (one entry in ``BRIDGES``): a factory that takes the
robot description and returns a :class:`~conformance.bridge.BridgeUnderTest`.
Four are registered: the reference bridge in process (``sim``) and on a pty
(``sim-pty``), the firmware's C built for this machine (``firmware-host``,
virtual time at the line's rate) and the AVR build in simavr on a pty in real
time (``firmware-simavr``, where the toolchain is installed).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from conformance.bridge import BridgeUnderTest, InProcessSimBridge, pty_sim_bridge
from conformance.simavr_bridge import SimavrBridge, available
from pirate_bt.robot import load_robot
from pirate_bt.robot.description import RobotDescription


def _firmware_host(robot: RobotDescription) -> BridgeUnderTest:
    """The firmware's own C (firmware/piratebay), built for this machine, in virtual time."""
    from firmware_host import FIRMWARE, FirmwareHostBridge, build_host_library

    tmp = Path(tempfile.mkdtemp(prefix="pirate-fw-"))
    try:
        # Inside this checkout (git-ignored), so make never mixes two checkouts' objects.
        library = build_host_library(FIRMWARE / "build" / "conformance-host")
    except RuntimeError as exc:
        pytest.skip(f"cannot build the firmware for the host: {exc}")
    return FirmwareHostBridge(robot, library, tmp)  # type: ignore[return-value]


BRIDGES: dict[str, Callable[[RobotDescription], BridgeUnderTest]] = {
    "sim": InProcessSimBridge,
    "sim-pty": pty_sim_bridge,
    "firmware-host": _firmware_host,
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
