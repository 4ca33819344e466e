"""A host of ``pirate-bt sim --pty``/``--tcp`` that stops reading for a while, then
reads again, gets only whole frames: what the OS buffer cannot take waits in the
server (``BACKLOG_BYTES``), and beyond that whole frames are dropped, oldest first,
and counted (``SimServer.frames_dropped``). The server threw away the rest of a write
the buffer could not take, cutting a frame in two (a CRC error the host could only
blame on the bridge)."""

from __future__ import annotations

import itertools
import os
import select
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager

import pytest

from pirate_bt.errors import FrameError
from pirate_bt.link.codec import FrameCodec
from pirate_bt.link.decoder import FrameDecoder
from pirate_bt.robot import load_robot
from pirate_bt.sim import Simulator
from pirate_bt.sim.server import SimServer

ROBOT = load_robot()

FRAMES_UNREAD = 5000
"""STATE frames the bridge sends while the host reads nothing: about 380 KB, several
times what the OS buffers and the server's backlog hold together."""


def _pty_host(server: SimServer) -> AbstractContextManager[Callable[[], bytes]]:
    return _pty_host_of(server.open_pty())


@contextmanager
def _tcp_host(server: SimServer) -> Iterator[Callable[[], bytes]]:
    host, port = server.open_tcp(0)
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # a host slow to read
        sock.connect((host, port))

        def read() -> bytes:
            if not select.select([sock], [], [], 0.05)[0]:
                return b""
            return sock.recv(65536)

        yield read
    finally:
        sock.close()


def _wait(condition: Callable[[], bool], what: str, limit_s: float = 60.0) -> None:
    deadline = time.monotonic() + limit_s
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(0.02)


@pytest.mark.parametrize("endpoint", [_pty_host, _tcp_host], ids=["pty", "tcp"])
def test_a_host_that_stops_reading_then_reads_gets_only_whole_frames(
    endpoint: Callable[[SimServer], AbstractContextManager[Callable[[], bytes]]],
) -> None:
    decoder = FrameDecoder(FrameCodec.for_robot(ROBOT))
    got: list[object] = []
    with Simulator("straight", ROBOT) as sim:
        server = SimServer(sim, speed=100.0)
        try:
            with endpoint(server) as read:
                server.start()
                # the host reads nothing while the bridge sends some 380 KB of STATEs
                _wait(
                    lambda: sim.counters().state_frames_sent >= FRAMES_UNREAD,
                    "the bridge sends",
                )

                def past_a_gap() -> bool:
                    got.extend(decoder.feed(read()))
                    seqs = [m.seq for m in got if not isinstance(m, FrameError)]
                    gaps = [i for i, (a, b) in enumerate(itertools.pairwise(seqs)) if b != a + 1]
                    # the host reads on: a gap, and a simulated second of frames after it
                    return bool(gaps) and len(seqs) - gaps[0] > 100

                _wait(past_a_gap, "frames after the frames dropped")
        finally:
            server.stop()
    errors = [m for m in got if isinstance(m, FrameError)]
    assert not errors, f"{len(errors)} frames cut, e.g. {errors[0]}"
    seqs = [m.seq for m in got if not isinstance(m, FrameError)]
    assert all(b > a for a, b in itertools.pairwise(seqs))  # in order
    missing = sum(b - a - 1 for a, b in itertools.pairwise(seqs))
    # every frame missing was dropped whole and counted (more may have been dropped
    # after the last frame the host read, had it been slow again before the end)
    assert 0 < missing <= server.frames_dropped


def test_a_host_that_opens_the_pty_gets_nothing_the_last_host_left_unread() -> None:
    """The kernel kept what a host that closed the pty had not read (some 20 KB, the
    last frame perhaps cut) and gave it to the next host before the new bridge's
    frames: some 230 frames of the last session, then a CRC error where the cut frame
    ran into the new session's first."""
    decoder = FrameDecoder(FrameCodec.for_robot(ROBOT))
    got: list[object] = []
    with Simulator("straight", ROBOT) as sim:
        server = SimServer(sim, speed=100.0)
        try:
            device = server.open_pty()
            server.start()
            first = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            try:  # it reads nothing while the bridge sends, then closes
                _wait(lambda: server.frames_dropped > 0, "frames dropped for the first host")
            finally:
                os.close(first)
            _wait(lambda: not server.host_connected, "the server sees the first host leave")
            with _pty_host_of(device) as read:

                def some_frames() -> bool:
                    got.extend(decoder.feed(read()))
                    return len(got) > 200

                _wait(some_frames, "frames for the second host")
        finally:
            server.stop()
    errors = [m for m in got if isinstance(m, FrameError)]
    assert not errors, f"{len(errors)} frames cut, e.g. {errors[0]}"
    seqs = [m.seq for m in got if not isinstance(m, FrameError)]
    # its own session's frames from the bridge's reset on, none of the last session's
    assert seqs[0] == 1 and all(b > a for a, b in itertools.pairwise(seqs))


@contextmanager
def _pty_host_of(device: str) -> Iterator[Callable[[], bytes]]:
    fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:

        def read() -> bytes:
            if not select.select([fd], [], [], 0.05)[0]:
                return b""
            try:
                return os.read(fd, 65536)
            except BlockingIOError:
                return b""

        yield read
    finally:
        os.close(fd)


SIM = [sys.executable, "-m", "pirate_bt", "sim", "straight"]


def test_pirate_bt_sim_says_how_many_frames_it_dropped_when_it_stops() -> None:
    """The count reaches the operator: a warning when the dropping starts, and a line
    of its own beside the counters when ``pirate-bt sim`` stops."""
    proc = subprocess.Popen(
        # --duration: the bound of the wait below, which only a server that never says
        # it drops frames reaches
        [*SIM, "--tcp", "0", "--speed", "100", "--duration", "60"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        assert proc.stdout is not None and proc.stderr is not None
        url = proc.stdout.readline().strip()  # socket://127.0.0.1:PORT
        host, port = url.removeprefix("socket://").rsplit(":", 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.connect((host, int(port)))  # and reads nothing
        said = []
        for line in proc.stderr:  # (the bridge's watchdog warns first: no host speaks)
            said.append(line)
            if "the host does not read: 64 KiB of frames wait" in line:
                break
        assert "the host does not read" in said[-1], said
        proc.send_signal(signal.SIGTERM)
        _out, err = proc.communicate(timeout=60)
    finally:
        sock.close()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    dropped = [line for line in err.splitlines() if "frames dropped" in line]
    assert len(dropped) == 1 and dropped[0].endswith(  # said once, at the end
        "bytes): a host did not read while 64 KiB of them waited"
    ), err
    assert int(dropped[0].split()[0]) > 0
