"""The live Foxglove server: :class:`FoxgloveServer`, the run's side of the server's
process (:mod:`pirate_bt.interop.foxglove_process`).

What it serves and how a run reaches it: :mod:`pirate_bt.interop.foxglove_live`,
which offers every name here (split from it, no change of behaviour).
"""

from __future__ import annotations

import contextlib
import errno
import importlib.util
import json
import logging
import os
import socket
import subprocess
import sys
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop import foxglove_process
from pirate_bt.interop.foxglove_backlog import Feed
from pirate_bt.interop.foxglove_option import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    check_server_args,
)
from pirate_bt.interop.foxglove_process import (
    CLOSED,
    FAILED,
    MESSAGE,
    OFF,
    READY,
    RECORD,
    SUBSCRIBED,
)
from pirate_bt.interop.foxglove_topics import TopicMessage, missing_extra
from pirate_bt.trace.sink import unframe
from pirate_bt.trace.sink_formats import forget_in_forks, let_go_in_forks, to_null

__all__ = ["FoxgloveServer"]

# The server logs as it always did, under the live view's module.
logger = logging.getLogger("pirate_bt.interop.foxglove_live")

_PIPE_BYTES = 1 << 20
_SCRIPT = Path(foxglove_process.__file__).resolve()


def _port_free(host: str, port: int) -> None:
    """Raise a clear error when ``host:port`` cannot be listened on (the SDK's is vague).

    Port 0 too: the host is looked up and an address of this machine asked for (until
    2026-11-30 an unknown host or an address not ours with port 0 started the server's
    process and said ``cannot start the server: RuntimeError: FoxgloveError: Failed to
    bind port: ...``). An IPv6 address is named in brackets (``::1:1700`` is one, read
    with the default port: ``--foxglove [::1:1700]:8765: cannot listen: ...``)."""
    where = f"[{host}]" if ":" in host else host
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as exc:  # IDNA's for a name such as a..b
        raise InputError(f"--foxglove {where}:{port}: unknown host: {exc}") from None
    family, kind, proto, _, address = infos[0]
    try:  # the family too: IPv6 on a machine without it
        probe = socket.socket(family, kind, proto)
    except OSError as exc:
        raise InputError(f"--foxglove {where}:{port}: cannot listen: {exc.strerror}") from None
    with probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise InputError(
                    f"--foxglove {where}:{port}: the port is taken (another server, or another"
                    " run with --foxglove?); pick another with --foxglove HOST:PORT"
                ) from None
            raise InputError(f"--foxglove {where}:{port}: cannot listen: {exc.strerror}") from None


