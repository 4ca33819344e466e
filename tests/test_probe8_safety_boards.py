"""Probe 8 of the protective layer: a command for a board that is not answering.

The supervisor checks the freshness of the readings a decision rests on (joints,
springs, the IMU's pitch); the rotational board (25: the rotate motor and a drive)
carries none of them. A drive sent while it rebooted went past the supervisor to the
link, which refuses a command for a board away for good, and the run ended on a link
error (exit 3), where a board away ends a run on stale data (exit 1, docs/safety.md).
"""

from __future__ import annotations

from pathlib import Path

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Clamp, Drive, Reason, Supervisor
from pirate_bt.safety.testing import FakePort

ROOT = Path(__file__).parents[1]
ROBOT = load_robot()


def test_a_drive_for_a_board_whose_readings_are_all_stale_is_refused_as_stale() -> None:
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    port.clamp_half(Half.FRONT)
    sup = Supervisor(port, clock)
    board: dict[int, list[str]] = {c.board: [] for c in ROBOT.state_channels()}
    for c in ROBOT.state_channels():
        board[c.board].append(c.name)
    port.freeze(*board[25][:1])  # one reading of it stale: the board still answers
    clock.advance(1.0)
    assert sup.command(Drive(0.01)).ok
    port.freeze(*board[25])
    clock.advance(1.0)
    verdict = sup.command(Drive(0.02))
    assert verdict.refused and verdict.reason is Reason.STALE_STATE
    assert verdict.detail.startswith(
        "not answering the bridge (rebooting?): board 25 (rotate, rotational_drive_b):"
        " every reading is stale: rotation_angle (2.000 s), rotational_drive_b.velocity (1.000 s)"
    )
    assert sup.command(Clamp(Half.REAR, 0.7)).ok  # nothing for board 25 in it


def test_a_rotational_board_rebooting_in_the_riser_ends_on_stale_data() -> None:
    # the straight PAB up the riser starts its drive 0.25 s into board 25's reboot
    result = pirate_bt.simulate_mission(
        ROOT / "scenarios" / "riser.route", faults="board_reset:25@24s"
    )
    # was: exit 3, "link error while sending: board 25 is not answering the bridge"
    assert result.exit_code == 1 and result.run.error is None
    assert "stale_state: not answering the bridge (rebooting?): board 25" in result.why
    assert result.safe_state and result.counters.violations == 0
