"""A drive left turning by a program that stopped calling in is stopped by the bridge.

On a wall clock the link's reader thread feeds the bridge's watchdog whatever the
program does, so that a planner thinking between two steps trips nothing
(tests/test_sim_server.py). A tree whose tick blocked with a drive set to turn left
the robot driving: a 3 s sleep beside an 80 mm/s drive, every wheel still at 80 mm/s
(this session's probe of planners' behaviours). The reader thread now feeds the
watchdog on its own for ``HOST_SILENCE_S`` only while a drive is set to turn
(pirate_bt/link/deadman.py); then the bridge's watchdog stops the drives.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from pirate_bt.clock import WallClock
from pirate_bt.link import open_link
from pirate_bt.link.deadman import HOST_SILENCE_S
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.sim import Simulator
from pirate_bt.sim.server import SimServer

pytestmark = pytest.mark.xdist_group("real-time")  # the wall clock: a bridge's watchdog

ROBOT = load_robot()
DRIVE = ROBOT.drive_motors()[0].name


@contextmanager
def _host_on_tcp(sim: Simulator) -> Iterator[Any]:
    server = SimServer(sim)
    host, port = server.open_tcp(0)
    server.start()
    try:
        link = open_link(f"socket://{host}:{port}", ROBOT, WallClock())
        try:
            yield link
        finally:
            link.close()
    finally:
        server.stop()


def _turning(sim: Simulator) -> float:
    return max(abs(m.velocity_mps) for m in sim.model._drives)


def test_a_program_silent_with_a_drive_turning_has_the_drive_stopped_by_the_bridge() -> None:
    with Simulator("straight", ROBOT) as sim, _host_on_tcp(sim) as link:
        link.send_and_wait([MotorCommand(DRIVE, ControlMode.VELOCITY, 0.05)])
        time.sleep(0.3)
        link.poll()
        assert _turning(sim) > 0.04  # the drive turns
        before = sim.counters().watchdog_trips
        time.sleep(HOST_SILENCE_S + 0.8)  # the program blocked: no poll, no send
        assert sim.counters().watchdog_trips == before + 1
        assert _turning(sim) == 0.0  # the bridge's stop category stopped it
        link.poll()  # called in again: the link goes on, the drive stays stopped
        assert link.health().connected


def test_a_program_that_calls_in_keeps_its_drive_turning() -> None:
    with Simulator("straight", ROBOT) as sim, _host_on_tcp(sim) as link:
        link.send_and_wait([MotorCommand(DRIVE, ControlMode.VELOCITY, 0.05)])
        before = sim.counters().watchdog_trips
        deadline = time.monotonic() + HOST_SILENCE_S + 0.8
        while time.monotonic() < deadline:  # a run's ticks: a poll every 50 ms
            link.poll()
            time.sleep(0.05)
        assert sim.counters().watchdog_trips == before
        assert _turning(sim) > 0.04


def test_a_program_silent_with_every_drive_stopped_trips_nothing() -> None:
    # the planner thinking between two steps, the robot at rest: fed as before
    with Simulator("straight", ROBOT) as sim, _host_on_tcp(sim) as link:
        link.send_and_wait([MotorCommand(DRIVE, ControlMode.VELOCITY, 0.05)])
        link.send_and_wait([MotorCommand(DRIVE, ControlMode.VELOCITY, 0.0)])
        before = sim.counters().watchdog_trips
        time.sleep(HOST_SILENCE_S + 0.8)
        assert sim.counters().watchdog_trips == before
