"""A run live in Foxglove: the trace's topics over the Foxglove WebSocket protocol.

``pirate-bt run|mission|teleop|sim ... --foxglove [HOST:PORT]`` starts a
:class:`FoxgloveServer` (``foxglove-sdk``, the ``foxglove`` extra) on
127.0.0.1:8765 by default. Foxglove or Lichtblick connect to
``ws://HOST:PORT`` ("Open connection" → "Foxglove WebSocket") and see the same
topics as in an MCAP file of the run (:mod:`pirate_bt.interop.foxglove_topics`),
made from the same records: :func:`attach_foxglove` puts a
:class:`~pirate_bt.trace.TraceRecorder` on the runner whose format writer
(:class:`LiveWriter`) publishes each record's messages instead of storing them.

The robot comes first. Publishing runs in the tick's thread, but the SDK only
queues a message (per client, at most ``message_backlog_size``; the oldest is
dropped when a slow client falls behind) and sends it from its own threads. A
message for a topic nobody subscribed to is not even encoded. Any error while
publishing is logged once and the live view is switched off; it never reaches
the tick. A client that subscribes late is sent the last message of every
whole-value topic (the run, the state, link health...) and a snapshot of every
node's status.

The server is read-only: it advertises no services, parameters or client
publishing, so a client can watch but cannot send anything to the robot.
"""

from __future__ import annotations

import errno
import json
import logging
import socket
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop.foxglove_option import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    add_foxglove_option,
    parse_address,
)
from pirate_bt.interop.foxglove_schemas import RUN, SIM
from pirate_bt.interop.foxglove_topics import (
    TOPICS,
    TopicMapper,
    TopicMessage,
    encode_message,
    missing_extra,
    schema_of,
)
from pirate_bt.trace.records import TickExtras
from pirate_bt.trace.sink import TraceFormatWriter
from pirate_bt.trace.writer import TraceRecorder

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "FoxgloveServer",
    "LiveWriter",
    "add_foxglove_option",
    "attach_foxglove",
    "parse_address",
    "publish_simulator",
    "serve_supervisor",
]

logger = logging.getLogger(__name__)


def _load_sdk() -> Any:
    try:
        import foxglove
        import foxglove.websocket
    except ImportError:
        raise ConfigurationError(missing_extra("--foxglove", "foxglove-sdk")) from None
    return foxglove


def _port_free(host: str, port: int) -> None:
    """Raise a clear error when ``host:port`` cannot be listened on (the SDK's is vague)."""
    if port == 0:
        return
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except OSError as exc:
        raise InputError(f"--foxglove {host}:{port}: unknown host: {exc}") from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise InputError(
                    f"--foxglove {host}:{port}: the port is taken (another server, or another"
                    " run with --foxglove?); pick another with --foxglove HOST:PORT"
                ) from None
            raise InputError(f"--foxglove {host}:{port}: cannot listen: {exc.strerror}") from None


