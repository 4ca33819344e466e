"""The Groot2 server's TCP ports, in a process of their own: Groot2's clients never
reach the run's process.

:class:`~pirate_bt.interop.groot2_server.Groot2Server` answers requests in the run's
process, on two ZeroMQ sockets bound to Unix sockets in a folder only its user can
enter. This process (``groot2_relay.py CONFIG``, started by the server) listens on
the TCP ports Groot2 connects to (a ROUTER on PORT, a PUB on PORT + 1) and relays:

- each client's requests to the server, and each reply back to its client (the
  ROUTER's routing parts travel with them, so the server answers each client as REP
  would). One request at a time: the next is read once the server has answered (or
  after :data:`REPLY_WAIT_S`), and ZeroMQ reads the clients in turn, so a client that
  sends without waiting has Groot2's request wait behind one of its own at most, as
  when the server listened itself; the rest wait in its pipe here (a few) and in its
  TCP connection. A message that is no request (no envelope) is dropped here, as the
  server drops it;
- the server's breakpoint notices to every subscriber.

Every connection a client opens is this process's: a client opening thousands of
connections (each a file descriptor and ZeroMQ's buffers) costs the run's process
nothing. Until 2026-11-30 the server listened in the run's process, and 266
connections that sent nothing made a run under ``ulimit -n 200`` fail at once:
*straight.yaml: cannot read: Too many open files*, exit 2.

It tells the server on its standard output, one JSON line: ``{"port": N}`` once it
listens, or ``{"error": "..."}`` (the one line to show) if it cannot. It ends when
its standard input closes (the server closed, or the run's process ended), and
removes the server's folder (which a run killed with SIGKILL would leave behind). Only
the standard library and ``pyzmq``: it imports nothing else of pirate_bt.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import signal
import socket
import struct
import sys
import time
from collections.abc import Sequence
from typing import Any

__all__ = ["first_line", "main", "room_for_connections"]

NICE = 5
"""The relay yields the CPU to the run (Groot2 polls ten times a second)."""
FILES_WANTED = 1 << 16
"""The relay's limit of open files when its hard limit is unlimited (or above what the
kernel allows a process): see :func:`room_for_connections`."""
REPLY_WAIT_S = 5.0
"""The longest wait for the server's reply before the next request goes (a reply that
failed to be sent is logged by the server and never comes); the configuration's
``reply_wait_s`` if it has one."""
RELISTEN_S = 1.0
"""How long a port stops listening once accepting on it ran out of file descriptors
(see :class:`_Port`)."""
_OUT_OF_FILES = frozenset({errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM})


class Refused(Exception):
    """A port the relay cannot listen on: the one line to show."""


def main(argv: Sequence[str]) -> int:
    """The relay: ``groot2_relay.py CONFIG`` (JSON: host, port, rep, pub, sys_path and
    the sockets' limits)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the run's Ctrl-C is for the run
    config = json.loads(argv[1])
    with contextlib.suppress(OSError):
        os.nice(NICE)
    room_for_connections()
    if config.get("sys_path"):
        sys.path[:] = config["sys_path"]  # find pyzmq where the run's process found it
    import zmq

    context = zmq.Context()
    try:
        front, notices = _listen(zmq, context, config)
    except Refused as exc:
        _tell({"error": str(exc)})
        context.destroy(linger=0)
        return 1
    server = context.socket(zmq.DEALER)
    server.setsockopt(zmq.LINGER, 0)
    server.setsockopt(zmq.SNDHWM, int(config["requests_queued"]))
    server.connect(config["rep"])
    heard = context.socket(zmq.SUB)
    heard.setsockopt(zmq.LINGER, 0)
    heard.setsockopt(zmq.SUBSCRIBE, b"")
    heard.connect(config["pub"])
    ports = [_Port(zmq, sock) for sock in (front, notices)]
    _tell({"port": ports[0].endpoint.rsplit(":", 1)[1]})
    try:
        wait_s = float(config.get("reply_wait_s", REPLY_WAIT_S))
        _relay(zmq, front, notices, server, heard, int(config["max_request_bytes"]), ports, wait_s)
    finally:
        context.destroy(linger=0)
        # the server's folder: gone with the server, or left by a run that was killed
        shutil.rmtree(str(config.get("folder") or ""), ignore_errors=True)
    return 0


def room_for_connections() -> None:
    """Raise this process's limit of open files to the most it may have (its hard limit):
    every connection a client opens is one here. Under the run's soft limit (1,024 in
    most shells) a client holding that many idle connections kept Groot2 from connecting,
    and ZeroMQ's listener, failing to accept (*Too many open files*), spun: until
    2026-12-01, 300 connections to a relay started under a soft limit of 128 took it 28 %
    of a CPU for as long as they stayed (past the hard limit, see :class:`_Port`). Only this
    process's limit is raised, never the run's. The Foxglove server's process calls it
    too (:mod:`pirate_bt.interop.foxglove_process`)."""
    try:
        import resource
    except ImportError:  # not POSIX
        return
    infinity = resource.RLIM_INFINITY
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    for wanted in (hard, FILES_WANTED):
        if soft == infinity or (wanted != infinity and wanted <= soft):
            return  # room enough already
        if hard != infinity and wanted > hard:
            continue
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
            return
        except (OSError, ValueError):  # above what the kernel lets a process have
            continue


def first_line(stdout: Any, within_s: float) -> dict[str, Any] | None:
    """The relay's first line (JSON) read off its standard output (in the server's
    process), or ``None`` if none came within ``within_s``."""
    import select

    fd = stdout.fileno()
    deadline = time.monotonic() + within_s
    line = b""
    while not line.endswith(b"\n"):
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            return None
        chunk = os.read(fd, 4096)
        if not chunk:  # it ended without a word (its error went to the terminal)
            return {"error": "--groot2: the relay process ended at its start"}
        line += chunk
    try:
        said = json.loads(line)
    except ValueError:
        said = None
    if not isinstance(said, dict) or not ("port" in said or "error" in said):
        return {"error": f"--groot2: the relay process said {line[:80]!r}, not its port"}
    return said


def _tell(message: dict[str, Any]) -> None:
    os.write(1, (json.dumps(message) + "\n").encode())


def _listen(zmq: Any, context: Any, config: dict[str, Any]) -> tuple[Any, Any]:
    """The ROUTER and the PUB, bound to the ports Groot2 connects to."""
    front = context.socket(zmq.ROUTER)
    notices = context.socket(zmq.PUB)
    host = str(config["host"])
    for sock in (front, notices):
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.SNDTIMEO, 1000)
        if ":" in host:  # ZeroMQ binds an IPv6 address only with this set
            sock.setsockopt(zmq.IPV6, 1)
    front.setsockopt(zmq.MAXMSGSIZE, int(config["max_request_bytes"]))
    front.setsockopt(zmq.SNDHWM, int(config["replies_queued"]))
    front.setsockopt(zmq.RCVHWM, int(config["requests_queued"]))
    # A subscriber's subscriptions wait in its pipe until a notice is published (rare).
    notices.setsockopt(zmq.MAXMSGSIZE, int(config["max_subscription_bytes"]))
    notices.setsockopt(zmq.RCVHWM, int(config["requests_queued"]))
    _bind(zmq, front, notices, host, int(config["port"]))
    return front, notices


