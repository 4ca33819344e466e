"""The Foxglove live server's process: records in on a pipe, topics out over WebSocket.

``--foxglove`` costs the run's process little because the server lives in a
process of its own (this file run as a script, ``python -I foxglove_process.py
CONFIG``), started by :class:`pirate_bt.interop.foxglove_live.FoxgloveServer`.
The run's recorders only capture what moved in each tick and hand it over, as
they hand it to the trace's writer process (:mod:`pirate_bt.trace.sink`); this
process encodes each tick record (:class:`~pirate_bt.trace.sink.TickEncoder`),
maps records to topic messages
(:class:`~pirate_bt.interop.foxglove_topics.TopicMapper`), serialises them and
gives them to the ``foxglove-sdk`` server, which queues them per client and
sends them from its own threads. It imports the standard library, the SDK and
those modules (behind stand-in packages, so that the package ``__init__``
modules, which import py_trees and more, do not run).

Messages in both directions are framed as on the trace's pipe
(:func:`pirate_bt.trace.sink.frame`: a 4-byte length, then ``marshal``):

from the run's process (standard input)
    ``(STREAM, stream, message)``: a message of the trace's writer protocol
    (``SETUP``, ``LINE``, ``TICK``, ``END``) from one recorder; each recorder is
    a stream with its own encoder, and all share one mapper, as the topics do.
    ``(DROPPED, stream, count)``: ticks of ``stream`` that were merged into later
    ones because this process lagged (sent before its ``END``, which then carries
    ``dropped``).
    ``(RECORD, record)``: a trace record as data; ``(MESSAGE, topic, log_time_ns,
    message)``: a message that comes from no record (``pirate-bt sim``).
    The end of the input ends the process: it publishes what it has, stops the
    server and exits.
to the run's process (standard output)
    ``(READY, port)``, or ``(FAILED, text)`` when the server could not start;
    ``(SUBSCRIBED, total)`` after subscriptions (at most once per :data:`LATE_S`);
    ``(OFF, text)`` when publishing failed (nothing more is published; the input is
    still read to its end);
    ``(CLOSED, published, cpu_s)`` last.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

if not __package__:  # run as the server process's script
    import types

    _here = os.path.dirname(os.path.realpath(__file__))
    for _name, _folder in (
        ("pirate_bt", os.path.dirname(_here)),
        ("pirate_bt.interop", _here),
        ("pirate_bt.trace", os.path.join(os.path.dirname(_here), "trace")),
    ):
        _package = types.ModuleType(_name)
        _package.__path__ = [_folder]
        sys.modules[_name] = _package

from pirate_bt.interop.foxglove_schemas import (
    BLACKBOARD,
    RUN,
    TOPICS,
    encode_message,
    schema_of,
)
from pirate_bt.interop.foxglove_topics import TopicMapper, TopicMessage
from pirate_bt.interop.groot2_relay import room_for_connections
from pirate_bt.interop.process_pipe import PipeOutput
from pirate_bt.trace.sink import END, LINE, SETUP, TICK, TickEncoder, read_messages

__all__ = [
    "CLOSED",
    "DROPPED",
    "FAILED",
    "LATE_S",
    "LOG_LINES",
    "MESSAGE",
    "NICE",
    "OFF",
    "POLL_S",
    "READY",
    "RECORD",
    "RELISTEN_S",
    "STOP_S",
    "STREAM",
    "SUBSCRIBED",
    "main",
]

# run's process -> server process (beside the trace's SETUP, LINE, TICK, END inside STREAM)
STREAM, DROPPED, RECORD, MESSAGE = 20, 21, 22, 23
# server process -> run's process
READY, FAILED, SUBSCRIBED, OFF, CLOSED = 30, 31, 32, 33, 34

NICE = 5
"""How much nicer than the run this process is (``os.nice``)."""

POLL_S = 0.005
"""How long the process rests after each batch read off its input: it is not woken by
every tick, and a message waits at most this long before it goes out."""

LATE_S = 0.05
"""The shortest time between two rounds of snapshots for late subscribers.