class FoxgloveServer:
    """A Foxglove WebSocket server with one channel per pirate_bt topic.

    Args:
        host: Interface to listen on (``0.0.0.0`` for every one).
        port: TCP port; 0 picks a free one (see :attr:`port`).
        name: Server name shown in Foxglove.
        message_backlog_size: Messages queued per client before the oldest is dropped.

    Raises:
        ConfigurationError: ``foxglove-sdk`` is missing.
        InputError: the port is taken or the host cannot be listened on.
    """

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        *,
        name: str = "pirate_bt",
        message_backlog_size: int = 1024,
    ) -> None:
        foxglove = _load_sdk()
        _port_free(host, port)
        self.host = host
        self._context = foxglove.Context()
        self._channels: dict[str, Any] = {}
        for topic in TOPICS:
            schema_name, schema = schema_of(topic)
            self._channels[topic] = foxglove.Channel(
                topic,
                schema=foxglove.Schema(
                    name=schema_name,
                    encoding="jsonschema",
                    data=json.dumps(schema).encode("utf-8"),
                ),
                message_encoding="json",
                context=self._context,
            )
        self.mapper = TopicMapper()
        self._lock = threading.Lock()
        self._late: set[str] = set()
        self.subscriptions = 0
        """Subscriptions made so far (all clients)."""
        self.enabled = True
        """False once publishing failed (the run goes on without the live view)."""
        try:
            self._server = foxglove.start_server(
                name=name,
                host=host,
                port=port,
                server_listener=_Listener(self),
                context=self._context,
                message_backlog_size=message_backlog_size,
            )
        except Exception as exc:  # the SDK raises its own RuntimeError for a failed bind
            raise InputError(f"--foxglove {host}:{port}: cannot start the server: {exc}") from None
        self.port: int = int(self._server.port)
        """The port it listens on."""
        logger.info("Foxglove WebSocket server on ws://%s:%d", host, self.port)

    @property
    def url(self) -> str:
        """``ws://HOST:PORT`` for Foxglove's "Open connection"."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    def _subscribed(self, topic: str) -> None:
        with self._lock:
            self._late.add(topic)
            self.subscriptions += 1

    def publish_record(self, record: Mapping[str, Any]) -> None:
        """Publish one trace record's messages; never raises (see the module docstring)."""
        if not self.enabled:
            return
        try:
            messages = self.mapper.messages(record)
            if record.get("type") == "header":
                with self._lock:
                    self._late.discard(RUN)  # sent now anyway
            self._send_late()
            for message in messages:
                self._send(message)
        except Exception:
            self.enabled = False
            logger.exception("Foxglove live view: publishing failed; it is switched off")

    def publish(self, message: TopicMessage) -> None:
        """Publish one message that does not come from a trace record (``pirate-bt sim``)."""
        if not self.enabled:
            return
        try:
            self.mapper.last[message.topic] = message
            self._send_late()
            self._send(message)
        except Exception:
            self.enabled = False
            logger.exception("Foxglove live view: publishing failed; it is switched off")

    def _send_late(self) -> None:
        if not self._late:
            return
        with self._lock:
            topics, self._late = self._late, set()
        for topic in topics:
            snapshot = self.mapper.snapshot(topic)
            if snapshot is not None:
                self._send(snapshot)

    def _send(self, message: TopicMessage) -> None:
        channel = self._channels[message.topic]
        if channel.has_sinks():
            channel.log(encode_message(message.message), log_time=message.log_time_ns)

    def close(self) -> None:
        """Stop the server (idempotent)."""
        server, self._server = getattr(self, "_server", None), None
        if server is not None:
            try:
                server.stop()
            except Exception:  # pragma: no cover - stopping must not fail a run's end
                logger.exception("Foxglove live view: stopping the server failed")

    def __enter__(self) -> FoxgloveServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Listener:
    """The SDK's server listener: notes subscriptions (called from the SDK's threads)."""

    def __init__(self, server: FoxgloveServer) -> None:
        self._server = server

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self._server._subscribed(str(channel.topic))

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        return None


class _Nowhere:
    """The file a :class:`LiveWriter` does not have."""

    closed = False

    def close(self) -> None:
        self.closed = True


class LiveWriter(TraceFormatWriter):
    """A trace format writer that publishes records to a :class:`FoxgloveServer`.

    Hand it to :class:`~pirate_bt.trace.TraceRecorder` as an open writer (it runs
    in-process). It never raises from :meth:`write_line`.
    """

    def __init__(self, server: FoxgloveServer) -> None:
        # No file: TraceFormatWriter.__init__ (which opens one) is not called.
        self.server = server
        self.path = Path(server.url)
        self.sync = False
        self._file = _Nowhere()  # type: ignore[assignment]

    def _open(self, fd: int | None) -> IO[bytes]:  # pragma: no cover - never called
        raise NotImplementedError

    def write_line(self, line: str) -> None:
        """Publish the record given as its JSON text."""
        try:
            record = json.loads(line)
        except ValueError:
            logger.warning("Foxglove live view: not a record: %.80s", line)
            return
        self.server.publish_record(record)

    def close(self) -> None:
        """Nothing to close: the server outlives the recorder (its owner stops it)."""
        self._file.close()


