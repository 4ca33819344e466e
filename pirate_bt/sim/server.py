"""The simulator in real time on a pseudo-terminal or a TCP port, for a separate host process.

``pirate-bt sim --pty`` prints a device path such as ``/dev/pts/7``; the host
opens it like the USB serial port of a real PIRATEbay (``--port /dev/pts/7``).
``pirate-bt sim --tcp 5760`` listens on 127.0.0.1 only; the host opens
``socket://127.0.0.1:5760``. Either way the host's link code is the one that
drives the robot, unchanged.

Here the simulator's own :class:`~pirate_bt.clock.SimClock` is advanced from the
wall clock (times ``speed``), every ``tick_s``: bytes from the host go to the
bridge as they arrive, state frames go out as the simulated time passes them.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import select
import socket
import termios
import threading
import time
import tty

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, InputError, kind_of, shown
from pirate_bt.sim.simulator import Simulator

__all__ = ["SimServer", "end_state"]

_log = logging.getLogger(__name__)


def end_state(sim: Simulator) -> str:
    """One line on what the robot was left doing, for ``pirate-bt sim``'s report when it
    stops: whether it moves or a drive (or the rotation) is still commanded, which halves
    hold, and the bridge's latch and watchdog.

    ``end state: robot at rest, drives stopped; front half clamped, rear half clamped;
    bridge e-stop not latched, watchdog tripped (1 trip)``
    """
    from pirate_bt.robot import ControlMode

    truth = sim.truth()
    robot = sim.robot
    motors = list(robot.drive_motors())
    with contextlib.suppress(KeyError):
        motors.append(robot.rotate_motor())
    commanded = []
    for motor in motors:
        setpoint = sim.model.setpoint(motor.name)
        if setpoint is not None and setpoint.value != 0 and setpoint.mode != ControlMode.POSITION:
            commanded.append(f"{motor.name} {setpoint.mode.value} {setpoint.value:g}")
    if truth.sliding and truth.velocity_mps:
        motion = f"robot sliding at {truth.velocity_mps:.3f} m/s"
    elif truth.sliding:  # sliding, not moving: held at the path's ends (docs/simulator.md)
        entry = truth.front_m <= sim.model.length_m + 1e-9
        where = (
            "back out of the pipe's entry (the simulator keeps it there)"
            if entry
            else "to the pipe's end and lies there"
        )
        motion = f"robot slid {where}, no half holding it"
    elif sim.model.held_as_put_in and abs(truth.slope_rad) > robot.motion.max_unclamped_slope:
        slope = math.degrees(abs(truth.slope_rad))
        motion = f"robot held where it was put in, no half clamped yet on a {slope:.0f} deg slope"
    elif truth.velocity_mps:
        motion = f"robot moving at {truth.velocity_mps:.3f} m/s"
    else:
        motion = "robot at rest"
    counters = sim.counters()
    if counters.slide_m > 0 and not truth.sliding:  # it fell, then stopped or held again
        slides = counters.violations.get("sliding", 0)
        motion += (
            f" after sliding {counters.slide_m:.2f} m with no half holding it"
            f" ({slides} slide{'' if slides == 1 else 's'})"
        )
    drives = "still commanded: " + ", ".join(commanded) if commanded else "drives stopped"
    halves = ", ".join(
        f"{half.value} half {'clamped' if h.clamped else 'not clamped'}"
        for half, h in truth.halves.items()
    )
    bridge = sim.bridge
    trips = bridge.watchdog_trips
    watchdog = (
        f"watchdog {'tripped' if bridge.watchdog_tripped else 'fed'}"
        f" ({trips} trip{'' if trips == 1 else 's'})"
    )
    latch = "e-stop latched" if bridge.estopped else "e-stop not latched"
    return f"end state: {motion}, {drives}; {halves}; bridge {latch}, {watchdog}"


BACKLOG_BYTES = 65536
"""Bytes of frames a server keeps for a host that does not read while the OS buffer
(a pty's, a socket's) is full: about 8 s of ``STATE`` frames at real time, as a USB
serial adapter's and its driver's buffers hold them (the simavr harness keeps as much).
Beyond it the oldest whole frames are dropped and counted, never part of a frame."""

_SOCKET_BUFFER = 16384  # a TCP host's send buffer in the kernel (doubled by Linux): about a pty's

MAX_SPEED = 100.0
"""The fastest a server runs, in simulated seconds per wall second (``pirate-bt sim
--speed``'s limit)."""


class ListenError(InputError, OSError):
    """The server cannot listen where it was asked (a port in use, an address not of
    this machine); an ``InputError`` naming the address, and an ``OSError`` as before."""


def _seconds(value: object, option: str, least: float, most: float) -> float:
    """``value`` as a number of seconds (or a speed) in ``(least, most]``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ArgumentTypeError(f"{option}: give a number, not {kind_of(value)}")
    if not least < value <= most:  # nan too
        raise ArgumentValueError(
            f"{option}: {shown(value)} is not a number above {least:g} and at most {most:g}"
        )
    return float(value)


class SimServer:
    """Serves one :class:`Simulator` on a pty or a TCP port, in real time.

    Args:
        sim: The simulator (its clock is advanced by the server).
        speed: Simulated seconds per wall second (1.0 = real time).
        tick_s: Wall time between steps of the serving loop.
    """

    def __init__(self, sim: Simulator, *, speed: float = 1.0, tick_s: float = 0.002) -> None:
        if not isinstance(sim, Simulator):
            raise ArgumentTypeError(f"sim: give a Simulator, not {kind_of(sim)}")
        # an infinite speed stepped the world for ever in one pass (a hung server), nan
        # froze it, and a tick of 0 or below spun a core
        self.sim = sim
        self.speed = _seconds(speed, "speed", 0.0, MAX_SPEED)
        self.tick_s = _seconds(tick_s, "tick_s", 0.0, 1.0)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._master: int | None = None
        self._slave: int | None = None
        self._pty_poll: select.poll | None = None
        self._host_open = False  # a host has the pty open
        self._listener: socket.socket | None = None
        self._client: socket.socket | None = None
        self.device: str | None = None
        self.address: tuple[str, int] | None = None
        # frames the OS buffer could not take yet, whole but for the head, which may be
        # the rest of a frame partly written (``_cut``)
        self._backlog = bytearray()
        self._cut = False
        self._dropping = False  # frames were dropped since the backlog was last empty
        self.frames_dropped = 0
        """Whole frames dropped for a host that did not read (beyond :data:`BACKLOG_BYTES`
        waiting)."""
        self.bytes_dropped = 0
        """The bytes of those frames."""

    # -- endpoints ------------------------------------------------------------------

    def open_pty(self) -> str:
        """Create the pseudo-terminal and return the device path a host opens.

        A host opening it resets the bridge, as opening a real bridge's port does (its
        DTR edge): the host meets a bridge that booted latched, not the last host's
        session, latch or half-received frame.
        """
        self._check_unopened()
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self.device = os.ttyname(slave)
        # from now on the master reports a hang-up while no host has the device open
        os.close(slave)
        self._master = master
        self._pty_poll = select.poll()
        self._pty_poll.register(master, select.POLLIN)
        self._host_open = False
        return self.device

    @property
    def host_connected(self) -> bool:
        """A host has the pty open, or a TCP host is connected (as the serving loop last
        saw it)."""
        return self._host_open if self._master is not None else self._client is not None

    def _pty_host(self) -> bool:
        """Whether a host has the pty open; its opening resets the bridge (a DTR edge)."""
        assert self._pty_poll is not None
        try:
            events = self._pty_poll.poll(0)
        except (OSError, ValueError):
            return False
        open_now = not any(flags & select.POLLHUP for _, flags in events)
        if open_now and not self._host_open:
            self.sim.bridge.reset()
            self._forget_backlog()
            _log.info("host opened %s: bridge reset (DTR)", self.device)
        elif not open_now and self._host_open:
            self._forget_backlog()
            self._drain_pty()
            _log.info("host closed %s", self.device)
        self._host_open = open_now
        return open_now

    def _drain_pty(self) -> None:
        """Throw away what the host that closed the pty left unread: the kernel keeps it
        for the next host (some 20 KB: the last session's frames, the last perhaps cut,
        read before the new bridge's), in the pty's buffers and in the line discipline's
        4 KB on the device's side."""
        assert self._master is not None and self.device is not None
        with contextlib.suppress(OSError, termios.error):
            termios.tcflush(self._master, termios.TCOFLUSH)
            device = os.open(self.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            try:
                termios.tcflush(device, termios.TCIFLUSH)
            finally:
                os.close(device)

    def open_tcp(self, port: int, host: str = "127.0.0.1") -> tuple[str, int]:
        """Listen on ``host:port`` (loopback by default; port 0 picks a free one).

        Raises:
            ArgumentTypeError, ArgumentValueError: a port that is no whole number from
                0 to 65535, a host that is no text.
            ListenError: the address cannot be listened on (in use, not this machine's).
        """
        if isinstance(port, bool) or not isinstance(port, int):
            raise ArgumentTypeError(f"port: give a whole number, not {kind_of(port)}")
        if not 0 <= port <= 65535:
            raise ArgumentValueError(f"port: {shown(port)} is not a port from 0 to 65535")
        if not isinstance(host, str):
            raise ArgumentTypeError(f"host: give an address as text, not {kind_of(host)}")
        self._check_unopened()
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            listener.bind((host, port))
            listener.listen(1)
        except (OSError, UnicodeError) as exc:
            listener.close()  # it was left open until garbage collection
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            raise ListenError(f"cannot listen on {host}:{port}: {reason}") from None
        listener.setblocking(False)
        self._listener = listener
        name = listener.getsockname()
        self.address = (str(name[0]), int(name[1]))
        return self.address

    # -- loop -----------------------------------------------------------------------

    def _check_unopened(self) -> None:
        """One endpoint per server: a second left the first open and unserved."""
        if self._master is not None or self._listener is not None:
            where = self.device or (self.address and f"{self.address[0]}:{self.address[1]}")
            raise InputError(
                f"this server already serves {where}; one endpoint per server (make another"
                " SimServer)"
            )

    def start(self) -> None:
        """Serve in a background thread until :meth:`stop`."""
        if self._thread is not None and self._thread.is_alive():
            # two loops stepped one simulator and read each other's bytes
            raise InputError("this server is serving already (start() was called before)")
        self._thread = threading.Thread(target=self.serve_forever, name="pirate-sim", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop serving and close the endpoints."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self.close()

    def serve_forever(self, duration_s: float | None = None) -> None:
        """Serve until :meth:`stop` (or for ``duration_s`` wall seconds; ``nan`` served
        for ever)."""
        if duration_s is not None and (
            isinstance(duration_s, bool)
            or not isinstance(duration_s, int | float)
            or math.isnan(duration_s)
        ):
            raise ArgumentValueError(
                f"duration_s: give wall seconds or None (for ever), not {shown(duration_s)}"
            )
        clock = self.sim.clock
        wall0 = time.monotonic()
        sim0 = clock.now()
        while not self._stop.is_set():
            wall = time.monotonic() - wall0
            if duration_s is not None and wall >= duration_s:
                break
            incoming = self._read()
            if incoming:
                self.sim.write(incoming)
            clock.advance_to(sim0 + wall * self.speed)
            outgoing = self.sim.read()
            if outgoing or self._backlog:
                self._write(outgoing)
            self._wait(self.tick_s)

    def _wait(self, timeout_s: float) -> None:
        fds: list[int | socket.socket] = []
        if self._master is not None and self._host_open:
            # (with no host the master reports its hang-up at once: no select on it)
            fds.append(self._master)
        if self._client is not None:
            fds.append(self._client)
        if self._listener is not None:
            fds.append(self._listener)
        if fds:
            with contextlib.suppress(OSError, ValueError):
                select.select(fds, [], [], timeout_s)
        else:
            time.sleep(timeout_s)

    def _read(self) -> bytes:
        if self._master is not None:
            if not self._pty_host():
                return b""
            try:
                return os.read(self._master, 4096)
            except (BlockingIOError, OSError):
                return b""
        # the host's bytes (and its end) first, then a new connection: a host that closed
        # and connected again within one tick was taken for a second host and hung up on
        data = self._recv_client()
        if self._listener is not None:
            self._accept()
        return data

    def _accept(self) -> None:
        assert self._listener is not None
        try:
            client, peer = self._listener.accept()
        except (BlockingIOError, OSError):
            return
        if self._client is not None:
            # one host at a time, as on the bridge's one serial line: a second is
            # disconnected at once (it heard nothing and timed out before)
            _log.warning("a second host from %s:%d refused: one host at a time", *peer)
            client.close()
            return
        client.setblocking(False)
        client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        # the kernel's own send buffer grows to megabytes (minutes of frames at real
        # time); bounded as a pty's is, so what waits for a host that does not read is
        # the server's backlog, dropped by whole frames
        client.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, _SOCKET_BUFFER)
        self._client = client
        _log.info("host connected from %s:%d", *peer)

    def _recv_client(self) -> bytes:
        """What the host sent so far, up to 64 KiB a pass (its end read too, when it closed
        after it), so a flooding host does not hold the simulated time back."""
        received = bytearray()
        while self._client is not None and len(received) < 65536:
            try:
                data = self._client.recv(4096)
            except BlockingIOError:
                break
            except OSError:
                data = b""
            if not data:
                _log.info("host disconnected")
                self._client.close()
                self._client = None
                self._forget_backlog()  # the next host starts at a frame's start
            received += data
        return bytes(received)

    def _write(self, data: bytes) -> None:
        """Send the bridge's frames to the host, whole: what the OS buffer cannot take
        waits (up to :data:`BACKLOG_BYTES`), and a host that does not read loses whole
        frames, oldest first, counted. Until 2026-12-01 the rest of a write the buffer
        could not take was thrown away, cutting a frame in two (a CRC error the host
        could only blame on the bridge)."""
        if self._master is not None:
            if not self._host_open:
                return  # no host has the pty open: the bridge talks to nobody
        elif self._client is None:
            return  # with no host connected, the bridge talks to nobody
        self._backlog += data
        self._flush()
        if len(self._backlog) > BACKLOG_BYTES:
            self._drop_oldest(len(self._backlog) - BACKLOG_BYTES)
        elif not self._backlog and self._dropping:
            self._dropping = False
            _log.info("the host reads again (%d frames dropped so far)", self.frames_dropped)

    def _flush(self) -> None:
        """Write what the OS buffer takes of the backlog."""
        while self._backlog:
            try:
                if self._master is not None:
                    written = os.write(self._master, self._backlog)
                elif self._client is not None:
                    written = self._client.send(self._backlog)
                else:
                    return
            except OSError:  # full (BlockingIOError), or the host gone: read next pass
                return
            if written <= 0:
                return
            self._cut = self._backlog[written - 1] != 0  # a frame ends with its 0x00
            del self._backlog[:written]

    def _drop_oldest(self, excess: int) -> None:
        """Drop whole frames, oldest first, until ``excess`` bytes are gone; the rest of a
        frame partly written is kept (the host has its start)."""
        start = self._backlog.find(0) + 1 if self._cut else 0
        end = self._backlog.find(0, start + excess - 1)
        if (self._cut and start == 0) or end < 0:
            return  # no whole frame to drop (bytes not from the bridge): keep them
        dropped = self._backlog[start : end + 1]
        del self._backlog[start : end + 1]
        self.frames_dropped += dropped.count(0)  # each frame ends with its one 0x00
        self.bytes_dropped += len(dropped)
        if not self._dropping:
            self._dropping = True
            _log.warning(
                "the host does not read: %d KiB of frames wait; the oldest are dropped,"
                " whole (%d so far)",
                BACKLOG_BYTES // 1024,
                self.frames_dropped,
            )

    def _forget_backlog(self) -> None:
        """A new host (or none) starts at the start of a frame: nothing left to it."""
        self._backlog.clear()
        self._cut = False
        self._dropping = False

    def close(self) -> None:
        """Close every endpoint (idempotent)."""
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None
        for sock in (self._client, self._listener):
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.close()
        self._client = self._listener = None
