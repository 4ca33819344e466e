"""The simulator in real time on TCP and on a pty, with the host's link unchanged."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from pirate_bt.clock import WallClock
from pirate_bt.link import open_link
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.sim import Simulator
from pirate_bt.sim.server import SimServer

ROBOT = load_robot()


def exercise(url: str, sim: Simulator) -> None:
    """A joint command over ``url``: the joint gets there and the state keeps coming.

    Polls until both are seen (about 1 s; the 30 s bound is for a loaded machine only).
    """
    clock = WallClock()
    link = open_link(url, ROBOT, clock, reset_wait_s=0.0)

    def there() -> bool:
        state = link.state()
        return state is not None and abs(state.joint_angle_rad["bend_3"] - 0.4) < 0.01

    try:
        link.send([MotorCommand("bend_3_joint", ControlMode.POSITION, 0.4)])
        deadline = time.monotonic() + 30.0
        while not (there() and sim.counters().state_frames_sent > 50):
            assert time.monotonic() < deadline, (link.state(), sim.counters())
            link.poll()
            time.sleep(0.005)
    finally:
        link.close()
    counters = sim.counters()
    assert counters.commands_executed >= 1
    assert counters.state_frames_sent > 50


def test_tcp_server_serves_a_host_link() -> None:
    with Simulator("straight", ROBOT) as sim:
        server = SimServer(sim)
        host, port = server.open_tcp(0)
        assert host == "127.0.0.1"
        server.start()
        try:
            exercise(f"socket://{host}:{port}", sim)
        finally:
            server.stop()


def test_pty_server_serves_a_host_link() -> None:
    with Simulator("straight", ROBOT) as sim:
        server = SimServer(sim)
        device = server.open_pty()
        assert device.startswith("/dev/")
        server.start()
        try:
            exercise(device, sim)
        finally:
            server.stop()


def test_cli_prints_where_to_connect() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "sim", "straight", "--tcp", "0", "--duration", "0.3"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("socket://127.0.0.1:")
    assert "simulated" in proc.stderr
    bad = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "sim", "--fault", "meteor@1s", "--duration", "0.1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert bad.returncode == 2
    assert "unknown fault kind" in bad.stderr


@contextmanager
def _host_on_tcp(sim: Simulator) -> Iterator[tuple[str, int, Any]]:
    """The simulator served on TCP and a host's link to it: (host, port, link)."""
    server = SimServer(sim)
    host, port = server.open_tcp(0)
    server.start()
    try:
        link = open_link(f"socket://{host}:{port}", ROBOT, WallClock())
        try:
            yield host, port, link
        finally:
            link.close()
    finally:
        server.stop()


def test_a_host_on_tcp_keeps_the_bridge_s_watchdog_fed_while_the_program_idles() -> None:
    # socket:// is a bridge behind a serial-over-TCP adapter, or this simulator: the
    # link's reader thread heartbeats while the program does not call in (it did only
    # for device paths, and a second of planner code thinking tripped the watchdog)
    with Simulator("straight", ROBOT) as sim, _host_on_tcp(sim):
        before = sim.counters().watchdog_trips
        time.sleep(1.0)  # the program idles: no poll, no send
        assert sim.counters().watchdog_trips == before


def test_a_second_host_on_tcp_is_disconnected_and_the_first_goes_on() -> None:
    import socket

    with Simulator("straight", ROBOT) as sim, _host_on_tcp(sim) as (host, port, link):
        with socket.create_connection((host, port), timeout=5.0) as second:
            # closed at once (it waited in the backlog, hearing nothing)
            assert second.recv(4096) == b""
        frames = sim.counters().state_frames_sent
        deadline = time.monotonic() + 30.0
        while sim.counters().state_frames_sent < frames + 20:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        assert link.state() is not None and link.health().connected
