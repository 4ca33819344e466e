"""Probe 15 of the protective hold: steep and vertical pipes under faults.

A robot set down free in a steep pipe is left to its tree's first clamp: the hold does
not clamp for it while the run goes on. When the run ended before that clamp held (the
rear half's board reset or in fault, a rear joint stalled), nothing clamped it at all:
the run handed back a robot held by nothing on a 45° slope, the simulator's truth
``sliding``. The end of a run clamps it now, and tilts the front module clear first
when it is in the front half's way (it is, until the tree's first steps move it).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Reason, Supervisor
from pirate_bt.safety.commands import MoveFrontClear
from pirate_bt.safety.supervisor_hold import half_channels
from pirate_bt.safety.testing import FakePort
from pirate_bt.sim import Simulator

ROBOT = load_robot()
DROP = Path(__file__).parent / "data" / "networks" / "drop.yaml"


def _hold_verdicts(sup: Supervisor) -> list[str]:
    return [v.detail for v in sup.verdicts if v.reason is Reason.STEEP_PIPE_UNCLAMPED]


def test_a_robot_never_held_is_clamped_when_the_run_ends() -> None:
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.set_pitch(math.radians(45))
    port.set_tilt(0.0)  # the front module in the front half's way, as set down
    sup = Supervisor(port, clock)
    sup.tick()
    # while the run goes on, the tree's first clamp is on its way: no protective clamp
    assert not _hold_verdicts(sup) and not port.sent
    assert not sup.come_to_rest()  # was: True at once, nothing clamped, nothing waited for
    said = _hold_verdicts(sup)
    assert any(d.endswith("the supervisor clamps the rear half") for d in said), said
    assert any(d.endswith("the front module tilts clear first") for d in said), said
    tilt = ROBOT.motor_of(ROBOT.modules[0].name, pirate_bt.robot.MotorFunction.TILT).name
    assert any(c.motor == tilt and c.value > 0 for c in port.sent)
    assert sup.holding


def test_the_front_half_clamps_once_its_module_is_clear_when_the_rear_cannot() -> None:
    # the rear half's board is away (its readings stale): only the front half can hold
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock, physics=True)
    port.set_pitch(math.radians(45))
    port.set_tilt(0.0)
    sup = Supervisor(port, clock)
    sup.tick()
    port.freeze(*half_channels(ROBOT)[Half.REAR])
    clock.advance(0.2)
    sup.tick()
    assert not _hold_verdicts(sup)  # the run goes on: still the tree's to clamp
    sup.end_safe("end of run")
    assert port.half_clamped(Half.FRONT), _hold_verdicts(sup)
    assert abs(port.values[port.tilt_channel or ""]) >= ROBOT.clamp.front_clear_angle
    assert not sup.holding and not port.violations.events
    assert any(isinstance(v.command, MoveFrontClear) for v in sup.verdicts)


@pytest.mark.parametrize(
    "fault", ["board_reset:26@0.1s", "board_fault:26@0.1s", "motor_stall:bend_3_joint@0.1s"]
)
def test_a_run_that_fails_before_its_first_clamp_on_a_slope_hands_back_a_held_robot(
    fault: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[Any] = []
    close = Simulator.close

    def closing(self: Simulator) -> None:
        if not seen:
            seen.append(self.truth())
        close(self)

    monkeypatch.setattr(Simulator, "close", closing)
    network = tmp_path / "slope45.yaml"
    network.write_text(
        "schema_version: 1\nname: slope45\ndiameter: 63 mm\nslope: 45 deg\nsegments:\n"
        "  - {id: a, type: straight, length: 3 m}\n",
        encoding="utf-8",
    )
    result = pirate_bt.simulate_tree(
        "straight", network=network, params={"distance": "1 m"}, faults=fault
    )
    assert result.status == "failure"
    truth = seen[0]
    # was: sliding, neither half clamped, on a 45° slope
    assert not truth.sliding and truth.velocity_mps == 0.0
    assert truth.halves["front"].clamped


def test_a_robot_held_on_the_level_that_reaches_a_steep_pipe_unheld_is_clamped() -> None:
    # The rear half alone held the robot going down into a drop and lost its hold as
    # the pitch crossed the limit: the first steep tick saw no half holding. The hold
    # counted a robot as held only on a steep tick, so it took it for one set down free
    # and left it to slide (the drive's grip check failed it 0.05 m later).
    clock = SimClock(100.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    sup = Supervisor(port, clock)
    sup.tick()  # level, held by the rear half
    port.free_half(Half.REAR, angle_rad=ROBOT.clamp.contact_angle(0.063))  # stalled: 0 N
    port.set_pitch(math.radians(-13))
    clock.advance(0.05)
    sup.tick()
    said = _hold_verdicts(sup)
    assert any(d.endswith("the supervisor clamps the rear half") for d in said), said
    assert sup.holding and sup.safe_state_reason is not None
    assert sup.safe_state_reason.startswith("steep_pipe_unclamped")


def test_a_stall_as_the_drop_begins_is_caught_by_the_hold(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[Any] = []
    close = Simulator.close

    def closing(self: Simulator) -> None:
        if not seen:
            seen.append(self.counters())
        close(self)

    monkeypatch.setattr(Simulator, "close", closing)
    route = tmp_path / "drop.route"
    route.write_text(
        "network drop\nat the bend turn down\nat the bend turn up\ninspect 0.5 m\n",
        encoding="utf-8",
    )
    result = pirate_bt.simulate_mission(
        route, network=DROP, faults="motor_stall:bend_3_joint@20.2s"
    )
    # was: "grip lost: no half holds the robot: bend_3 presses 0.0 N ...", after a
    # slide of 0.326 m (and before the end-of-run hold, on and on)
    assert result.why.startswith("steep_pipe_unclamped"), result.why
    assert seen[0].slide_m < 0.3
