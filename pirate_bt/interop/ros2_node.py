"""The ROS 2 node of ``--ros2``, as the run's process sees it: a child process and a pipe.

:class:`Ros2Node` starts the publishing process
(:mod:`pirate_bt.interop.ros2_process`) at once and returns: the process imports
Zenoh, opens the session, declares the publishers, their liveliness tokens and
the e-stop subscription while the run is still being prepared, and says when it
is ready (:meth:`Ros2Node.wait_ready`). From then on the run's process only
hands over frames (:meth:`Ros2Node.offer`: one ``marshal`` and one
non-blocking ``os.write``); the type store, the messages, their CDR and Zenoh
are the other process's work, on another core, never in the run's interpreter.

The pipe is bounded (1 MiB): when the publishing process lags so far behind that
a frame does not fit, the frame is dropped and counted (:attr:`Ros2Node.dropped`),
never waited for. A thread of the run's process waits (blocked in ``os.read``,
holding no lock) for what the publishing process sends back: that it is ready,
that publishing failed (the output is then switched off; the run goes on), and
every ``std_msgs/Bool`` on the e-stop topic, which :class:`EStopInput` queues
for the supervisor's next tick.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import logging
import os
import select
import subprocess
import sys
import threading
import time
import weakref
from collections import deque
from pathlib import Path
from typing import Any, ClassVar

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop import rmw_zenoh, ros2_process
from pirate_bt.interop.ros2_option import (
    DEFAULT_ENDPOINT,
    DEFAULT_NAMESPACE,
    check_names,
    check_node_args,
    domain_from_env,
    parse_endpoint,
)
from pirate_bt.interop.ros2_process import BOOL, CLOSED, FAILED, FLUSHED, OFF, READY, WARN
from pirate_bt.interop.ros2_reach import REACH
from pirate_bt.interop.ros2_topics import TOPIC_TYPES
from pirate_bt.interop.ros2_types import missing
from pirate_bt.safety.operator import EStop, OperatorAction
from pirate_bt.trace.sink_formats import forget_in_forks, let_go_in_forks, to_null

__all__ = ["ESTOP", "EStopInput", "Ros2Node"]

logger = logging.getLogger(__name__)

ESTOP = "estop"
"""The e-stop topic, relative to the namespace."""

_PIPE_BYTES = 1 << 20
_SCRIPT = Path(ros2_process.__file__).resolve()


def _plain(value: Any) -> Any:
    """``value`` with everything ``marshal`` cannot carry turned into what it can."""
    if value is None or type(value) in (bool, int, float, str, bytes):
        return value
    if isinstance(value, bool):
        return bool(value)
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str):
        return str(value)
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return tuple(_plain(v) for v in value)
    try:
        return float(value)
    except (TypeError, ValueError):
        return str(value)


class EStopInput:
    """The e-stop topic as an operator input (see :mod:`pirate_bt.interop.ros2_live`).

    The node's reader thread :meth:`push`\\ es; the supervisor's tick :meth:`poll`\\ s.
    """

    releases = False
    """It only stops: nobody can reset the e-stop through it, so a run does not wait
    for it to (:attr:`~pirate_bt.safety.supervisor.Supervisor.operator_attached`)."""

    def __init__(self, topic: str) -> None:
        self.topic = topic
        self._due: deque[OperatorAction] = deque()
        self.received = 0
        """``std_msgs/Bool`` messages received (``true`` or not)."""
        self.estops = 0
        """E-stops handed to a supervisor so far."""
        self.heard_ns = 0
        """When the last ``true`` reached the publishing process (``time.monotonic_ns``)."""
        self.queued_ns = 0
        """When the last ``true`` was queued here, in this process."""
        self.drained_ns = 0
        """When a supervisor last took an e-stop from here."""

    def push(self, data: bool, heard_ns: int = 0, count: int = 1) -> None:
        """``count`` ``std_msgs/Bool`` messages arrived, one of them ``true`` if ``data``
        (``heard_ns``: when the first ``true``, or the last, arrived, if known)."""
        self.received += count
        if data:
            self.heard_ns = heard_ns
            self.queued_ns = time.monotonic_ns()
            # One e-stop due is enough: a peer that floods the topic must not make the
            # supervisor's next tick send thousands of e-stop frames and log lines.
            if not self._due:
                self._due.append(EStop(f"ROS 2 e-stop on {self.topic}"))

    def poll(self, tick: int, now_s: float) -> list[OperatorAction]:
        if not self._due:
            return []
        due: list[OperatorAction] = []
        while self._due:
            due.append(self._due.popleft())
        self.estops += len(due)
        self.drained_ns = time.monotonic_ns()
        return due


class Ros2Node:
    """One ROS 2 node over Zenoh (rmw_zenoh's conventions), run by a process of its own.

    The publishing process starts at once and sets itself up in the background:
    :meth:`wait_ready` waits for it. Frames go to it with :meth:`begin` and
    :meth:`offer` (:mod:`pirate_bt.interop.ros2_live` does both).

    Args:
        endpoint: A Zenoh endpoint (``tcp/HOST:PORT``), usually a router's.
        domain_id: The ROS domain (default: ``ROS_DOMAIN_ID``, else 0).
        namespace: The namespace of the node and its topics.
        name: The node's name.
        rate_hz: At most this many messages per topic and wall-clock second.
        estop: Subscribe to ``<namespace>/estop`` (see the module docstring).
        listen: Endpoints to listen on for peer-to-peer links (rmw_zenoh's default:
            the loopback, on a port the system picks).

    Raises:
        ConfigurationError: ``eclipse-zenoh`` is missing, or no process can be started.
        InputError: a bad endpoint, domain id, namespace or rate, or an argument of the
            wrong kind (``ArgumentTypeError``, an ``InputError`` too).
    """

    _PROCESS_OPTIONS: ClassVar[dict[str, Any]] = {}
    """More settings for the publishing process (the tests' ``fail_publishing``)."""

    def __init__(
        self,
        endpoint: str = DEFAULT_ENDPOINT,
        *,
        domain_id: int | None = None,
        namespace: str = DEFAULT_NAMESPACE,
        name: str = "pirate_bt",
        rate_hz: float = 20.0,
        estop: bool = True,
        listen: tuple[str, ...] = ("tcp/127.0.0.1:0",),
    ) -> None:
        if importlib.util.find_spec("zenoh") is None:
            raise ConfigurationError(missing("--ros2", "eclipse-zenoh"))
        check_node_args(endpoint, domain_id, namespace, name, rate_hz)
        self.endpoint = parse_endpoint(endpoint)
        self.domain_id = domain_from_env() if domain_id is None else int(domain_id)
        if not 0 <= self.domain_id <= 232:
            raise InputError(f"--ros-domain-id {self.domain_id}: ROS domain ids go from 0 to 232")
        self.namespace = check_names(
            namespace, name, max((t for t in TOPIC_TYPES if not t.startswith("/")), key=len)
        )
        self.fq_estop = rmw_zenoh.qualified_name(self.namespace, ESTOP)
        self.name = name
        self.period_s = 1.0 / rate_hz
        self.estop = EStopInput(self.fq_estop) if estop else None
        self.enabled = True
        """False once the output failed (the run goes on without it)."""
        self.session_id = ""
        """The Zenoh session's id (once ready)."""
        self.published = 0
        """Messages handed to Zenoh so far (as of the last flush or close)."""
        self.dropped = 0
        """Frames dropped because the publishing process lagged (the pipe was full)."""
        self.process_cpu_s = 0.0
        """The CPU time the publishing process spent (known once it is closed)."""
        self.failure: tuple[str, str] | None = None
        """``(kind, text)`` when the publishing process could not set up (see ``FAILED``)."""
        self.reached = True
        """False while the node's session reaches no Zenoh router or peer (said in the
        log; see :mod:`~pirate_bt.interop.ros2_reach`)."""
        self._supervisors: list[weakref.ref[Any]] = []
        """The supervisors attached, held weakly, so that each goes with its run."""
        self._ready = threading.Event()
        self._lock = threading.Lock()
        self._flushed = threading.Condition()
        self._flush_asked = 0
        self._flush_answered = 0
        self._tail = b""
        self._runs = 0
        self._closed = False
        # Frames go in on the process's standard input, which it reads every period
        # (it does not wait on it: see ros2_process._batches); a byte on this pipe wakes
        # it at once for what must not wait.
        wake_r, self._wake_fd = os.pipe()
        os.set_blocking(self._wake_fd, False)
        config = {
            "wake_fd": wake_r,
            "poll_s": self.period_s,
            "endpoint": self.endpoint,
            "listen": list(listen),
            "domain_id": self.domain_id,
            "namespace": self.namespace,
            "name": name,
            "fq_estop": self.fq_estop,
            "estop": estop,
            "sys_path": list(sys.path),
            **self._PROCESS_OPTIONS,
        }
        try:
            self._proc = subprocess.Popen(
                # -I: no user site, no PYTHON* variables, no script folder on the path.
                [sys.executable, "-I", str(_SCRIPT), json.dumps(config)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                pass_fds=(wake_r,),
                start_new_session=True,  # a signal to the run's process group spares it
            )
        except OSError as exc:
            os.close(self._wake_fd)
            raise ConfigurationError(f"--ros2: cannot start the ROS 2 process: {exc}") from None
        finally:
            os.close(wake_r)
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._fd = self._proc.stdin.fileno()
        try:  # room for a lag of many frames; beyond it frames are dropped
            import fcntl

            fcntl.fcntl(self._fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), _PIPE_BYTES)
        except (ImportError, OSError):
            pass
        os.set_blocking(self._fd, False)
        self._reader = threading.Thread(
            target=self._read, args=(self._proc.stdout.fileno(),), name="pirate-ros2", daemon=True
        )
        self._reader.start()
        let_go_in_forks(self)
        logger.info(
            "ROS 2 node %s/%s on Zenoh %s, domain %d (process %d)",
            self.namespace,
            name,
            self.endpoint,
            self.domain_id,
            self._proc.pid,
        )

    @property
    def pid(self) -> int:
        """The publishing process's id."""
        return self._proc.pid

    # --- what the publishing process says ---------------------------------------------------

    def _read(self, fd: int) -> None:
        buffer = bytearray()
        while True:
            try:
                chunk = os.read(fd, 65536)
            except OSError:
                chunk = b""
            if not chunk:
                break
            buffer += chunk
            for message in ros2_process.decode_messages(buffer):
                try:
                    self._heard(message)
                except Exception:  # this thread must not die
                    logger.exception("ROS 2 output: a message from its process failed")
        if not self._ready.is_set():
            self.failure = self.failure or ("setup", "the ROS 2 process ended before it was ready")
        if not self._closed and self.enabled:
            self.enabled = False
            logger.warning(
                "ROS 2 output: its process ended (exit %s); the run is no longer shown and the"
                " e-stop topic no longer reaches it",
                self._proc.poll(),
            )
        self._ready.set()
        with self._flushed:
            self._flush_answered = self._flush_asked
            self._flushed.notify_all()

    def _heard(self, message: tuple[Any, ...]) -> None:
        kind = message[0]
        if kind == BOOL:
            if self.estop is not None:
                self.estop.push(bool(message[1]), int(message[2]), int(message[3]))
        elif kind == READY:
            self.session_id = str(message[1])
            self._ready.set()
        elif kind == FAILED:
            self.failure = (str(message[2]), str(message[1]))
            self.enabled = False
            logger.error("ROS 2 output: %s; it is switched off", message[1])
            self._ready.set()
        elif kind == REACH:
            self.reached = bool(message[1])
            if self.reached:
                logger.warning(
                    "ROS 2: reached a Zenoh router or peer at %s: the graph sees this run",
                    self.endpoint,
                )
            else:
                logger.warning(
                    "ROS 2: no Zenoh router or peer reached at %s (still trying): the graph"
                    " does not see this run%s",
                    self.endpoint,
                    f", and {self.fq_estop} does not reach it" if self.estop is not None else "",
                )
        elif kind == WARN:
            logger.warning("ROS 2: %s; ignored", message[1])
        elif kind == OFF:
            self.enabled = False
            logger.error("ROS 2 output: publishing failed (%s); it is switched off", message[1])
        elif kind == FLUSHED:
            self.published = int(message[2])
            with self._flushed:
                self._flush_answered = max(self._flush_answered, int(message[1]))
                self._flushed.notify_all()
        elif kind == CLOSED:
            self.published = int(message[1])
            self.process_cpu_s = float(message[2])
            logger.info(
                "ROS 2 output: %d messages published, %d frames dropped, %.3f s of CPU in its"
                " process",
                self.published,
                self.dropped,
                self.process_cpu_s,
            )

    def wait_ready(self, timeout_s: float = 10.0) -> bool:
        """Wait until the publishers, tokens and the e-stop subscription exist.

        Returns:
            True when ready; False on time-out or when the set-up failed (logged).
        """
        return self._ready.wait(timeout_s) and self.failure is None

    def check_opened(self, timeout_s: float = 10.0) -> bool:
        """:meth:`wait_ready`, raising what the user can fix.

        Raises:
            InputError: the Zenoh session could not be opened (a bad endpoint).
            ConfigurationError: the publishing process could not import Zenoh.
        """
        ready = self.wait_ready(timeout_s)
        if self.failure is not None and self.failure[0] == "input":
            raise InputError(f"--ros2 {self.endpoint}: {self.failure[1]}")
        if self.failure is not None and self.failure[0] == "config":
            raise ConfigurationError(missing("--ros2", "eclipse-zenoh"))
        return ready

    # --- supervisors -------------------------------------------------------------------------

    def attach_supervisor(self, supervisor: Any) -> None:
        """Let ``supervisor`` drain the e-stop topic (once per supervisor)."""
        if self.estop is None or supervisor is None:
            return
        # Weakly: a node shared by many runs kept every run's supervisor, and with it
        # the run's simulator and link, for as long as the node was open.
        self._supervisors = [ref for ref in self._supervisors if ref() is not None]
        if any(ref() is supervisor for ref in self._supervisors):
            return
        self._supervisors.append(weakref.ref(supervisor))
        supervisor.add_input(self.estop)

    # --- handing over ------------------------------------------------------------------------

    def begin(self, shape: Any, start_ns: int, hardware_id: str, period_s: float) -> int:
        """Announce a run's tree (a :class:`~pirate_bt.interop.ros2_topics.TreeShape`) and
        clock; returns the run number its frames are offered under."""
        self._runs += 1
        run = self._runs
        self._send(
            (ros2_process.SETUP, run, shape.to_wire(), int(start_ns), hardware_id, period_s),
            keep=True,
        )
        return run

    def offer(self, run: int, values: tuple[Any, ...], *, final: bool = False) -> None:
        """Hand one frame of ``run`` over: ``values`` are ``FRAME``'s from ``n`` on
        (:mod:`pirate_bt.interop.ros2_process`). A frame that does not fit in the pipe is
        dropped and counted; a ``final`` one (a run's last) is waited for, and goes out at
        once with the tree."""
        if self.enabled:
            self._send((ros2_process.FRAME, run, final, *values), keep=final)
            if final:
                self._wake()

    def _wake(self) -> None:
        with self._lock, contextlib.suppress(OSError):  # full: it is woken already
            if not self._closed:
                os.write(self._wake_fd, b"!")

    def _send(self, message: tuple[Any, ...], *, keep: bool) -> None:
        """Write ``message`` to the pipe without blocking, unless ``keep``: then it is
        written whole, waiting (at most 5 s) for room."""
        if self._closed or not self.enabled:
            return
        try:
            data = ros2_process.encode_message(message)
        except ValueError:  # a value marshal does not carry (a subclass, numpy...)
            data = ros2_process.encode_message(_plain(message))
        with self._lock:
            try:
                if self._tail and not self._write_tail(keep):
                    self.dropped += 1  # the last frame is still going in: this one is dropped
                    return
                written = self._write(data)
                if written == 0 and not keep:
                    self.dropped += 1
                    return
                self._tail = data[written:]
                if keep:
                    self._write_tail(True)
            except BrokenPipeError:
                self.enabled = False
                logger.warning("ROS 2 output: its process has gone; it is switched off")
            except TimeoutError:
                self.enabled = False
                logger.warning("ROS 2 output: its process stopped reading; it is switched off")

    def _write(self, data: bytes) -> int:
        try:
            return os.write(self._fd, data)
        except BlockingIOError:
            return 0

    def _write_tail(self, wait: bool) -> bool:
        """Write what is left of a message; True once it is all written."""
        deadline = time.monotonic() + 5.0
        while self._tail:
            self._tail = self._tail[self._write(self._tail) :]
            if not self._tail or not wait:
                break
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError
            select.select([], [self._fd], [], left)
        return not self._tail

    def flush(self, timeout_s: float = 5.0) -> bool:
        """Wait until the publishing process has published everything offered (True) or
        time is up (False)."""
        if self._closed or not self.enabled:
            return True  # nothing is waiting to go out
        with self._flushed:
            self._flush_asked += 1
            token = self._flush_asked
        self._send((ros2_process.FLUSH, token), keep=True)
        self._wake()
        with self._flushed:
            return self._flushed.wait_for(lambda: self._flush_answered >= token, timeout_s)

    def close(self, timeout_s: float = 10.0) -> None:
        """Let the publishing process publish what it has, withdraw the node from the graph
        and exit; wait for that (idempotent)."""
        if self._closed:
            return
        with self._lock:
            with contextlib.suppress(OSError, TimeoutError):
                self._write_tail(True)
            self._closed = True
            assert self._proc.stdin is not None
            with contextlib.suppress(OSError):
                self._proc.stdin.close()  # the end of its input: it finishes and exits
            os.close(self._wake_fd)  # which wakes it
        self._reader.join(timeout_s)
        try:
            self._proc.wait(max(0.1, timeout_s / 10))
        except subprocess.TimeoutExpired:
            logger.warning("ROS 2 output: its process did not finish; it is stopped")
            self._proc.kill()
            self._proc.wait()
        if self._proc.stdout is not None:
            self._proc.stdout.close()
        forget_in_forks(self)

    def _forked(self) -> None:
        """In a process forked from the run's: let go of the publishing process, as
        :meth:`FoxgloveServer._forked <pirate_bt.interop.foxglove_server.FoxgloveServer._forked>`
        does (its pipes kept it running after :meth:`close`, which waited 11 s, then
        killed it)."""
        self._closed = True
        pipes = (pipe.fileno() for pipe in (self._proc.stdin, self._proc.stdout) if pipe)
        to_null(self._wake_fd, *pipes)

    def __enter__(self) -> Ros2Node:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
