"""Probe 8 of the protective layer: nothing public sends past the supervisor.

``Supervisor.port`` was the robot port itself, so planner code holding a connection
could write ``robot.supervisor.port.send([...])`` and reach the link past every check
(a clamp's release in a riser, a drive in the safe state). It is a read-only view now.
"""

from __future__ import annotations

import pytest

import pirate_bt
from pirate_bt.robot import ControlMode, MotorCommand


def test_the_supervisor_s_port_reads_but_never_commands() -> None:
    with pirate_bt.connect("straight") as robot:
        port = robot.supervisor.port
        port.poll()
        assert port.state() is not None and port.health().connected
        assert port.robot is robot.robot
        robot.supervisor.safe_state("test")
        for name in ("send", "estop", "reset_estop", "close", "session", "_port"):
            with pytest.raises(AttributeError, match="the supervisor's port is read-only"):
                getattr(port, name)
        stop = [MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)]
        with pytest.raises(AttributeError):
            port.send(stop)
        sim = robot.simulator
        assert sim is not None
        assert sim.model.setpoint("bend_1_drive").value == 0.0
