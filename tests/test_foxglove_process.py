"""The Foxglove server's process: the run never waits for it, and outlives it."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.interop.foxglove_live import FoxgloveServer, attach_foxglove

ROOT = Path(__file__).resolve().parent.parent


def test_a_server_process_that_dies_mid_run_switches_the_view_off_not_the_run(
    caplog: pytest.LogCaptureFixture,
) -> None:
    import pirate_bt
    from pirate_bt.trace import supervised_extras

    ticks: list[int] = []
    with FoxgloveServer(port=0) as server:

        def observe(runner: Any, connection: Any) -> None:
            sim = connection.simulator
            extras = supervised_extras(connection.supervisor, counters=sim.counters)
            attach_foxglove(runner, server, extras=extras)

            def kill_at_20(_info: Any) -> None:
                ticks.append(len(ticks) + 1)
                if len(ticks) == 20:
                    os.kill(server.pid, signal.SIGKILL)
                    # the server's reader thread notices its process's end on its own;
                    # on a busy machine the run had ended (and closed the server, after
                    # which a death is not said) before that thread ran
                    deadline = time.monotonic() + 10.0
                    while server.enabled and time.monotonic() < deadline:
                        time.sleep(0.005)

            runner.add_post_tick(kill_at_20)

        before = pirate_bt.simulate_tree(
            ROOT / "trees" / "straight.yaml", params={"distance": "0.2m"}, max_time="60 s"
        )
        result = pirate_bt.simulate_tree(
            ROOT / "trees" / "straight.yaml",
            params={"distance": "0.2m"},
            max_time="60 s",
            observe=observe,
        )
    assert result.status == "success"
    assert (result.ticks, result.sim_time_s) == (before.ticks, before.sim_time_s)
    assert not server.enabled
    assert server.failure is not None and "exit -9" in server.failure
    assert "Foxglove live view: its process" in caplog.text and "the run goes on" in caplog.text


def test_a_server_process_killed_as_the_run_ends_is_said_to_have_died() -> None:
    # its reader thread is told of the close first and says nothing after it: a view
    # killed in the run's last moments was closed as if it had been there to the end
    with FoxgloveServer(port=0) as server:
        os.kill(server.pid, signal.SIGKILL)
    assert not server.enabled
    assert server.failure is not None and "exit -9" in server.failure
