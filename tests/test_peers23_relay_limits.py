"""A client holding more connections than the Groot2 relay may have open (its hard limit
of open files) no longer makes it spin, and Groot2 connects again within a second or two.

ZeroMQ's listener, failing to accept for want of descriptors, tried again at once for
as long as the connections stayed: 28 % of a CPU with a hard limit of 128 and 300
connections, and Groot2 got no reply.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

zmq = pytest.importorskip("zmq")
pytest.importorskip("msgpack")

from pirate_bt.interop.groot2_protocol import pack_request  # noqa: E402

# the real-time group (tests/conftest.py): a live server, replies awaited on the wall clock
pytestmark = [
    pytest.mark.xdist_group("real-time"),
    pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="no /proc here"),
]

ROOT = Path(__file__).resolve().parent.parent
LIMIT = 128
CONNECTIONS = 300

# A run's process whose hard limit of open files is 128 (the relay cannot raise it)
# serving Groot2 on port 0; it says its port and its relay's process id.
_LIMITED = f"""
import resource, sys
import py_trees
from pirate_bt.interop.groot2_server import Groot2Server

resource.setrlimit(resource.RLIMIT_NOFILE, ({LIMIT}, {LIMIT}))
root = py_trees.composites.Sequence("root", memory=False)
root.add_children([py_trees.behaviours.Running("leaf")])
tree = py_trees.trees.BehaviourTree(root)
tree.setup()
with Groot2Server(port=0) as server:
    server.serve(tree)
    server.served()
    print(server.port, server._relay.pid, flush=True)
    sys.stdin.readline()
"""


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_a_client_past_the_relay_s_hard_limit_neither_makes_it_spin_nor_keeps_groot2_out() -> None:
    run = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_LIMITED)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    idle: list[socket.socket] = []
    context = zmq.Context()
    try:
        assert run.stdout is not None and run.stdin is not None
        port, relay = map(int, run.stdout.readline().split())
        for _ in range(CONNECTIONS):  # connected, never a word: past the relay's limit
            try:
                idle.append(socket.create_connection(("127.0.0.1", port), timeout=5))
            except OSError:  # not accepted (its listen queue full), or not listening
                break
        assert len(idle) > LIMIT
        groot2 = context.socket(zmq.REQ)
        groot2.setsockopt(zmq.LINGER, 0)
        groot2.setsockopt(zmq.RCVTIMEO, 20_000)
        groot2.connect(f"tcp://127.0.0.1:{port}")
        groot2.send(pack_request(ord("S"), 1667))
        try:
            reply = groot2.recv_multipart()
        except zmq.Again:
            reply = [b"no reply in 20 s"]
        assert reply[0][2:6] == (1667).to_bytes(4, "little"), reply
        before, start = _cpu_s(relay), time.monotonic()
        time.sleep(3)  # the connections still held: what the relay spends meanwhile
        spent, wall = _cpu_s(relay) - before, time.monotonic() - start
        assert spent < 0.1 * wall, f"the relay took {spent:.2f} s of CPU in {wall:.1f} s"
        run.stdin.write("done\n")
        run.stdin.flush()
        run.wait(60)
    finally:
        for sock in idle:
            sock.close()
        context.destroy(linger=0)
        if run.poll() is None:
            run.kill()
            run.wait(60)
