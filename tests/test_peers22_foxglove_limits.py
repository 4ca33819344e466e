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
