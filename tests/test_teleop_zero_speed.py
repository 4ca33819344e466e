"""The console's speed keys down to zero stop the robot, whatever the readings say.

Pressing ``w`` then ``s`` back to 0 sent ``Drive(0.0)``, a command judged on the
readings like any drive: while a board whose readings do not put the robot in the safe
state reboots (board 25, the rotation's), it was refused as ``stale_state`` and the
robot drove on at 20 mm/s. The speed keys now send ``Stop()`` (which always passes)
when the speed they set is 0.
"""

from __future__ import annotations

from pirate_bt.cli.teleop import TeleopSession
from pirate_bt.robot import load_robot
from pirate_bt.safety.factory import open_supervisor


def _steps(session: TeleopSession, n: int) -> None:
    for _ in range(n):
        session.sup.clock.sleep(0.05)
        session.step()


def test_the_speed_keys_down_to_zero_stop_while_a_board_reboots() -> None:
    sup = open_supervisor(load_robot(), network="straight", seed=1)
    session = TeleopSession(sup)
    try:
        for key in "mr":  # take over, clamp the rear half
            session.press(key)
        _steps(session, 30)
        session.press("w")
        _steps(session, 30)
        sim = sup.simulator
        assert sim is not None and sim.truth().velocity_mps > 0.015
        sim.schedule(f"board_reset:25@{sim.clock.now() + 0.01:.3f}s")
        _steps(session, 20)  # its readings stale by now
        session.press("s")  # back to 0
        _steps(session, 5)
        assert session.velocity_mps == 0.0
        assert sim.truth().velocity_mps == 0.0  # was 0.02: Drive(0) refused, stale
    finally:
        sup.close()