def _bind(zmq: Any, front: Any, notices: Any, host: str, port: int) -> None:
    where = f"[{host}]" if ":" in host else host
    if port == 0:
        for _ in range(64):
            try:
                first = front.bind_to_random_port(f"tcp://{where}", 20000, 60000)
            except zmq.ZMQError as exc:
                raise _cannot_listen(where, host, exc) from None
            try:
                notices.bind(f"tcp://{where}:{first + 1}")
                return
            except zmq.ZMQError:
                front.unbind(f"tcp://{where}:{first}")
        raise Refused(f"--groot2 {where}: found no two free neighbouring ports")
    if not 0 < port < 65535:
        raise Refused(f"--groot2 {where}:{port}: the port must be from 1 to 65534")
    for sock, number in ((front, port), (notices, port + 1)):
        try:
            sock.bind(f"tcp://{where}:{number}")
        except zmq.ZMQError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise Refused(
                    f"--groot2 {where}:{port}: port {number} is taken (another server, or"
                    " another run with --groot2?); pick another with --groot2 HOST:PORT"
                ) from None
            raise _cannot_listen(f"{where}:{port}", host, exc) from None


def _cannot_listen(given: str, host: str, exc: Any) -> Refused:
    """The one line for a bind ZeroMQ refused. A host name that does not resolve is
    ZeroMQ's ENODEV, which said *No such device* (with the random port it tried, for
    port 0) until 2026-11-30: it is named an unknown host, as ``--foxglove`` names one."""
    if exc.errno == errno.ENODEV:  # neither an address, a name nor an interface of ours
        try:
            socket.getaddrinfo(host, None)
        except (OSError, UnicodeError) as lookup:
            return Refused(f"--groot2 {given}: unknown host: {lookup}")
    from zmq import strerror  # the reason alone (pyzmq's text adds the address tried)

    return Refused(f"--groot2 {given}: cannot listen: {strerror(exc.errno)}")