class FoxgloveServer:
    """A Foxglove WebSocket server with one channel per pirate_bt topic, in its own process.

    Returns at once while its process starts the server; with port 0, once the server
    listens (so that :attr:`port` is known).

    Args:
        host: Interface to listen on (``0.0.0.0`` for every one).
        port: TCP port; 0 picks a free one (see :attr:`port`).
        name: Server name shown in Foxglove.
        message_backlog_size: Messages queued per client before the oldest is dropped.

    Raises:
        ConfigurationError: ``foxglove-sdk`` is missing, or no process can be started.
        InputError: the port is taken or the host cannot be listened on; a host or port
            of the wrong kind (``ArgumentTypeError``) or a port out of range.
    """

    _PROCESS_OPTIONS: ClassVar[dict[str, Any]] = {}
    """More settings for the server's process (the tests' ``fail_publishing``)."""

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        *,
        name: str = "pirate_bt",
        message_backlog_size: int = 1024,
        timeout_s: float = 20.0,
    ) -> None:
        if importlib.util.find_spec("foxglove") is None:
            raise ConfigurationError(missing_extra("--foxglove", "foxglove-sdk"))
        check_server_args(host, port)
        _port_free(host, port)
        self.host = host
        self.port: int = port
        """The port it listens on."""
        self.subscriptions = 0
        """Subscriptions made so far (all clients)."""
        self.enabled = True
        """False once publishing failed or the process ended (the run goes on without it)."""
        self.published = 0
        """Messages handed to the SDK (known once closed)."""
        self.process_cpu_s = 0.0
        """The CPU time the server's process spent (known once closed)."""
        self.failure: str | None = None
        """Why the live view was switched off, if it was."""
        self._lock = threading.Lock()
        self._ready = threading.Event()
        self._streams = 0
        self._closed = False
        config = {
            "host": host,
            "port": port,
            "name": name,
            "backlog": message_backlog_size,
            "sys_path": list(sys.path),
            **self._PROCESS_OPTIONS,
        }
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-I", str(_SCRIPT), json.dumps(config)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                start_new_session=True,  # a signal to the run's process group spares it
            )
        except OSError as exc:
            raise ConfigurationError(
                f"--foxglove: cannot start the server's process: {exc}"
            ) from None
        assert self._proc.stdin is not None and self._proc.stdout is not None
        self._fd = self._proc.stdin.fileno()
        with contextlib.suppress(ImportError, OSError):  # room for a lag of many ticks
            import fcntl

            fcntl.fcntl(self._fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), _PIPE_BYTES)
        os.set_blocking(self._fd, False)
        self._feed = Feed(self._fd, self._gone)
        self._reader = threading.Thread(
            target=self._read,
            args=(self._proc.stdout.fileno(),),
            name="pirate-foxglove",
            daemon=True,
        )
        self._reader.start()
        let_go_in_forks(self)
        # The port was free a moment ago (_port_free): only port 0 has to wait to be known;
        # otherwise the server starts while the run is prepared (what is handed over
        # meanwhile waits in the pipe), and a failure is logged and switches the view off.
        if port == 0 and (not self._ready.wait(timeout_s) or self.failure is not None):
            why = self.failure or f"no answer in {timeout_s:g} s"
            self.close()
            where = f"[{host}]" if ":" in host else host
            raise InputError(f"--foxglove {where}:{port}: cannot start the server: {why}")
        logger.info(
            "Foxglove WebSocket server on ws://%s:%d (process %d)", host, self.port, self.pid
        )

    @property
    def url(self) -> str:
        """``ws://HOST:PORT`` for Foxglove's "Open connection"."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    @property
    def pid(self) -> int:
        """The server process's id."""
        return self._proc.pid

    # --- what the server's process says -------------------------------------------------

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
            for message in unframe(buffer):
                self._heard(message)
        if not self._closed and self.enabled:
            self._switch_off(f"its process ended (exit {self._proc.wait()})")
        self._ready.set()

    def _heard(self, message: tuple[Any, ...]) -> None:
        kind = message[0]
        if kind == SUBSCRIBED:
            self.subscriptions = int(message[1])
        elif kind == READY:
            self.port = int(message[1])
            self._ready.set()
        elif kind == FAILED:
            if self.port == 0:  # the constructor is waiting: it raises
                self.failure, self.enabled = str(message[1]), False
            else:
                self._switch_off(f"the server could not start ({message[1]})")
            self._ready.set()
        elif kind == OFF:
            self._switch_off(f"publishing failed ({message[1]})")
        elif kind == CLOSED:
            self.published, self.process_cpu_s = int(message[1]), float(message[2])
            logger.info(
                "Foxglove live view: %d messages published, %d dropped, %.3f s of CPU in its"
                " process",
                self.published,
                self.dropped,
                self.process_cpu_s,
            )

    def _gone(self, why: str) -> None:
        code: int | None = None
        with contextlib.suppress(subprocess.TimeoutExpired):  # once: the pipe broke as it died
            code = self._proc.wait(1.0)
        self._switch_off(why.replace("{exit}", str(code)))

    def _switch_off(self, why: str) -> None:
        if not self.enabled and self.failure is not None:
            return  # said once
        self.enabled = False
        self.failure = why
        logger.error("Foxglove live view: %s; it is switched off (the run goes on)", why)

    # --- handing over -------------------------------------------------------------------

    def _stream(self) -> int:
        """A number for a new recorder's messages."""
        with self._lock:
            self._streams += 1
            return self._streams

    @property
    def dropped(self) -> int:
        """Ticks merged into later ones, and simulator messages left out, because the
        server's process lagged (see :mod:`pirate_bt.interop.foxglove_backlog`)."""
        return self._feed.dropped

    def _hand_over(self, stream: int | None, message: tuple[Any, ...]) -> None:
        if not self._closed and self.enabled:
            self._feed.hand_over(stream, message)

    def publish_record(self, record: Mapping[str, Any]) -> None:
        """Publish one trace record as data (it waits for room in the pipe at most a few
        seconds). A record that is no mapping is left out and logged; never raises."""
        if not isinstance(record, Mapping):
            logger.warning(
                "foxglove: a record that is no mapping left out (%s)", type(record).__name__
            )
            return
        try:
            self._hand_over(None, (RECORD, dict(record)))
        except ValueError:  # a value marshal does not carry: as JSON text would have it
            self._hand_over(None, (RECORD, json.loads(json.dumps(dict(record), default=str))))

    def publish(self, message: TopicMessage) -> None:
        """Publish one message that does not come from a trace record (``pirate-bt sim``);
        left out and counted when the pipe is full."""
        if not self._closed and self.enabled:
            self._feed.offer((MESSAGE, message.topic, message.log_time_ns, message.message))

    def close(self, timeout_s: float = 10.0) -> None:
        """Let the server's process publish what it has, stop the server and exit; wait for
        that (idempotent)."""
        if self._closed:
            return
        with self._lock:
            self._feed.flush()
            self._closed = True
            assert self._proc.stdin is not None
            with contextlib.suppress(OSError):
                self._proc.stdin.close()  # the end of its input: it finishes and exits
        self._reader.join(timeout_s)
        try:
            code = self._proc.wait(max(0.1, timeout_s / 10))
        except subprocess.TimeoutExpired:
            logger.warning("Foxglove live view: its process did not finish; it is stopped")
            self._proc.kill()
            self._proc.wait()
        else:
            if code < 0 and self.enabled:
                # killed before it was told to finish, and its reader, told of the close
                # first, never said so: a view that died at the run's end was not said
                self._switch_off(f"its process ended (exit {code})")
        if self._proc.stdout is not None:
            self._proc.stdout.close()
        forget_in_forks(self)

    def _forked(self) -> None:
        """In a process forked from the run's (``multiprocessing``'s ``fork``, a planner's
        ``os.fork``): let go of the server's process. The child's copy of its pipe kept
        it running after :meth:`close`, which waited 11 s for it, then killed it and
        warned that it *did not finish*. The pipe points at ``/dev/null`` here, and
        ``close`` does nothing."""
        self._closed = True
        to_null(*(pipe.fileno() for pipe in (self._proc.stdin, self._proc.stdout) if pipe))

    def __enter__(self) -> FoxgloveServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
