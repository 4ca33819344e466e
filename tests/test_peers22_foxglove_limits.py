"""The Foxglove server's process holds every client's connection: a client holding more
idle connections than the run's soft limit of open files leaves it listening, and the
next client (Foxglove) connects."""

from __future__ import annotations

import resource
import socket
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("foxglove", reason="the foxglove extra (foxglove-sdk) is not installed")

from tests.foxglove_ws import FoxgloveClient

# the real-time group (tests/conftest.py): live servers, answers awaited on the wall clock
pytestmark = pytest.mark.xdist_group("real-time")

IDLE_CONNECTIONS = 300

# A run's process whose soft limit of open files is 128 (its hard one as it was) serving
# Foxglove on port 0: the server's process starts under that limit.
_LIMITED = """
import resource, sys
from pirate_bt.interop.foxglove_server import FoxgloveServer

hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
resource.setrlimit(resource.RLIMIT_NOFILE, (128, hard))
with FoxgloveServer(port=0) as server:
    print(server.port, flush=True)
    sys.stdin.readline()
"""


def test_foxglove_connects_while_another_client_holds_more_connections_than_the_run_s_limit() -> (
    None
):
    """Before: foxglove-sdk's server, at its process's limit (the run's soft one, 128
    here), stopped listening for good: connection refused from the 129th connection on,
    for every client, even once the idle ones had gone, and the run was not told."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 2 * IDLE_CONNECTIONS:
        pytest.skip(f"a hard limit of {hard} open files leaves the server no room")
    if soft != resource.RLIM_INFINITY and soft < IDLE_CONNECTIONS + 64:
        pytest.skip(f"this process may open only {soft} files")
    run = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_LIMITED)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    idle: list[socket.socket] = []
    try:
        assert run.stdout is not None and run.stdin is not None
        port = int(run.stdout.readline())
        refused = None
        for _ in range(IDLE_CONNECTIONS):  # connected, never a word
            try:
                idle.append(socket.create_connection(("127.0.0.1", port), timeout=10))
            except OSError as exc:  # refused: nothing listens any more
                refused = type(exc).__name__
                break
        try:
            client = FoxgloveClient("127.0.0.1", port, timeout_s=30)
        except OSError as exc:
            said = f"Foxglove refused: {type(exc).__name__}"
        else:
            said = "connected"
            client.close()
        assert (len(idle), refused, said) == (IDLE_CONNECTIONS, None, "connected")
        run.stdin.write("done\n")
        run.stdin.flush()
        run.wait(60)
    finally:
        for sock in idle:
            sock.close()
        if run.poll() is None:
            run.kill()
            run.wait(60)


def test_a_blackboard_value_too_long_for_the_live_view_is_shown_by_its_size() -> None:
    """Every blackboard change republishes the whole board, and the SDK holds 1,024
    messages for a client that does not read: before, a 2 MB value beside a counter set
    every tick grew the server's process by 2 MB a tick for such a client (606 MB in
    300 ticks). A live client is sent the board within 64 KiB, the largest values shown
    by their size; the others as they are."""
    import json
    from pathlib import Path
    from tempfile import TemporaryDirectory

    from pirate_bt.interop.foxglove_server import FoxgloveServer
    from tests.trace_support import run_and_record

    with TemporaryDirectory() as folder:
        trace = Path(folder) / "run.jsonl"
        run_and_record(trace, ticks=2)
        header = json.loads(trace.read_text().splitlines()[0])
    big = "x" * 200_000
    with FoxgloveServer(port=0) as server:
        client = FoxgloveClient("127.0.0.1", server.port)
        try:
            assert client.wait_for(lambda c: "/pirate/blackboard" in c.channels, 10)
            client.subscribe("/pirate/blackboard")
            assert client.wait_for(lambda _: server.subscriptions >= 1, 10)
            server.publish_record(header)
            for n in (1, 2):
                bb = {"counter": n, "path": [0.5] * 10, **({"map": big} if n == 1 else {})}
                server.publish_record({"type": "tick", "n": n, "t_s": n / 100, "bb": bb})
            assert client.wait_for(lambda c: len(c.of("/pirate/blackboard")) >= 2, 20)
            boards = client.of("/pirate/blackboard")
        finally:
            client.close()
    shown = "(200,002 bytes of JSON: too long for the live view)"
    assert [board["set"].get("map") for board in boards] == [shown, None]
    assert [board["values"] for board in boards] == [
        {"counter": n, "path": [0.5] * 10, "map": shown} for n in (1, 2)
    ]
    assert all(len(json.dumps(board)) <= 64 * 1024 for board in boards)  # the docs' 64 KiB
