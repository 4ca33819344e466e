"""Groot2's live port against a client opening many connections: they cost the run's
process no file descriptor (the ports are a relay process's), so the run goes on."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

zmq = pytest.importorskip("zmq")
pytest.importorskip("msgpack")

from pirate_bt.interop import groot2_protocol as proto  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CONNECTIONS = 300

# A run's process with room for 256 files (the server started first: its relay keeps the
# test's limit), serving Groot2 on port 0; it runs a tree once the test says "go".
_RUN = """
import resource, sys
import pirate_bt
from pirate_bt.interop.groot2_server import Groot2Server

server = Groot2Server(port=0)
hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
resource.setrlimit(resource.RLIMIT_NOFILE, (256, hard))
print(server.port, flush=True)
sys.stdin.readline()
try:
    result = pirate_bt.simulate_tree(
        "straight", params={"distance": "0.02m"}, max_time="60 s", groot2=server
    )
    print(result.status, flush=True)
except Exception as exc:
    print(f"{type(exc).__name__}: {exc}", flush=True)
finally:
    server.close()
"""


def test_many_connections_to_groot2_s_port_cost_the_run_no_file(tmp_path: Path) -> None:
    run = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_RUN)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    context = zmq.Context()
    try:
        assert run.stdout is not None and run.stdin is not None
        port = int(run.stdout.readline())
        poller = zmq.Poller()
        clients = []  # every connection held open until the run has ended
        for n in range(CONNECTIONS):
            client = context.socket(zmq.REQ)
            clients.append(client)
            client.setsockopt(zmq.LINGER, 0)
            client.connect(f"tcp://127.0.0.1:{port}")
            client.send(proto.pack_request(ord("S"), n))
            poller.register(client, zmq.POLLIN)
        answered = 0
        deadline = time.monotonic() + 30  # a generous limit: answered in well under 1 s
        while answered < CONNECTIONS and time.monotonic() < deadline:
            for client, _ in poller.poll(500):
                client.recv_multipart()  # "no tree is running yet": any reply will do
                poller.unregister(client)
                answered += 1
        run.stdin.write("go\n")
        run.stdin.flush()
        said, _ = run.communicate(timeout=120)
        # before: 244 answered, then the run said "OSError: [Errno 24] Too many open
        # files: '.../pirate_bt/api/__init__.py'" (the server's connections were the run's)
        assert (answered, said.strip(), run.returncode) == (CONNECTIONS, "success", 0)
    finally:
        context.destroy(linger=0)
        if run.poll() is None:
            run.kill()
            run.wait(60)


_KILLED = """
import sys, time
from pirate_bt.interop.groot2_server import Groot2Server

server = Groot2Server(port=0)
print(server._folder, server._relay.pid, flush=True)
time.sleep(600)
"""


def _running(pid: str) -> bool:
    """Whether process ``pid`` runs (a zombie nobody reaped has ended)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def test_a_run_killed_while_serving_groot2_leaves_no_relay_and_no_folder() -> None:
    run = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_KILLED)],
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        assert run.stdout is not None
        folder, relay = run.stdout.readline().split()
        assert Path(folder).is_dir()
        run.kill()
        run.wait(60)
        deadline = time.monotonic() + 30  # a generous limit: gone in well under 1 s
        while time.monotonic() < deadline and (Path(folder).exists() or _running(relay)):
            time.sleep(0.05)
        # before: the relay ended, and the folder stayed in the temporary folder
        assert not _running(relay)
        assert not Path(folder).exists()
    finally:
        if run.poll() is None:
            run.kill()
            run.wait(60)


@pytest.mark.parametrize("said", [b"Warning: something\n", b"[1, 2]\n", b'{"x": 1}\n'])
def test_a_relay_that_says_something_else_than_its_port_is_one_line(said: bytes) -> None:
    # before: a JSONDecodeError traceback (or a KeyError on 'port')
    import os

    from pirate_bt.interop.groot2_relay import first_line

    read, write = os.pipe()
    with os.fdopen(read, "rb") as stdout:
        os.write(write, said)
        os.close(write)
        answer = first_line(stdout, 30)
    assert answer is not None and set(answer) == {"error"}
    assert answer["error"].startswith("--groot2: the relay process said ")
    assert "\n" not in answer["error"]


_FORKS = """
import os, sys, time
from pirate_bt.interop.groot2_server import Groot2Server

server = Groot2Server(port=0)
relay = server._relay
child = os.fork()
if child == 0:
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)  # the test reads this process's lines
    time.sleep(600)  # a pool's worker, living on
    os._exit(0)
server.close()
print(relay.returncode, flush=True)
os.kill(child, 9)
os.waitpid(child, 0)
"""


def test_a_forked_child_does_not_keep_the_relay_of_a_closed_server() -> None:
    # before: -9: the child's copy of the relay's pipe kept it running after the server
    # closed it, and the server killed it after waiting 5 s for it to end
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(_FORKS)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
        check=False,
    )
    assert (done.returncode, done.stdout.strip()) == (0, "0"), done.stderr[-2000:]
