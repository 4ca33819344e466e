"""Probe 18b of the operator console and teleop, as an operator at the keys.

A refused key changed the setpoints it stepped: two 'w' refused while the tree was in
charge set the kept speed to 40 mm/s, and the takeover that followed drove the robot
off at it (the console re-sends the kept speed every tick in manual).
"""

from __future__ import annotations

import math

from pirate_bt.cli.teleop import TeleopSession
from pirate_bt.robot import load_robot
from pirate_bt.safety import Mode
from pirate_bt.safety.factory import open_supervisor


def _steps(session: TeleopSession, n: int) -> None:
    for _ in range(n):
        session.sup.clock.sleep(0.05)
        session.step()


def _keys(session: TeleopSession, keys: str, ticks: int = 1) -> None:
    for key in keys:
        session.press(key)
        _steps(session, ticks)


def test_a_drive_refused_before_a_takeover_does_not_drive_after_it() -> None:
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.AUTONOMOUS)
    session = TeleopSession(sup)
    try:
        _keys(session, "ww")  # refused twice: the tree is in charge
        assert session.velocity_mps == 0.0  # was 0.04
        _keys(session, "mr", ticks=30)  # take over, clamp the rear half
        assert sup.simulator is not None
        assert sup.simulator.truth().velocity_mps == 0.0  # drove off at 40 mm/s
        _keys(session, "w", ticks=20)  # one press now is one step
        assert session.velocity_mps == 0.02
    finally:
        sup.close()


def test_refused_rotate_presses_do_not_add_up() -> None:
    sup = open_supervisor(load_robot(), network="straight", seed=1, mode=Mode.AUTONOMOUS)
    session = TeleopSession(sup)
    try:
        _keys(session, "ddd][")  # all refused: the tree is in charge
        assert session.rotation_rad == 0.0 and session.bend_rad == 0.0
        _keys(session, "mr", ticks=30)  # take over, clamp the rear half
        _keys(session, "d")
        assert math.isclose(session.rotation_rad, math.radians(5))  # was 20°
    finally:
        sup.close()
