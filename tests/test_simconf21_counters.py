"""The simulated bridge's per-board RS485 counters, as the firmware bridge counts them.

docs/board-bus.md: a poll that gets no reply counts in the board's ``timeouts``; the
bridge then retries once (``retries`` +1) when the period has time for it, and the
retry's own timeout counts too. With board 22 away for 0.3 s the firmware bridge
reported 60 timeouts and 30 retries, the simulated bridge 29 timeouts and no retry.

The same scenario against both, through their bytes only (the conformance suite's
bridges): the firmware's C built for this machine and the simulated bridge in process,
each in virtual time. The board goes away mid-period, so both poll it the same number
of times.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from conformance.bridge import InProcessSimBridge, Wire
from conformance.test_conformance import counters, start_session
from firmware_host import FirmwareHostBridge, build_host_library

from pirate_bt.link import Heartbeat
from pirate_bt.robot import load_robot

ROBOT = load_robot()
AWAY = 22


@pytest.fixture(scope="module")
def library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_host_library(tmp_path_factory.mktemp("simconf21-counters"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware cannot be built for the host")
        raise


@pytest.fixture
def firmware(library: Path, tmp_path: Path) -> Iterator[FirmwareHostBridge]:
    bridge = FirmwareHostBridge(ROBOT, library, tmp_path)
    try:
        yield bridge
    finally:
        bridge.close()


def board_counters(
    bridge: FirmwareHostBridge | InProcessSimBridge, away_s: float
) -> dict[int, tuple[int, int, int]]:
    """(timeouts, crc_errors, retries) of each board after board 22 was away ``away_s``."""
    wire = Wire(bridge)
    start_session(wire)
    wire.collect(0.005)  # mid-period
    bridge.disconnect_board(AWAY, away_s)
    for seq in range(100, 100 + round((away_s + 0.1) / 0.02)):
        wire.ask(Heartbeat(seq), timeout_s=0.02, expect=1)
    reply = counters(wire, 50)
    return {b.board: (b.timeouts, b.crc_errors, b.retries) for b in reply.boards}


@pytest.mark.parametrize("away_s", [0.3, 0.05])
def test_a_board_away_counts_its_timeouts_and_retries_as_the_firmware_does(
    firmware: FirmwareHostBridge, away_s: float
) -> None:
    expected = board_counters(firmware, away_s)
    polls = round(away_s / ROBOT.bridge.state_period)
    assert expected[AWAY] == (2 * polls, 0, polls)  # the firmware: a timeout, a retry's
    assert board_counters(InProcessSimBridge(ROBOT), away_s) == expected