def attach_foxglove(
    runner: Any,
    server: FoxgloveServer,
    *,
    extras: Callable[[Any], TickExtras | None] | None = None,
    **options: Any,
) -> TraceRecorder | None:
    """Publish every tick of ``runner`` on ``server``, as :func:`~pirate_bt.trace.attach_trace`.

    Errors are logged and switch the live view off; they never reach the tick.

    Args:
        runner: A :class:`pirate_bt.runner.Runner` (not yet run).
        server: The server.
        extras: What else happened in a tick (see ``attach_trace``).
        **options: Passed to :class:`~pirate_bt.trace.TraceRecorder`.

    Returns:
        The recorder, or ``None`` if it could not be made (logged).
    """
    from pirate_bt.trace.attach import outcome_of_result

    options.setdefault("tick_period_s", runner.period_s)
    try:
        recorder = TraceRecorder(
            LiveWriter(server), runner.tree, clock=runner.clock, background=False, **options
        )
    except Exception:
        logger.exception("Foxglove live view: cannot record this run; it is not shown")
        return None
    alive = [True]

    def post_tick(info: Any) -> None:
        if not alive[0]:
            return
        try:
            recorder.record_tick(extras(info) if extras is not None else None)
        except Exception:
            alive[0] = False
            logger.exception("Foxglove live view: recording a tick failed; it is switched off")

    def finish(result: Any) -> None:
        try:
            recorder.close(outcome_of_result(result), reason=getattr(result, "message", None))
        except Exception:
            logger.exception("Foxglove live view: closing failed")

    runner.add_post_tick(post_tick)
    runner.add_finish(finish)
    return recorder


def publish_simulator(
    server: FoxgloveServer, simulator: Any, *, period_s: float = 0.05
) -> Callable[[], None]:
    """Publish a simulator's counters and truth on ``/pirate/sim`` from a thread.

    For ``pirate-bt sim``, which has no tree: the thread reads
    ``simulator.counters()`` and ``simulator.truth()`` (both take the simulator's
    lock) every ``period_s`` of wall time.

    Returns:
        A function that stops the thread.
    """
    from pirate_bt.trace.attach import counter_values
    from pirate_bt.trace.structure import jsonable

    stop = threading.Event()
    start_ns = time.time_ns()
    clock0 = simulator.clock.now()

    def loop() -> None:
        n = 0
        while not stop.wait(period_s):
            try:
                truth = simulator.truth()
                n += 1
                t_s = round(simulator.clock.now() - clock0, 6)
                message: dict[str, Any] = {"n": n, "t_s": t_s}
                message.update(counter_values(simulator.counters()))
                message["truth"] = {
                    "front_m": truth.front_m,
                    "velocity_mps": truth.velocity_mps,
                    "rotation_rad": truth.rotation_rad,
                    "joint_angle_rad": dict(truth.joint_angle_rad),
                    "slipping": truth.slipping,
                    "sliding": truth.sliding,
                    "diameter_m": truth.diameter_m,
                    "slope_rad": truth.slope_rad,
                }
                message = jsonable(message)
                server.publish(TopicMessage(SIM, start_ns + round(t_s * 1e9), message))
            except Exception:
                logger.exception("Foxglove live view: reading the simulator failed; stopped")
                return

    thread = threading.Thread(target=loop, name="pirate-foxglove-sim", daemon=True)
    thread.start()

    def halt() -> None:
        stop.set()
        thread.join(timeout=2.0)

    return halt


def serve_supervisor(
    server: FoxgloveServer, supervisor: Any, *, name: str = "teleop", robot: Any = None
) -> Callable[[], None]:
    """A function to call once per tick that publishes a supervisor's state, verdicts, link.

    For ``pirate-bt teleop``, where the operator drives and no tree may run: the
    records come from a recorder over a one-node tree named ``name``. Errors are
    logged and switch the live view off; they never reach the caller.
    """
    import py_trees

    from pirate_bt.trace.attach import supervised_extras

    simulator = getattr(supervisor, "simulator", None)
    extras = supervised_extras(
        supervisor, counters=simulator.counters if simulator is not None else None
    )
    root = py_trees.behaviours.Running(name=name)
    recorder = TraceRecorder(
        LiveWriter(server), root, clock=supervisor.clock, background=False, robot=robot
    )
    alive = [True]

    def tick() -> None:
        if not alive[0]:
            return
        try:
            recorder.record_tick(extras(None))
        except Exception:
            alive[0] = False
            logger.exception("Foxglove live view: recording a tick failed; it is switched off")

    return tick
