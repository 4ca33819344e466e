"""A run live in Foxglove: the trace's topics over the Foxglove WebSocket protocol.

``pirate-bt run|mission|teleop|sim ... --foxglove [HOST:PORT]`` starts a
:class:`FoxgloveServer` (``foxglove-sdk``, the ``foxglove`` extra) on
127.0.0.1:8765 by default. Foxglove or Lichtblick connect to
``ws://HOST:PORT`` ("Open connection" → "Foxglove WebSocket") and see the same
topics as in an MCAP file of the run (:mod:`pirate_bt.interop.foxglove_topics`),
made from the same records.

The robot comes first. The server runs in a **process of its own**
(:mod:`pirate_bt.interop.foxglove_process`): :func:`attach_foxglove` puts a
:class:`~pirate_bt.trace.TraceRecorder` on the runner that only captures what
moved in each tick and hands it to that process through a pipe, as the trace
hands it to its writer process; the encoding, the mapping to topics, the JSON and
the SDK's sending are that process's work, on another core. The run never waits
for the pipe: when that process lags so far that the pipe (1 MiB) is full, the
tick is merged into one held back for its recorder and counted as dropped
(:mod:`pirate_bt.interop.foxglove_backlog`; :attr:`FoxgloveServer.dropped`, and
``dropped`` in the run's ``/pirate/end`` message). The SDK queues each message
per client (at most ``message_backlog_size``; the oldest is dropped when a slow
client falls behind) and sends it from its own threads; a topic nobody subscribed
to is not even encoded. If publishing fails or the process dies, the live view is
switched off with the cause logged; the run goes on. A client that subscribes late
is sent the last message of every whole-value topic (the run, the state, link
health...) and a snapshot of every node's status.

The server is read-only: it advertises no services, parameters or client
publishing, so a client can watch but cannot send anything to the robot.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from pirate_bt.interop.foxglove_option import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    add_foxglove_option,
    parse_address,
)
from pirate_bt.interop.foxglove_schemas import SIM
from pirate_bt.interop.foxglove_server import _PIPE_BYTES as _PIPE_BYTES
from pirate_bt.interop.foxglove_server import _SCRIPT as _SCRIPT
from pirate_bt.interop.foxglove_server import FoxgloveServer
from pirate_bt.interop.foxglove_server import _port_free as _port_free
from pirate_bt.interop.foxglove_topics import TopicMessage
from pirate_bt.trace.records import LINK_FIELDS, TickExtras
from pirate_bt.trace.sink import END, LINE, SETUP, SinkProcess
from pirate_bt.trace.sink_formats import TraceFormatWriter
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


class _LiveSink(SinkProcess):
    """A recorder's end of the live view: its messages go to the server's process.

    It stands where a recorder keeps its trace's writer process (it is not one: no
    process of its own, see :func:`_live_recorder`).
    """

    def __init__(self, server: FoxgloveServer) -> None:  # no super().__init__: no process
        self.server = server
        self.stream = server._stream()
        self.path = Path(server.url)

    @property
    def pid(self) -> int:
        """The server's process."""
        return self.server.pid

    def send(self, message: tuple[Any, ...]) -> None:
        """Hand one message over (never waits for a tick, never raises but ValueError)."""
        server = self.server
        if message[0] == END and not server._closed and server.enabled:
            merged = server._feed.finish(self.stream, message)
            if merged:
                logger.warning(
                    "Foxglove live view: %d ticks merged into later ones (its process lagged)",
                    merged,
                )
        else:
            server._hand_over(self.stream, message)

    def close(self, timeout_s: float = 60.0) -> None:
        """Nothing to wait for: the server outlives its recorders."""


class _Nowhere:
    """The file a writer without one does not have."""

    closed = False

    def close(self) -> None:
        self.closed = True


class _Lines(TraceFormatWriter):
    """Keeps the lines a recorder writes while it is made (its header)."""

    def __init__(self) -> None:  # no file
        self.path = Path("foxglove")
        self.sync = False
        self.lines: list[str] = []
        self._file = _Nowhere()  # type: ignore[assignment]

    def write_line(self, line: str) -> None:
        self.lines.append(line)


class LiveWriter(TraceFormatWriter):
    """A trace format writer that publishes records to a :class:`FoxgloveServer`.

    For a recorder of your own that must write in-process (``background=False``):
    each record is encoded in the caller's thread and handed to the server's process
    as data. :func:`attach_foxglove` does not use it (its recorder hands over what it
    captured, unencoded). It never raises from :meth:`write_line`.
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


def _live_recorder(server: FoxgloveServer, tree: Any, **options: Any) -> TraceRecorder:
    """A recorder whose messages go to the server's process instead of a writer.

    The recorder is made to write in-process into :class:`_Lines` (which keeps its
    header), then given a :class:`_LiveSink` where a recorder keeps its writer
    process: from then on each tick is captured and handed over, never encoded here.
    """
    lines = _Lines()
    recorder = TraceRecorder(lines, tree, background=False, **options)
    sink = _LiveSink(server)
    ids = recorder.node_ids
    setup = (SETUP, ids, recorder.every_tick, recorder.full_state, recorder.readings)
    sink.send((*setup, list(LINK_FIELDS)))
    for line in lines.lines:
        sink.send((LINE, line))
    recorder.hand_over(sink)
    return recorder


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
        recorder = _live_recorder(server, runner.tree, clock=runner.clock, **options)
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
    recorder = _live_recorder(server, root, clock=supervisor.clock, robot=robot)
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
