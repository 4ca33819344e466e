"""Probe 8 of the protective layer: the operator console's stop stays a stop.

The console keeps the operator's drive alive by sending it again every tick in manual,
and an operator's command in manual passes in the safe state. So its own safe-stop key
('p') was undone at the next tick (the robot drove on at 40 mm/s, in the safe state),
and after an e-stop that came from elsewhere (the bridge's button) was reset, the robot
drove off again at the speed set before it.
"""

from __future__ import annotations

from pirate_bt.cli.teleop import TeleopSession
from pirate_bt.robot import load_robot
from pirate_bt.safety.factory import open_supervisor


def _driving() -> tuple[TeleopSession, object]:
    sup = open_supervisor(load_robot(), network="straight", seed=1)
    session = TeleopSession(sup)
    for key in "mr":  # take over, clamp the rear half
        session.press(key)
    _steps(session, 30)
    for key in "ww":
        session.press(key)
        _steps(session, 2)
    _steps(session, 20)
    assert sup.simulator is not None and sup.simulator.truth().velocity_mps > 0.03
    return session, sup.simulator


def _steps(session: TeleopSession, n: int) -> None:
    for _ in range(n):
        session.sup.clock.sleep(0.05)
        session.step()


def test_the_safe_stop_key_stops_for_good() -> None:
    session, sim = _driving()
    try:
        session.press("p")
        _steps(session, 20)
        assert session.sup.in_safe_state
        assert sim.truth().velocity_mps == 0.0  # type: ignore[attr-defined]  # was 0.04
        assert session.velocity_mps == 0.0
    finally:
        session.sup.close()


def test_no_drive_resumes_after_an_estop_from_elsewhere_is_reset() -> None:
    session, sim = _driving()
    try:
        session.sup.estop("the bridge's button")
        _steps(session, 5)
        session.press("x")  # reset: manual again
        _steps(session, 20)
        assert sim.truth().velocity_mps == 0.0  # type: ignore[attr-defined]  # was 0.04
    finally:
        session.sup.close()
