"""Groot2's relay (groot2_relay.py) in front of the server, with clients at once: every
request a client still waits for is answered, to that client, with that request's id,
whatever the others do (ask in turn, send several without waiting, give up on a request
and ask again on a new socket)."""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable
from typing import Any

import py_trees
import pytest

zmq = pytest.importorskip("zmq")
pytest.importorskip("msgpack")

from pirate_bt.interop.groot2_protocol import pack_request  # noqa: E402
from pirate_bt.interop.groot2_server import Groot2Server  # noqa: E402

# the real-time group (tests/conftest.py): live servers, answers awaited on the wall clock
pytestmark = pytest.mark.xdist_group("real-time")

REQUESTS = 120
WAIT_MS = 30_000  # answers take well under a millisecond; only a lost one reaches this


def _tree() -> py_trees.trees.BehaviourTree:
    root = py_trees.composites.Sequence("root", memory=False)
    root.add_children([py_trees.behaviours.Running(f"leaf{i}") for i in range(5)])
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup()
    return tree


def _socket(context: Any, kind: int, port: int) -> Any:
    sock = context.socket(kind)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, WAIT_MS)
    sock.connect(f"tcp://127.0.0.1:{port}")
    return sock


def _uid(reply: list[bytes]) -> int | None:
    """The unique id a reply echoes (its header's bytes 2-5), ``None`` for an error reply."""
    if reply[0] == b"error":
        return None
    return int.from_bytes(reply[0][2:6], "little")


def test_every_request_a_client_waits_for_is_answered_to_it(tmp_path: Any) -> None:
    problems: list[str] = []
    answered: collections.Counter[str] = collections.Counter()

    def in_turn(name: str, port: int, give_up_every: int = 0) -> None:
        context = zmq.Context()
        sock = _socket(context, zmq.REQ, port)
        try:
            for i in range(REQUESTS):
                uid = (hash(name) + 7 * i) & 0xFFFFFFFF
                kind = b"STDB"[i % 4]
                sock.send_multipart([pack_request(kind, uid)] + ([b""] if kind == ord("B") else []))
                if give_up_every and i % give_up_every == 0:
                    sock.close()  # gave up on it: a new REQ socket asks the next
                    sock = _socket(context, zmq.REQ, port)
                    continue
                try:
                    reply = sock.recv_multipart()
                except zmq.Again:
                    problems.append(f"{name}: request {i} ({chr(kind)}) not answered")
                    return
                if _uid(reply) != uid:
                    problems.append(f"{name}: request {i} answered {reply[0]!r}, not id {uid}")
                    return
                answered[name] += 1
        finally:
            sock.close()
            context.term()

    def without_waiting(name: str, port: int) -> None:
        context = zmq.Context()
        sock = _socket(context, zmq.DEALER, port)
        try:
            for burst in range(REQUESTS // 10):
                uids = [burst * 10 + k for k in range(10)]
                for uid in uids:
                    sock.send_multipart([b"", pack_request(ord("S"), uid)])
                for uid in uids:  # answered one at a time, in the order asked
                    try:
                        reply = sock.recv_multipart()[1:]
                    except zmq.Again:
                        problems.append(f"{name}: request {uid} not answered")
                        return
                    if _uid(reply) != uid:
                        problems.append(f"{name}: request {uid} answered {reply[0]!r}")
                        return
                    answered[name] += 1
        finally:
            sock.close()
            context.term()

    tree = _tree()
    clients: list[tuple[Callable[..., None], tuple[Any, ...]]] = [
        (in_turn, ("first",)),
        (in_turn, ("second",)),
        (in_turn, ("gives up", 5)),
        (without_waiting, ("several",)),
    ]
    with Groot2Server(port=0) as server:
        server.serve(tree)
        assert server.served() is not None
        threads = [
            threading.Thread(target=target, args=(args[0], server.port, *args[1:]), daemon=True)
            for target, args in clients
        ]
        try:
            for thread in threads:
                thread.start()
            while any(thread.is_alive() for thread in threads):
                tree.tick()  # the tree ticks meanwhile, as in a run, every 2 ms
                threads[0].join(0.002)
        finally:
            for thread in threads:
                thread.join(60)
    assert problems == []
    assert answered == {
        "first": REQUESTS,
        "second": REQUESTS,
        "gives up": REQUESTS - REQUESTS // 5,
        "several": REQUESTS,
    }


# A run's process whose soft limit of open files is 128 (its hard one as it was) serving
# Groot2 on port 0: the relay starts under that limit.
_LIMITED = """
import resource, sys
import py_trees
from pirate_bt.interop.groot2_server import Groot2Server

hard = resource.getrlimit(resource.RLIMIT_NOFILE)[1]
resource.setrlimit(resource.RLIMIT_NOFILE, (128, hard))
root = py_trees.composites.Sequence("root", memory=False)
root.add_children([py_trees.behaviours.Running("leaf")])
tree = py_trees.trees.BehaviourTree(root)
tree.setup()
with Groot2Server(port=0) as server:
    server.serve(tree)
    server.served()
    print(server.port, flush=True)
    sys.stdin.readline()
"""
IDLE_CONNECTIONS = 300


def test_groot2_connects_while_another_client_holds_more_connections_than_the_run_s_limit() -> None:
    """The relay holds the connections: its limit of open files is its hard limit, not
    the run's soft one (before: with 128, Groot2 could not connect past 300 idle
    connections, and the relay's ZeroMQ spun failing to accept)."""
    import resource
    import socket
    import subprocess
    import sys
    import textwrap

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 2 * IDLE_CONNECTIONS:
        pytest.skip(f"a hard limit of {hard} open files leaves the relay no room")
    if soft != resource.RLIM_INFINITY and soft < IDLE_CONNECTIONS + 64:
        pytest.skip(f"this process may open only {soft} files")
    run = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(_LIMITED)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    idle: list[socket.socket] = []
    context = zmq.Context()
    try:
        assert run.stdout is not None and run.stdin is not None
        port = int(run.stdout.readline())
        for _ in range(IDLE_CONNECTIONS):  # connected, never a word
            try:
                idle.append(socket.create_connection(("127.0.0.1", port), timeout=10))
            except TimeoutError:  # not accepted: its listen queue full
                break
        groot2 = _socket(context, zmq.REQ, port)
        groot2.send(pack_request(ord("S"), 1667))
        try:
            reply = groot2.recv_multipart()
        except zmq.Again:
            reply = [b"no reply in 30 s"]
        assert (len(idle), _uid(reply)) == (IDLE_CONNECTIONS, 1667), reply
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


def test_a_request_over_1_mib_in_many_parts_never_reaches_the_run_s_process() -> None:
    """ZeroMQ's limit of 1 MiB is each part's: before, a request of 300 parts of 1 MiB
    reached the server, and the run's process grew by 600 MB reading it. A request over
    1 MiB in all is dropped by the relay, unanswered, as one part over 1 MiB is; the
    client's next request is answered."""
    tree = _tree()
    context = zmq.Context()
    with Groot2Server(port=0) as server:
        server.serve(tree)
        assert server.served() is not None
        sock = _socket(context, zmq.DEALER, server.port)
        try:
            part = bytes(64 * 1024)
            sock.send_multipart([b"", pack_request(ord("S"), 1), *[part] * 20])  # 1.25 MiB
            sock.send_multipart([b"", pack_request(ord("S"), 2)])
            try:
                reply = sock.recv_multipart()[1:]
            except zmq.Again:
                reply = [b"no reply in 30 s"]
            assert (_uid(reply), server.requests) == (2, 1)
        finally:
            sock.close()
            context.destroy(linger=0)