class _Port:
    """A TCP port of the relay's, watched for accepts that fail for want of descriptors.

    A client holding more connections than the relay may have open (its hard limit)
    made ZeroMQ's listener spin: the connection it cannot accept stays queued, and it
    tries again at once, for as long as they stay (until 2026-12-01: 28 % of a CPU with a
    hard limit of 128 and 300 connections, and Groot2 could not connect). On the first
    such failure the port stops listening for :data:`RELISTEN_S` (ZeroMQ closes the
    connections it had accepted there, every client's: Groot2 reconnects by itself),
    then listens again on the same port.
    """

    def __init__(self, zmq: Any, sock: Any) -> None:
        self.sock = sock
        self.endpoint: str = sock.getsockopt(zmq.LAST_ENDPOINT).decode()
        self.failures = sock.get_monitor_socket(zmq.EVENT_ACCEPT_FAILED)
        self.again_at = 0.0  # when it listens again (0: it listens)

    def heard(self, zmq: Any) -> None:
        """Read the failures; stop listening after one for want of descriptors."""
        short = False
        with contextlib.suppress(zmq.Again):
            while True:
                event = self.failures.recv_multipart(zmq.NOBLOCK)
                if len(event[0]) == 6 and struct.unpack("=hi", event[0])[1] in _OUT_OF_FILES:
                    short = True
        if short and not self.again_at:
            with contextlib.suppress(zmq.ZMQError):
                self.sock.unbind(self.endpoint)
            self.again_at = time.monotonic() + RELISTEN_S

    def relisten(self, zmq: Any) -> None:
        """Listen again once its pause is over (later again if the port is taken)."""
        if self.again_at and time.monotonic() >= self.again_at:
            try:
                self.sock.bind(self.endpoint)
                self.again_at = 0.0
            except zmq.ZMQError:
                self.again_at = time.monotonic() + RELISTEN_S


