"""A client holding more connections than the Foxglove server's process may open (its
hard limit of open files) no longer leaves the server deaf for the rest of the run.

foxglove-sdk's server stops listening for good when an accept fails for want of
descriptors: until 2026-12-01 every later client was refused, even once the client
holding the connections had gone, and the run was not told.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

pytest.importorskip("foxglove", reason="the foxglove extra (foxglove-sdk) is not installed")

from tests.foxglove_ws import FoxgloveClient

# the real-time group (tests/conftest.py): live servers, answers awaited on the wall clock
pytestmark = [
    pytest.mark.xdist_group("real-time"),
    pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="no /proc/net/tcp here"),
]

ROOT = Path(__file__).resolve().parent.parent
LIMIT = 128
CONNECTIONS = 300
WAIT_S = 30.0

# A run's process whose hard limit of open files is 128 (the server's process cannot
# raise it) serving Foxglove on port 0.
_LIMITED = f"""
import resource, sys
from pirate_bt.interop.foxglove_server import FoxgloveServer

resource.setrlimit(resource.RLIMIT_NOFILE, ({LIMIT}, {LIMIT}))
with FoxgloveServer(port=0) as server:
    print(server.port, flush=True)
    sys.stdin.readline()
"""


def _connects(port: int) -> str:
    """'connected', or why not once :data:`WAIT_S` has passed (tried every half second)."""
    deadline = time.monotonic() + WAIT_S
    while True:
        try:
            client = FoxgloveClient("127.0.0.1", port, timeout_s=10)
        except OSError as exc:
            if time.monotonic() > deadline:
                return f"refused for {WAIT_S:g} s: {type(exc).__name__}"
            time.sleep(0.5)
        else:
            client.close()
            return "connected"


def test_foxglove_connects_again_once_a_client_past_the_hard_limit_has_gone() -> None:
    run = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_LIMITED)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    idle: list[socket.socket] = []
    try:
        assert run.stdout is not None and run.stdin is not None
        port = int(run.stdout.readline())
        for _ in range(CONNECTIONS):  # connected, never a word: past the process's limit
            try:
                idle.append(socket.create_connection(("127.0.0.1", port), timeout=5))
            except OSError:  # refused: the server stopped listening
                break
        for sock in idle:
            sock.close()
        idle.clear()
        assert _connects(port) == "connected"
        run.stdin.write("done\n")
        run.stdin.flush()
        _, err = run.communicate(timeout=60)
        assert "stopped listening (a client held more connections than this process" in err
    finally:
        for sock in idle:
            sock.close()
        if run.poll() is None:
            run.kill()
            run.wait(60)
