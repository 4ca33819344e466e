"""A run live in Foxglove: a real WebSocket client subscribes and sees the robot and the tree."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from foxglove_ws import FoxgloveClient

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.interop.foxglove_live import FoxgloveServer, attach_foxglove, parse_address
from pirate_bt.interop.foxglove_topics import TOPICS

ROOT = Path(__file__).resolve().parent.parent
PIRATE_BT = str(Path(sys.executable).with_name("pirate-bt"))


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _connect(port: int, timeout_s: float = 20.0) -> FoxgloveClient:
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return FoxgloveClient("127.0.0.1", port)
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def _simulated_run(observe: Any, realtime: bool = True, distance: str = "0.05m") -> Any:
    """``pirate-bt run trees/straight.yaml`` in-process, with ``observe(runner, connection)``."""
    import pirate_bt

    return pirate_bt.simulate_tree(
        ROOT / "trees" / "straight.yaml",
        params={"distance": distance},
        max_time="60 s",
        realtime=realtime,
        observe=observe,
    )


def _observer(server: FoxgloveServer) -> Any:
    from pirate_bt.trace import supervised_extras

    def observe(runner: Any, connection: Any) -> None:
        sim = connection.simulator
        extras = supervised_extras(connection.supervisor, counters=sim.counters)
        attach_foxglove(runner, server, extras=extras)

    return observe


def test_client_sees_state_and_tree_while_the_run_goes_on() -> None:
    with FoxgloveServer(port=0) as server:
        client = _connect(server.port)
        assert client.subprotocol in ("foxglove.sdk.v1", "foxglove.websocket.v1")
        assert client.wait_for(lambda c: set(TOPICS) <= set(c.channels), 10)
        channel = client.channels["/pirate/state"]
        assert (channel["encoding"], channel["schemaEncoding"]) == ("json", "jsonschema")
        assert channel["schemaName"] == "pirate.RobotState"
        client.subscribe("/pirate/state", "/pirate/tree", "/pirate/run", "/pirate/end")
        assert client.wait_for(lambda _: server.subscriptions >= 4, 10)
        # py_trees sets signal handlers: the run stays in the main thread, the client reads
        # in another and notes when each message arrived.
        arrivals: list[tuple[str, float]] = []
        stop = threading.Event()

        def read() -> None:
            while not stop.is_set():
                before = len(client.messages)
                client.pump(0.05)
                now = time.monotonic()
                arrivals.extend((topic, now) for topic, _, _ in client.messages[before:])

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        result = _simulated_run(_observer(server))
        ended = time.monotonic()
        time.sleep(0.5)
        stop.set()
        reader.join(5)
        client.close()
    during = [topic for topic, when in arrivals if when < ended]
    assert during.count("/pirate/state") >= 3 and during.count("/pirate/tree") >= 2
    assert result.status == "success"
    state = client.of("/pirate/state")[-1]
    assert set(state["joint_angle_rad"]) >= {"bend_1", "bend_4"} and "speed_mps" in state
    tree = client.of("/pirate/tree")
    assert tree[0]["status"][0] == {
        "id": "0",
        "name": tree[0]["status"][0]["name"],
        "path": tree[0]["status"][0]["name"],
        "status": "RUNNING",
    }
    assert any(m["active"] for m in tree)
    assert client.of("/pirate/run")[0]["format"] == "pirate-bt-trace"
    assert client.of("/pirate/end")[0]["outcome"] == "success"
    times = [t for topic, t, _ in client.messages if topic == "/pirate/state"]
    assert times == sorted(times)


def test_late_subscriber_gets_the_run_and_a_tree_snapshot() -> None:
    with FoxgloveServer(port=0) as server:
        result = _simulated_run(_observer(server), realtime=False)
        assert result.status == "success"
        client = _connect(server.port)
        client.wait_for(lambda c: "/pirate/run" in c.channels, 10)
        client.subscribe("/pirate/run", "/pirate/tree", "/pirate/state")
        client.wait_for(lambda _: server.subscriptions >= 3, 10)
        # Latched topics are re-sent with the next record: a teleop-like tick here.
        server.publish_record({"type": "tick", "n": 10_000, "t_s": 1.0})
        assert client.wait_for(lambda c: c.of("/pirate/run") and c.of("/pirate/tree"), 10)
        client.close()
    snapshot = client.of("/pirate/tree")[0]
    assert snapshot["snapshot"] is True
    assert {e["status"] for e in snapshot["status"]} == {"SUCCESS"}


def test_a_client_that_vanishes_mid_run_does_not_hurt_the_run() -> None:
    port = _free_port()
    proc = subprocess.Popen(
        [
            PIRATE_BT,
            "run",
            "trees/straight.yaml",
            "--param",
            "distance=0.05m",
            "--realtime",
            "--quiet",
            "--foxglove",
            f"127.0.0.1:{port}",
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    client = _connect(port)
    client.wait_for(lambda c: "/pirate/state" in c.channels, 10)
    client.subscribe(*TOPICS)
    assert client.wait_for(lambda c: len(c.of("/pirate/state")) >= 2, 20)
    client.sock.close()  # gone without a goodbye, mid-run
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "SUCCESS" in out
    assert f"Foxglove live view on ws://127.0.0.1:{port}" in err


def _fast_run(slow_client: bool) -> tuple[Any, float, bool]:
    """The straight tree, as fast as it goes: ``(result, wall seconds, server enabled)``."""
    with FoxgloveServer(port=0, message_backlog_size=16) as server:
        client = None
        if slow_client:  # subscribes to everything, then never reads
            client = _connect(server.port)
            client.wait_for(lambda c: "/pirate/state" in c.channels, 10)
            client.subscribe(*TOPICS)
            client.wait_for(lambda _: server.subscriptions >= len(TOPICS), 10)
            client.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        started = time.monotonic()
        result = _simulated_run(_observer(server), realtime=False, distance="0.5m")
        took = time.monotonic() - started
        if client is not None:
            client.sock.close()
        return result, took, server.enabled


def test_a_slow_client_never_slows_the_tick() -> None:
    """A client that subscribes and never reads: the run is the same run, as fast as without.

    Compared with runs with no client on either side of it: the simulated run is tick for
    tick the same, and its wall time stays within twice the slower of them plus a second
    (a client that held the tick up would stall it for good or multiply it; what is
    left is the noise of a loaded machine).
    """
    before, before_s, _ = _fast_run(slow_client=False)
    result, slow_s, enabled = _fast_run(slow_client=True)
    after, after_s, _ = _fast_run(slow_client=False)
    assert result.status == before.status == after.status == "success"
    assert enabled  # the slow client did not switch the live view off
    assert (result.ticks, result.sim_time_s) == (before.ticks, before.sim_time_s)
    assert slow_s < 2 * max(before_s, after_s) + 1.0, (before_s, slow_s, after_s)


def test_a_publishing_error_switches_the_view_off_not_the_run(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The server runs in a process of its own: it is told to fail there.
    monkeypatch.setattr(FoxgloveServer, "_PROCESS_OPTIONS", {"fail_publishing": True})
    with FoxgloveServer(port=0) as server:
        result = _simulated_run(_observer(server), realtime=False)
        server.close()  # waits for the process, which said why it stopped publishing
    assert result.status == "success"
    assert not server.enabled
    assert "publishing failed" in caplog.text and "fails on purpose" in caplog.text


def test_port_taken_is_one_clear_line(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code = main(["run", "trees/straight.yaml", "--param", "distance=0.05m", "--quiet",
                     "--foxglove", f"127.0.0.1:{port}"])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and "the port is taken" in err[0] and str(port) in err[0]


def test_addresses() -> None:
    assert parse_address(None) == ("127.0.0.1", 8765)
    assert parse_address("0.0.0.0:9000") == ("0.0.0.0", 9000)
    assert parse_address("9001") == ("127.0.0.1", 9001)
    assert parse_address("[::1]:9002") == ("::1", 9002)
    assert parse_address("robot.local") == ("robot.local", 8765)
    with pytest.raises(InputError, match="port must be a number"):
        parse_address("127.0.0.1:99999")


def test_missing_sdk_is_one_clear_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("foxglove", "foxglove.websocket"):
        monkeypatch.setitem(sys.modules, name, None)  # import fails as if not installed
    code = main(["run", "trees/straight.yaml", "--param", "distance=0.05m", "--quiet",
                 "--foxglove"])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == [
        "pirate-bt: --foxglove needs the 'foxglove-sdk' package: pip install 'pirate-bt[foxglove]'"
    ]


def test_sim_and_teleop_serve_too() -> None:
    port = _free_port()
    proc = subprocess.Popen(
        [PIRATE_BT, "sim", "--tcp", "0", "--duration", "3", "--foxglove", f"127.0.0.1:{port}"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    client = _connect(port)
    client.wait_for(lambda c: "/pirate/sim" in c.channels, 10)
    client.subscribe("/pirate/sim")
    assert client.wait_for(lambda c: len(c.of("/pirate/sim")) >= 2, 10)
    client.close()
    proc.communicate(timeout=30)
    assert proc.returncode == 0
    assert {"front_m", "joint_angle_rad"} <= set(client.of("/pirate/sim")[-1]["truth"])
    # teleop --keys: the operator's verdicts and the state, one tick per key.
    port = _free_port()
    done = subprocess.run(
        [PIRATE_BT, "teleop", "--keys", "w" * 20, "--foxglove", f"127.0.0.1:{port}"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert f"ws://127.0.0.1:{port}" in done.stderr


def test_a_mission_serves_the_localiser_belief_live() -> None:
    """A mission's live view carries ``/pirate/localisation`` (belief and truth), from the
    runner of each leg of it, while it runs."""
    from pirate_bt import simulate_mission
    from pirate_bt.trace import supervised_extras

    with FoxgloveServer(port=0) as server:
        client = _connect(server.port)
        assert client.wait_for(lambda c: "/pirate/localisation" in c.channels, 10)
        client.subscribe("/pirate/localisation", "/pirate/state")
        assert client.wait_for(lambda _: server.subscriptions >= 2, 10)
        stop = threading.Event()

        def read() -> None:
            while not stop.is_set():
                client.pump(0.05)

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        runners: list[Any] = []

        def observe(runner: Any, localiser_values: Any) -> None:
            runners.append(runner)
            attach_foxglove(
                runner, server, extras=supervised_extras(_Quiet(), more=localiser_values)
            )

        result = simulate_mission(ROOT / "scenarios" / "straight.route", observe=observe)
        time.sleep(0.5)
        stop.set()
        reader.join(5)
        client.close()
    assert result.succeeded and len(runners) == 1
    beliefs = client.of("/pirate/localisation")
    assert len(beliefs) >= 3
    last = beliefs[-1]
    assert abs(last["belief_m"] - result.belief_m) < 1e-3
    assert abs(last["truth_m"] - result.truth_m) < 0.05


class _Quiet:
    """A supervisor stand-in with nothing to say (the test looks at the belief only)."""

    def add_listener(self, _listener: Any) -> None:
        return None

    def state(self) -> None:
        return None

    def health(self) -> None:
        return None
