"""A run whose link is lost mid-run ends as a link error (exit code 3, DESIGN.md).

The supervisor stops the robot on the lost link (its first cause), the primitive at
work fails on the safe state, and the run's result carries the link error, so the
command line exits 3 ("link or hardware error"), not 1, and a caller can tell a
lost link from a tree that failed. The simulator is served on TCP in real time and
stopped under the run, as when its process is killed.
"""

from __future__ import annotations

import threading
from pathlib import Path

import pirate_bt
from pirate_bt.errors import LinkError
from pirate_bt.robot import load_robot
from pirate_bt.sim import Simulator
from pirate_bt.sim.server import SimServer

STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"


def test_a_link_lost_mid_run_is_a_link_error_with_its_cause() -> None:
    with Simulator("straight", load_robot()) as sim:
        server = SimServer(sim)
        host, port = server.open_tcp(0)
        server.start()
        stopper = threading.Timer(1.5, server.stop)  # mid-run: the halves are clamping
        stopper.start()
        try:
            result = pirate_bt.run_tree(
                STRAIGHT,
                port=f"socket://{host}:{port}",
                params={"distance": "1 m"},
                max_time="30 s",
            )
        finally:
            stopper.cancel()
            server.stop()
    assert result.status == "failure"
    assert result.safe_state
    # a read or a write notices first, as the timing goes; on a loaded machine the
    # silence can be noticed first (the readings stale before the closed socket is
    # read, seen once in a fresh clone's suite): a link error too, exit 3
    assert result.why.startswith(
        ("link lost: ", "link error while sending: ", "link_silent: nothing heard")
    ), result.why
    assert isinstance(result.error, LinkError)
    assert result.exit_code == 3
    assert result.sim_time_s < 10  # stopped on the loss, not at the time limit


def test_a_link_fallen_silent_is_a_link_error_not_stale_sensors() -> None:
    # nothing in, nothing out: the safety readings go stale after 0.15 s, long before
    # max_link_silence; the cause is the silence (exit 3), not the sensors (exit 1)
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"}, faults="link_loss@3s")
    assert result.safe_state
    assert result.why.startswith("link_silent: nothing heard from the bridge for 0.150 s")
    assert "readings are stale: bend_1_angle" in result.why
    assert isinstance(result.error, LinkError)
    assert result.exit_code == 3


def test_readings_stale_while_frames_arrive_are_stale_data() -> None:
    # a board rebooting: the bridge goes on sending frames, its channels not fresh
    result = pirate_bt.simulate_tree(
        STRAIGHT, params={"distance": "1 m"}, faults="board_reset:22@5s"
    )
    assert result.safe_state
    assert result.why.startswith("stale data: bend_1_angle")
    assert result.error is None
    assert result.exit_code == 1


def test_the_command_line_exits_3_on_a_silent_link() -> None:
    import subprocess
    import sys

    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "pirate_bt",
            "run",
            str(STRAIGHT),
            "--param",
            "distance=1m",
            "--sim",
            "straight",
            "--faults",
            "link_loss@3s",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert run.returncode == 3, run.stderr
    assert "link_silent: nothing heard from the bridge" in run.stdout + run.stderr
