"""The protective layer probed from docs/safety.md as hostile planner code would.

Each test pins a bug a user saw, fixed here.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.safety import Drive, Raw, Reason
from pirate_bt.safety.checks import CheckContext, Intent, Problem
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.safety.testing import FakePort


@pytest.fixture
def sup() -> Iterator[Supervisor]:
    supervisor = open_supervisor(network="straight")
    try:
        supervisor.tick()
        yield supervisor
    finally:
        supervisor.close()


# -- a command that answers the checks one value and the expansion another ---------------------


class _ShiftyDrive(Drive):
    """A `Drive` whose speed is a property: 0 for its first two reads, NaN after."""

    __slots__ = ()
    reads = 0

    @property  # type: ignore[misc]
    def velocity_mps(self) -> float:  # type: ignore[override]
        type(self).reads += 1
        return 0.0 if type(self).reads <= 2 else float("nan")


class _ShiftyMotor(MotorCommand):
    """A `MotorCommand` naming the front LEDs for its first two reads, a drive after."""

    __slots__ = ()
    reads = 0

    @property  # type: ignore[misc]
    def motor(self) -> str:  # type: ignore[override]
        type(self).reads += 1
        return "front_leds" if type(self).reads <= 2 else "bend_1_drive"


def test_a_command_is_read_once_and_what_was_checked_is_what_is_sent(sup: Supervisor) -> None:
    """A subclass of `Drive` whose speed read finite when the supervisor checked it for
    a number and NaN when it was expanded *passed*, every drive sent 0.12 m/s (its raw
    range's end, above the 0.1 m/s limit, from still, past the acceleration limit: a
    NaN is outside no bound). A `Raw` of a `MotorCommand` subclass naming the front LEDs
    to the checks and a drive motor after went out as full PWM on `bend_1_drive`, a mode
    no `Raw` of a drive motor may use. The command is now read once and rebuilt of plain
    values; the checks and the motors get that copy."""
    drive = object.__new__(_ShiftyDrive)
    verdict = sup.command(drive)
    assert {mc.value for mc in verdict.sent} <= {0.0}, verdict
    assert type(verdict.command) is Drive
    mc = object.__new__(_ShiftyMotor)
    object.__setattr__(mc, "mode", ControlMode.PWM)
    object.__setattr__(mc, "value", 0.5)
    verdict = sup.command(Raw(mc))
    assert [m.motor for m in verdict.sent] in ([], ["front_leds"]), verdict
    for _ in range(5):
        sup.clock.sleep(0.1)
        sup.tick()
    state = sup.state()
    assert state is not None
    assert max(abs(v) for v in state.drive_velocity_mps.values()) < 1e-3, state


# -- a check of yours that raises, as the supervisor clamps a robot in a steep pipe -------------


def test_a_check_that_raises_does_not_hold_back_the_protective_clamp() -> None:
    """A check added with `sup.add_check` written for drives (`intent.drive_mps < 0.05`,
    a `TypeError` on any other command) raised out of `tick()` when the robot's only
    holding half let go 30° up a pipe: the protective clamp was never sent, and the
    next tick raised again, the robot left sliding. The hold now passes over a check
    that cannot judge it (and logs it); a check that refuses still refuses."""
    clock = SimClock(100.0)
    port = FakePort(load_robot(), clock)
    port.clamp_half(Half.FRONT)
    port.set_pitch(math.radians(30))
    sup = Supervisor(port, clock)
    sup.tick()

    def slow_drives_only(ctx: CheckContext, intent: Intent) -> Problem | None:
        assert intent.drive_mps is not None  # written for drives: raises on a clamp
        return None

    sup.add_check(slow_drives_only)
    port.free_half(Half.FRONT)
    clock.advance(0.05)
    sup.tick()
    clamps = [v for v in sup.verdicts if v.reason is Reason.STEEP_PIPE_UNCLAMPED and v.sent]
    assert clamps and sup.holding, sup.verdicts[-3:]
