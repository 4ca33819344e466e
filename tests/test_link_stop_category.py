"""The stop category (docs/protocol.md; issue 19, item 1): stops that do not drop the robot.

Halfway up a vertical riser, both halves clamped: an e-stop, a watchdog trip (the host
falls silent) and the supervisor's safe state each stop the robot where it is. The
simulator's truth (position, clamps) and its counters (slide, violations) are checked
over several seconds of virtual time after each stop. A rotate joint in torque mode
stops turning on an e-stop.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.pipes import Network, load_network
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, Motor
from pirate_bt.safety.commands import Clamp, Command, MoveFrontClear
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.safety.verdict import Outcome
from pirate_bt.sim import Simulator

ROBOT = load_robot()
TICK_S = 0.05
_riser = load_network("riser")
HALFWAY_UP = Network(
    _riser.spec.model_copy(
        update={"start": _riser.spec.start.model_copy(update={"position": 2.6})}
    ),
    "riser (start 2.6 m)",
)


def run(sup: Supervisor, seconds: float) -> None:
    for _ in range(round(seconds / TICK_S)):
        sup.clock.sleep(TICK_S)
        sup.tick()


def until(sup: Supervisor, command: Command, done: Callable[[], bool]) -> None:
    """Send ``command`` every tick (as a primitive does) until ``done``, at most 3 s."""
    deadline = sup.clock.now() + 3.0
    while not done():
        assert sup.clock.now() < deadline
        assert sup.command(command).outcome in (Outcome.PASS, Outcome.CLIP)
        sup.clock.sleep(TICK_S)
        sup.tick()


def clamped_half(sup: Supervisor, half: Half) -> Callable[[], bool]:
    return lambda: sup.half_states()[half].value == "clamped"


@pytest.fixture
def clamped() -> Iterator[Supervisor]:
    """The robot halfway up the riser with both halves clamped."""
    sup = open_supervisor(ROBOT, network=HALFWAY_UP, seed=2)
    try:
        clear = ROBOT.clamp.front_clear_angle
        until(sup, Clamp(Half.REAR, 0.6), clamped_half(sup, Half.REAR))
        until(sup, MoveFrontClear(), lambda: abs(_tilt(sup)) >= clear)
        until(sup, Clamp(Half.FRONT, 0.6), clamped_half(sup, Half.FRONT))
        run(sup, 0.5)
        sim = sup.simulator
        assert sim is not None
        truth = sim.truth()
        assert truth.halves[Half.FRONT].clamped and truth.halves[Half.REAR].clamped
        assert truth.slope_rad == pytest.approx(1.5708, abs=0.01)  # vertical
        yield sup
    finally:
        sup.close()


def holds(sup: Supervisor, seconds: float, *, poll: bool = True) -> None:
    """The robot does not move and nothing is violated over ``seconds``."""
    sim = sup.simulator
    assert sim is not None
    before_m = sim.truth().front_m
    before = sim.counters()
    if poll:
        run(sup, seconds)
    else:
        sup.clock.sleep(seconds)  # the host is silent: nothing is polled or sent
    truth, after = sim.truth(), sim.counters()
    assert truth.front_m == pytest.approx(before_m, abs=1e-4)
    assert truth.halves[Half.FRONT].clamped and truth.halves[Half.REAR].clamped
    assert after.slide_m == before.slide_m
    assert dict(after.violations) == dict(before.violations)
    assert dict(after.damage) == dict(before.damage)


def test_estop_keeps_the_clamps_in_a_riser(clamped: Supervisor) -> None:
    clamped.estop("test")
    holds(clamped, 5.0)
    assert clamped.port.health().estopped


def test_watchdog_trip_keeps_the_clamps_in_a_riser(clamped: Supervisor) -> None:
    sim = clamped.simulator
    assert sim is not None
    holds(clamped, 5.0, poll=False)
    assert sim.counters().watchdog_trips == 1


def test_safe_state_keeps_the_clamps_in_a_riser(clamped: Supervisor) -> None:
    clamped.safe_state("test")
    holds(clamped, 5.0)


def test_estop_stops_a_rotation_in_torque_mode() -> None:
    clock = SimClock()
    with Simulator("straight", ROBOT, clock=clock, seed=1) as sim:
        link = open_link(sim.url, ROBOT, clock)
        rear = [MotorCommand(m.name, ControlMode.TORQUE, 0.6) for m in _joints(Half.REAR)]
        link.send_and_wait(rear)
        clock.sleep(1.0)
        link.poll()
        rotate = ROBOT.rotational_module()
        motor = next(
            m.name
            for b in ROBOT.boards
            if b.module == rotate.name
            for m in b.motors
            if m.function == "rotate"
        )
        link.send_and_wait([MotorCommand(motor, ControlMode.TORQUE, 0.3)])
        clock.sleep(0.2)
        link.poll()
        turning = sim.truth().joint_angle_rad[motor]
        assert abs(turning) > 0.01  # it turns
        link.estop()
        clock.sleep(0.05)
        link.poll()
        stopped = sim.truth().joint_angle_rad[motor]
        clock.sleep(2.0)
        link.poll()
        assert sim.truth().joint_angle_rad[motor] == pytest.approx(stopped, abs=1e-9)
        assert sim.truth().halves[Half.REAR].clamped  # and the clamp holds
        link.close()


def _joints(half: Half) -> list[Motor]:
    names = {m.name for m in ROBOT.bend_modules(half)}
    return [m for b in ROBOT.boards if b.module in names for m in b.motors if m.function == "bend"]


def _tilt(sup: Supervisor) -> float:
    state = sup.state()
    tilt = state.front_tilt_rad if state is not None else None
    return tilt if tilt is not None else 0.0