The SDK sends a channel's messages to every client subscribed to it, so each round goes
to every subscriber of those topics. A client subscribing and unsubscribing in a loop
(thousands a second) made a round for nearly every one: other clients were sent the
run's header and state hundreds of times a second, and the run's process was told of
each subscription. Rounds are at most this often now, and the run's process is told the
total once per round (:meth:`Server.subscribed`)."""

LOG_LINES = 10
"""The SDK's log lines written to the run's standard error per minute at most."""

RELISTEN_S = 1.0
"""How often the process looks whether the SDK's server still listens
(:meth:`Server._relisten_loop`)."""

STOP_S = 2.0
"""How long stopping the SDK's server may take before the process exits without it.

The SDK's ``stop()`` closes each client's connection in turn and waits for it: a client
that subscribed and reads nothing (a frozen app, a laptop asleep, a hostile peer), with
its queue and socket full, held it for ever; the run's process waited 11 s at its end,
said "its process did not finish" and killed it. Past this bound the process exits, and
the kernel closes what is left."""


class _FewLines(logging.Handler):
    """The SDK's log (``foxglove.*``: a client's invalid message, a lost connection) to
    standard error, at most :data:`LOG_LINES` lines a minute.

    Unconfigured, Python's last-resort handler wrote every record: a client sending
    invalid messages in a loop wrote a line for each into the run's terminal (the
    operator console's included), as fast as it could send them.
    """

    def __init__(self, per_minute: int = LOG_LINES) -> None:
        super().__init__(logging.WARNING)
        self.per_minute = per_minute
        self.window = -60.0
        self.written = 0
        self.dropped = 0

    def emit(self, record: logging.LogRecord) -> None:
        now = time.monotonic()
        if now - self.window >= 60.0:
            self.window, self.written, self.dropped = now, 0, 0
        if self.written >= self.per_minute:
            self.dropped += 1
            return
        self.written += 1
        text = f"foxglove server: {record.getMessage()}"
        if self.written == self.per_minute:
            text += " (more of the server's log lines this minute are left out)"
        try:
            sys.stderr.write(text + "\n")
            sys.stderr.flush()
        except (OSError, ValueError):  # the run's standard error is gone
            pass


def _quiet_sdk_log() -> None:
    sdk = logging.getLogger("foxglove")
    sdk.addHandler(_FewLines())
    sdk.propagate = False
    _said.addHandler(_FewLines())  # its own few lines: never crowded out by the SDK's
    _said.propagate = False


_said = logging.getLogger("pirate_bt.interop.foxglove_process")
"""What this process itself says on standard error (as the SDK's lines are written)."""


class Server:
    """The SDK's server with a channel per topic, fed with records."""

    def __init__(self, foxglove: Any, config: Mapping[str, Any], out: PipeOutput) -> None:
        self.out = out
        self.context = foxglove.Context()
        self.channels: dict[str, Any] = {}
        for topic in TOPICS:
            schema_name, schema = schema_of(topic)
            self.channels[topic] = foxglove.Channel(
                topic,
                schema=foxglove.Schema(
                    name=schema_name,
                    encoding="jsonschema",
                    data=json.dumps(schema).encode("utf-8"),
                ),
                message_encoding="json",
                context=self.context,
            )
        self.fail_publishing = bool(config.get("fail_publishing"))
        self.mapper = TopicMapper()
        self.encoders: dict[int, TickEncoder] = {}
        self.dropped: dict[int, int] = {}
        self.lock = threading.Lock()
        self.handling = threading.Lock()
        """Held while the main thread handles a message, and while :meth:`_late_loop`
        sends late subscribers their snapshots (the mapper is not shared otherwise)."""
        self.late: set[str] = set()
        self.late_asked = threading.Event()
        self.last_round = -LATE_S
        """When the last snapshots for late subscribers were sent (``time.monotonic``)."""
        self.subscriptions = 0
        self.published = 0
        self.enabled = True
        listener = _Listener(self)

        def start(port: int) -> Any:
            return foxglove.start_server(
                name=str(config["name"]),
                host=str(config["host"]),
                port=port,
                server_listener=listener,
                context=self.context,
                message_backlog_size=int(config["backlog"]),
            )

        self.server: Any = start(int(config["port"]))
        self.port = int(self.server.port)
        threading.Thread(target=self._late_loop, name="pirate-foxglove-late", daemon=True).start()
        self.closing = threading.Event()
        self.swap = threading.Lock()
        """Held while the server is started again (:meth:`_relisten_loop`) or closed."""
        self.tables = _tcp_tables()
        if self.tables:
            threading.Thread(
                target=self._relisten_loop,
                args=(start,),
                name="pirate-foxglove-listen",
                daemon=True,
            ).start()

    def _relisten_loop(self, start: Callable[[int], Any]) -> None:
        """Start the SDK's server again where it stopped listening, on the same port.

        foxglove-sdk's server stops listening for good when an accept fails for want of
        descriptors: until 2026-12-01 a client holding more connections than this
        process may have open (its hard limit, ``ulimit -Hn``) left every later client
        refused for the rest of the run, even once it had gone. Every
        :data:`RELISTEN_S` this thread looks whether the port still listens (the
        kernel's table of TCP sockets, read through descriptors kept open for it); where
        it does not, the old server is stopped (in a thread of its own: its clients'
        connections are closed, which frees their descriptors; a connection that never
        finished its handshake may hold its stop) and a new one listens on the same port
        as soon as a descriptor is free. Clients reconnect by themselves.
        """
        while not self.closing.wait(RELISTEN_S):
            if self._listening() is not False:
                continue
            with self.swap:
                if self.closing.is_set():
                    return
                old, self.server = self.server, None
                if old is not None:
                    _said.warning(
                        "port %d stopped listening (a client held more connections than"
                        " this process may open); it listens again as soon as it can",
                        self.port,
                    )
                    threading.Thread(target=_stop_quietly, args=(old,), daemon=True).start()
                try:
                    self.server = start(self.port)
                except Exception:  # no descriptor free yet, or the port taken: later
                    continue

    def _listening(self) -> bool | None:
        """Whether something listens on :attr:`port` (``None``: cannot tell)."""
        suffix = f":{self.port:04X}".encode()
        for table in self.tables:
            try:
                table.seek(0)
                text = table.read()
            except OSError:
                return None
            for line in text.split(b"\n")[1:]:
                fields = line.split()
                if len(fields) > 3 and fields[3] == b"0A" and fields[1].endswith(suffix):
                    return True
        return False

    def subscribed(self, topic: str) -> None:
        """Note a subscription (from the SDK's thread); :meth:`_late_loop` acts on it."""
        with self.lock:
            self.late.add(topic)
            self.subscriptions += 1
        self.late_asked.set()

    def _late_loop(self) -> None:
        """Tell the run's process how many subscriptions there were, and send late
        subscribers their snapshot even when no record comes (the run ended, the server
        outlives it, or a breakpoint holds the tree); while records come, the next one
        sends it first. Both at most once per :data:`LATE_S`, however fast clients
        subscribe."""
        told = 0
        while True:
            self.late_asked.wait()
            time.sleep(POLL_S)  # out of the SDK's callback, with the subscription in place
            self.late_asked.clear()
            with self.lock:
                total = self.subscriptions
            if total != told:
                told = total
                self.out.send((SUBSCRIBED, total))
            time.sleep(max(0.0, self.last_round + LATE_S - time.monotonic()))
            with self.handling:
                if not self.enabled:
                    continue
                try:
                    self._send_late()
                except Exception as exc:
                    self._off(exc)
            if self.late:  # a round came just before: the next one sends it
                self.late_asked.set()

    def handle(self, message: tuple[Any, ...]) -> None:
        """One message off the input (see the module docstring)."""
        kind = message[0]
        if kind == STREAM:
            self._stream(message[1], message[2])
        elif kind == RECORD:
            self.publish_record(message[1])
        elif kind == MESSAGE:
            _, topic, log_time_ns, data = message
            self.publish(TopicMessage(topic, int(log_time_ns), data))
        elif kind == DROPPED:
            self.dropped[message[1]] = int(message[2])

    def _stream(self, stream: int, message: tuple[Any, ...]) -> None:
        kind = message[0]
        if kind == TICK:
            encoder = self.encoders.get(stream)
            line = encoder.encode(message) if encoder is not None else None
            if line is not None:
                self.publish_record(json.loads(line))
        elif kind == LINE:
            self.publish_record(json.loads(message[1]))
        elif kind == END:
            record = json.loads(message[1])
            dropped = self.dropped.pop(stream, 0)
            if dropped:
                record["dropped"] = dropped
            self.encoders.pop(stream, None)
            self.publish_record(record)
        elif kind == SETUP:
            _, ids, every_tick, full_state, readings, link_fields = message
            self.encoders[stream] = TickEncoder(
                ids,
                every_tick=every_tick,
                full_state=full_state,
                readings=readings,
                link_fields=link_fields,
            )

    def publish_record(self, record: Mapping[str, Any]) -> None:
        if not self.enabled:
            return
        try:
            messages = self.mapper.messages(record)
            if record.get("type") == "header":
                with self.lock:
                    self.late.discard(RUN)  # sent now anyway
            self._send_late()
            for message in messages:
                self._send(message)
        except Exception as exc:
            self._off(exc)

    def publish(self, message: TopicMessage) -> None:
        if not self.enabled:
            return
        try:
            self.mapper.last[message.topic] = message
            self._send_late()
            self._send(message)
        except Exception as exc:
            self._off(exc)

    def _off(self, exc: Exception) -> None:
        self.enabled = False
        import traceback  # only when something failed

        traceback.print_exc()
        self.out.send((OFF, f"{type(exc).__name__}: {exc}"))

    def _send_late(self) -> None:
        if not self.late or time.monotonic() - self.last_round < LATE_S:
            return
        with self.lock:
            topics, self.late = self.late, set()
        self.last_round = time.monotonic()
        for topic in topics:
            snapshot = self.mapper.snapshot(topic)
            if snapshot is not None:
                self._send(snapshot)

    def _send(self, message: TopicMessage) -> None:
        if self.fail_publishing:
            raise RuntimeError("publishing fails on purpose (fail_publishing)")
        channel = self.channels[message.topic]
        if channel.has_sinks():  # a topic nobody subscribed to is not even encoded
            data = encode_message(message.message)
            if message.topic == BLACKBOARD and len(data) > LIVE_BLACKBOARD_BYTES:
                data = encode_message(_shortened(message.message, len(data)))
            channel.log(data, log_time=message.log_time_ns)
            self.published += 1

    def close(self, within_s: float = STOP_S) -> None:
        """Stop the SDK's server, waiting at most ``within_s`` for it (:data:`STOP_S`)."""
        with self.swap:  # not started again meanwhile
            self.closing.set()
            server, self.server = self.server, None
        if server is None:
            return
        stopper = threading.Thread(
            target=_stop_quietly, args=(server, True), name="pirate-foxglove-stop", daemon=True
        )
        stopper.start()
        stopper.join(within_s)


def _stop_quietly(server: Any, say: bool = False) -> None:
    """Stop an SDK server; a failure is printed when ``say`` (it must not hide what was
    published)."""
    try:
        server.stop()
    except Exception:
        if say:
            import traceback

            traceback.print_exc()


def _tcp_tables() -> list[Any]:
    """The kernel's tables of TCP sockets (``/proc/net/tcp``, ``tcp6``), open for good: read
    when this process may have no descriptor left. None where there are none (not Linux)."""
    tables = []
    for name in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(OSError):
            tables.append(open(name, "rb", buffering=0))  # noqa: SIM115 - kept open
    return tables


class _Listener:
    """The SDK's server listener: notes subscriptions (called from the SDK's threads)."""

    def __init__(self, server: Server) -> None:
        self._server = server

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self._server.subscribed(str(channel.topic))

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        return None


LIVE_BLACKBOARD_BYTES = 64 * 1024
"""The longest ``/pirate/blackboard`` message a live client is sent (JSON bytes): the
largest values are shown shortened (:func:`_shortened`) until it fits."""


def _shortened(board: Mapping[str, Any], size: int) -> dict[str, Any]:
    """A blackboard message of ``size`` bytes of JSON, its largest ``values`` and ``set``
    entries replaced, largest first, by a line saying their size until it is at most
    :data:`LIVE_BLACKBOARD_BYTES`.

    Every change republishes the whole board (its ``values``), and the SDK holds up to
    1,024 messages for a client that does not read: until 2026-12-01 a board holding a
    value of 2 MB, beside a counter set every tick, grew this process by 2 MB a tick
    for such a client (606 MB after 300 ticks). A trace or an MCAP file holds the values
    whole."""
    shortened = dict(board)
    sizes: list[tuple[int, str, str]] = []
    for part in ("values", "set"):
        values = board.get(part)
        if isinstance(values, Mapping):
            shortened[part] = dict(values)
            for key, value in values.items():
                if isinstance(value, str | list | dict):
                    sizes.append((len(encode_message({"": value})) - 5, part, key))
    sizes.sort(reverse=True)
    for value_size, part, key in sizes:
        if size <= LIVE_BLACKBOARD_BYTES:
            break
        line = f"({value_size:,} bytes of JSON: too long for the live view)"
        shortened[part][key] = line
        size -= value_size - len(line) - 2
    return shortened


def main(argv: Sequence[str]) -> int:
    """The server process: ``foxglove_process.py CONFIG`` (JSON); messages on stdin/stdout."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the run's Ctrl-C is for the run
    config = json.loads(argv[1])
    # The robot comes first: on a busy machine this process (and the SDK's threads, made
    # after this) yields the CPU to the run; lagging only merges ticks (foxglove_backlog).
    with contextlib.suppress(OSError):
        os.nice(int(config.get("nice", NICE)))
    # Every client's connection is one of this process's files. At the run's soft limit
    # (1,024 in most shells) foxglove-sdk's server stopped listening for good: until
    # 2026-12-01 a client holding 128 idle connections to a server started under a soft
    # limit of 128 left every later client refused, the run unaware. Its hard limit now
    # (past it the SDK still stops listening).
    room_for_connections()
    out = PipeOutput(sys.stdout.fileno())
    if config.get("sys_path"):
        sys.path[:] = config["sys_path"]  # find the SDK where the run's process found it
    _quiet_sdk_log()  # before the SDK is imported: its log goes through Python's logging
    try:
        import foxglove

        server = Server(foxglove, config, out)
    except Exception as exc:  # the SDK raises its own RuntimeError for a failed bind
        out.send((FAILED, f"{type(exc).__name__}: {exc}"))
        return 1
    out.send((READY, server.port))
    try:
        for message in read_messages(sys.stdin.fileno(), POLL_S):
            with server.handling:
                server.handle(message)
    finally:
        server.close()
        out.send((CLOSED, server.published, time.process_time()))
    return 0


if __name__ == "__main__":
    status = main(sys.argv)
    sys.stderr.flush()
    os._exit(status)  # the server is stopped: no interpreter teardown to wait for
