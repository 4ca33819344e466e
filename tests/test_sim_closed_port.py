"""A simulator closed under an open ``sim://`` port fails that port as a device
unplugged does: the run ends as a lost link that names the closed simulator. Its
bridge had gone on answering the host's writes (heartbeats acknowledged) with no
clock to move it, so a run saw a live link that sent no state."""

from __future__ import annotations

import pytest
import serial

import pirate_bt
from pirate_bt.sim import Simulator


def test_a_run_on_a_closed_simulator_is_a_lost_link_naming_it() -> None:
    with pirate_bt.connect("sim:straight") as robot:
        assert robot.simulator is not None
        robot.simulator.close()
        assert robot.simulator.closed
        result = robot.run("straight", params={"distance": "0.2 m"})
    assert result.status == "failure"
    assert result.exit_code == 3
    assert "link lost" in result.why and "was closed" in result.why, result.why


def test_a_port_to_a_closed_simulator_refuses_reads_and_writes() -> None:
    with Simulator("straight") as sim:
        port = serial.serial_for_url(f"sim://{sim.name}")
        port.write(b"\x00")  # open: taken
        sim.close()
        with pytest.raises(serial.SerialException, match="was closed"):
            port.write(b"\x00")
        with pytest.raises(serial.SerialException, match="was closed"):
            port.read(1)
        port.close()
