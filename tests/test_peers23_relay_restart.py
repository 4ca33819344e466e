"""The Groot2 server's relay process ended while the server serves (killed; its pipe
closed by another's mistake): the server starts it again on the same ports and says
so, and says once when it cannot. Until 2026-12-01 the server went on without a word,
and every Groot2 request after it waited for ever."""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import threading
import time
from typing import Any

import pytest

zmq = pytest.importorskip("zmq")
pytest.importorskip("msgpack")

import test_peers23_groot2_replies  # noqa: E402

from pirate_bt.interop import groot2_server  # noqa: E402
from pirate_bt.interop.groot2_protocol import pack_request  # noqa: E402
from pirate_bt.interop.groot2_server import Groot2Server  # noqa: E402

# the real-time group (tests/conftest.py): a live server, waits on the wall clock
pytestmark = pytest.mark.xdist_group("real-time")


server = test_peers23_groot2_replies.server  # a served one-leaf tree, closed after: a fixture


def _status(port: int, wait_ms: int) -> list[bytes] | None:
    """A new client's STATUS request to ``port``: the reply, or ``None`` in ``wait_ms``."""
    context = zmq.Context()
    try:
        sock = context.socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.RCVTIMEO, wait_ms)
        sock.connect(f"tcp://127.0.0.1:{port}")
        sock.send(pack_request(ord("S")))
        try:
            reply: list[bytes] = sock.recv_multipart()
        except zmq.Again:
            return None
        return reply
    finally:
        context.destroy(linger=0)


def _kill_relay(server: Groot2Server) -> Any:
    relay = server._relay
    assert relay is not None
    os.kill(relay.pid, signal.SIGKILL)
    relay.wait()
    return relay


def _until(condition: Any, what: str, within_s: float = 30.0) -> None:
    deadline = time.monotonic() + within_s
    while not condition():
        assert time.monotonic() < deadline, f"not within {within_s:g} s: {what}"
        time.sleep(0.05)


def test_a_killed_relay_is_started_again_on_the_same_ports(
    server: Groot2Server, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, "pirate_bt.interop.groot2_server")
    port = server.port
    assert _status(port, 30_000) is not None
    killed = _kill_relay(server)
    _until(lambda: server._relay is not killed, "the relay started again")
    reply = _status(port, 30_000)  # a client as Groot2 reconnects: the same port
    assert reply is not None and reply[0] != b"error"
    assert server.port == port and server.enabled
    assert killed.stdin.closed and killed.stdout.closed  # the ended one's pipes let go
    said = [r.getMessage() for r in caplog.records]
    assert any(
        f"relay process listening on 127.0.0.1:{port} ended (signal 9 (SIGKILL));"
        " started again" in line
        for line in said
    ), said


def test_a_relay_that_cannot_be_started_again_is_said_once_and_the_run_goes_on(
    server: Groot2Server, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, "pirate_bt.interop.groot2_server")
    port = server.port
    taker = socket.socket()  # another program takes the port once the relay is gone
    try:
        killed = _kill_relay(server)
        taker.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        taker.bind(("127.0.0.1", port))
        taker.listen()
        _until(lambda: server._relay is not killed, "the server looked at the relay")
        assert server._relay is None and not server.enabled
        lost = [r for r in caplog.records if "can no longer connect" in r.getMessage()]
        assert len(lost) == 1 and lost[0].levelno == logging.ERROR
        assert f"port {port} is taken" in lost[0].getMessage()
        time.sleep(2 * groot2_server.RELAY_LOOK_S)  # once: not said again every second
        assert len([r for r in caplog.records if "can no longer" in r.getMessage()]) == 1
    finally:
        taker.close()
    server.close()  # closes cleanly without its relay
    assert not os.path.exists(server._folder)


def test_a_relay_that_keeps_ending_is_given_up_after_a_few_starts(
    server: Groot2Server, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(groot2_server, "RELAY_RESTARTS", 1)
    caplog.set_level(logging.WARNING, "pirate_bt.interop.groot2_server")
    first = _kill_relay(server)
    _until(lambda: server._relay is not first, "the first start again")
    assert server._relay is not None and server.enabled
    second = _kill_relay(server)
    _until(lambda: server._relay is not second, "the server gave up")
    assert server._relay is None and not server.enabled
    lines = [r.getMessage() for r in caplog.records]
    assert sum("started again" in line for line in lines) == 1
    assert any("it ended 2 times: Groot2 can no longer connect" in line for line in lines)


def test_a_relay_in_front_of_a_stalled_server_still_ends_when_the_server_closes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The relay sends the server nothing that would block it: with the server stalled
    and its queue full, a request is dropped, and the relay still sees its standard
    input close (before: it blocked in the send and was killed after 5 s)."""
    from pirate_bt.interop import groot2_ports

    start = groot2_ports.start_relay
    monkeypatch.setattr(  # the next request goes after 50 ms without a reply, not 5 s
        groot2_server, "start_relay", lambda h, p, s: start(h, p, {**s, "reply_wait_s": 0.05})
    )
    release = threading.Event()
    monkeypatch.setattr(Groot2Server, "_answer", lambda self, parts: release.wait(60) and [])
    made = Groot2Server(port=0)
    relay = made._relay
    assert relay is not None
    context = zmq.Context()
    try:
        clients = []
        for _ in range(30):  # more than the relay's and the server's queues hold
            sock = context.socket(zmq.DEALER)
            sock.setsockopt(zmq.LINGER, 0)
            sock.connect(f"tcp://127.0.0.1:{made.port}")
            # 200 kB each: past what the Unix socket's buffers hold, too
            sock.send_multipart([b"", pack_request(ord("B")), b"x" * 200_000])
            clients.append(sock)
        time.sleep(3)  # every request has had its turn at the relay by now
        assert relay.stdin is not None
        relay.stdin.close()  # as the server's close does (its sockets still open here)
        try:
            assert relay.wait(timeout=10) == 0  # it ended by itself
        except subprocess.TimeoutExpired:
            pytest.fail("the relay, blocked sending to the stalled server, did not end")
    finally:
        release.set()
        context.destroy(linger=0)
        made.close()
