"""The ``bridge`` fixture: every bridge implementation the conformance suite runs against.

Add an implementation here (one entry in ``BRIDGES``): a factory that takes the
robot description and returns a :class:`~conformance.bridge.BridgeUnderTest`.
The firmware in simavr, on a pty in real time, plugs in the same way: start its
harness, then return ``PtyBridge("simavr", robot, harness_pty_path, reset=...,
close=...)`` (``conformance.bridge.PtyBridge``).
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from conformance.bridge import BridgeUnderTest, InProcessSimBridge, pty_sim_bridge
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