def _relay(
    zmq: Any,
    front: Any,
    notices: Any,
    server: Any,
    heard: Any,
    most: int,
    ports: list[_Port],
    wait_s: float = REPLY_WAIT_S,
) -> None:
    """Relay until the standard input closes: one request at a time to the server, none
    over ``most`` bytes (:func:`_too_big`); ``ports`` paused while out of descriptors."""
    poller = zmq.Poller()
    poller.register(server, zmq.POLLIN)
    poller.register(heard, zmq.POLLIN)
    poller.register(0, zmq.POLLIN)  # the server's end of the pipe: closed, the relay ends
    poller.register(front, zmq.POLLIN)
    for port in ports:
        poller.register(port.failures, zmq.POLLIN)
    asked = 0.0  # when the request the server answers now went (0: none)
    while True:
        timeout_ms = 250 if any(port.again_at for port in ports) else 1000
        if asked:  # woken when the wait for the server's reply is over, not up to 1 s later
            left_ms = (asked + wait_s - time.monotonic()) * 1000
            timeout_ms = max(1, min(timeout_ms, int(left_ms) + 1))
        ready = dict(poller.poll(timeout_ms))
        if 0 in ready and not os.read(0, 4096):
            return
        for port in ports:
            if port.failures in ready:
                port.heard(zmq)
            port.relisten(zmq)
        if asked and time.monotonic() - asked > wait_s:
            asked = 0.0  # no reply (the server gave up on it): the others' turn
        if ready.get(heard, 0) & zmq.POLLIN:
            with contextlib.suppress(zmq.Again):
                while True:
                    notice = heard.recv_multipart(zmq.NOBLOCK)
                    with contextlib.suppress(zmq.ZMQError):  # a courtesy, as before
                        notices.send_multipart(notice, zmq.NOBLOCK)
        if ready.get(server, 0) & zmq.POLLIN:
            with contextlib.suppress(zmq.Again):
                while True:
                    reply = server.recv_multipart(zmq.NOBLOCK)
                    asked = 0.0
                    _to_client(zmq, front, reply)
        while not asked:
            try:
                request = front.recv_multipart(zmq.NOBLOCK)  # the clients in turn
            except zmq.Again:
                break
            if _envelope_ends(request) is None:
                continue  # not a request (REP drops it too): nobody to answer
            if _too_big(request, most):
                continue  # as ZeroMQ drops a part over the limit, unanswered
            try:  # never blocks: the relay must still see its standard input close
                server.send_multipart(request, zmq.NOBLOCK)
            except zmq.Again:  # the server has stalled with requests queued: dropped,
                continue  # unanswered, as ZeroMQ drops what exceeds a full queue
            asked = time.monotonic()
        # the clients are read only when the server has no request of theirs to answer
        poller.register(front, 0 if asked else zmq.POLLIN)


def _to_client(zmq: Any, front: Any, reply: list[bytes]) -> None:
    """Send ``reply`` to its client; dropped when the client is gone or holds
    :data:`~pirate_bt.interop.groot2_run.REPLIES_QUEUED` replies it has not read.

    The ROUTER's commands are processed first (``EVENTS``). ZeroMQ counts a client's
    unsent replies from what its I/O thread last *said* it had taken, a command the
    socket reads only now and then: at most once a millisecond on a send, and never
    while the relay waits for the server (the socket is not polled then). Until
    2026-12-01 a client asking back to back (Groot2 asks ten times a second, a probe
    or another client faster) had one reply in a few hundred dropped as if it had 4
    unread, while it had none: Groot2's REQ socket then waited for it for ever, and a
    client sending 8 requests before reading lost some of the 8 replies, where
    BT.CPP's server answers every one."""
    with contextlib.suppress(zmq.ZMQError):  # gone, or does not read: dropped, as before
        front.getsockopt(zmq.EVENTS)
        front.send_multipart(reply, zmq.NOBLOCK)


ENVELOPE_BYTES = 4096
"""The most bytes of a request's routing envelope (a REQ client's is its 5-byte identity
and the empty delimiter; a DEALER may add parts of its own)."""


def _too_big(parts: Sequence[bytes], most: int) -> bool:
    """Whether a request (envelope, delimiter, then its parts) holds more than ``most``
    bytes after its envelope, or an envelope over :data:`ENVELOPE_BYTES`. ZeroMQ's limit
    (``MAXMSGSIZE``) is each part's: until 2026-12-01 one request of 300 parts of 1 MiB
    reached the server, and the run's process grew by 600 MB reading it (the relay, a
    process of its own, still holds it until it is dropped here)."""
    ends = _envelope_ends(parts)
    assert ends is not None
    envelope = sum(len(part) for part in parts[: ends + 1])
    return envelope > ENVELOPE_BYTES or sum(len(part) for part in parts[ends + 1 :]) > most


def _envelope_ends(parts: Sequence[bytes]) -> int | None:
    """Where a request's routing envelope ends (its empty part, REQ's delimiter), as the
    server finds it; ``None`` when there is none, or no request after it."""
    for index in range(1, len(parts) - 1):
        if not parts[index]:
            return index
    return None


if __name__ == "__main__":
    status = main(sys.argv)
    sys.stderr.flush()
    os._exit(status)
