"""The ROS 2 publishing process: a Zenoh session that behaves as a ROS 2 node.

``--ros2`` costs the run's process almost nothing because the node lives in a
process of its own (this file run as a script, ``python -I ros2_process.py
CONFIG``), started by :class:`pirate_bt.interop.ros2_node.Ros2Node` when the
option is opened, so that it starts while the run is still being prepared. The
process owns everything ROS 2: the Zenoh session (``eclipse-zenoh``), the
publishers and their liveliness tokens (rmw_zenoh's conventions,
:mod:`pirate_bt.interop.rmw_zenoh`), the mapping from frames to messages
(:mod:`pirate_bt.interop.ros2_topics`), their CDR
(:mod:`pirate_bt.interop.ros2_cdr`) and the e-stop subscription. It imports the
standard library, Zenoh and those four modules (stand-in packages keep the
package ``__init__`` modules, which import py_trees and more, from running), so
it is ready in well under 0.1 s of CPU.

Messages in both directions are a 4-byte little-endian length and a
``marshal``\\ led tuple whose first item says which:

from the run's process (standard input)
    ``(SETUP, run, shape, start_ns, hardware_id, period_s)``: a runner's tree
    (:meth:`~pirate_bt.interop.ros2_topics.TreeShape.to_wire`) and clock; the
    frames of ``run`` follow.
    ``(FRAME, run, final, n, t_s, state, link, sim, task, supervisor, statuses,
    feedback, blackboard)``: one moment; ``statuses`` is every node's status
    code in the shape's order, ``feedback`` ``(index, text)`` pairs and
    ``blackboard`` a mapping, all three ``None`` in the frames that leave the
    tree out.
    ``(FLUSH, token)``: answer ``FLUSHED`` once everything before it is out.
    The end of the input ends the process: it publishes what it still has,
    withdraws the node from the graph and exits.
to the run's process (standard output)
    ``(READY, session_id)``; ``(FAILED, text, kind)`` instead when the set-up
    failed: ``kind`` is ``"config"`` (no Zenoh), ``"input"`` (the session
    could not be opened: a bad endpoint) or ``"setup"`` (anything after);
    ``(BOOL, data, monotonic_ns, count)`` for the ``std_msgs/Bool`` messages on
    the e-stop topic: ``count`` of them since the last, ``data`` true when one of
    them was, with when the first such arrived here (``time.monotonic_ns``, one
    clock for every process of the machine); at most one every
    :data:`ESTOP_GAP_NS` (:class:`_EStopForward`); ``(OFF, text)`` when publishing failed (the
    process publishes nothing more, the e-stop subscription stays);
    ``(WARN, text)`` for something the run's log should say (a message on the
    e-stop topic too short to read);
    ``(REACH, reached)`` when the session reaches no router or peer a moment after
    it opened, and whenever that changes (:mod:`~pirate_bt.interop.ros2_reach`);
    ``(FLUSHED, token, published)``; ``(CLOSED, published, cpu_s)`` last, with
    the CPU time the process spent (all its threads, Zenoh's included).

When more frames wait than it has published, it publishes the newest frame of
each run and drops the older ones (but the newest that holds the tree, which
goes out with the values it was read with), and after each batch it rests 49
times as long as the batch took (a 2 % duty cycle of one core, however big the
tree).
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from typing import Any

if not __package__:  # run as the publishing process's script
    # ``python -I ros2_process.py``: stand-in packages let this file import its
    # siblings without running the package's ``__init__`` modules.
    import types

    for _name, _folder in (
        ("pirate_bt", os.path.dirname(os.path.dirname(os.path.realpath(__file__)))),
        ("pirate_bt.interop", os.path.dirname(os.path.realpath(__file__))),
        (
            "pirate_bt.trace",
            os.path.join(os.path.dirname(os.path.dirname(os.path.realpath(__file__))), "trace"),
        ),
    ):
        _package = types.ModuleType(_name)
        _package.__path__ = [_folder]
        sys.modules[_name] = _package

from pirate_bt.interop import rmw_zenoh
from pirate_bt.interop.process_pipe import PipeOutput
from pirate_bt.interop.ros2_reach import ReachWatch
from pirate_bt.interop.ros2_topics import TOPIC_TYPES, TREE, Frame, Ros2Mapper, TreeShape
from pirate_bt.interop.ros2_types import dds_type_name, type_hash

# The messages on both pipes are framed as the trace's (length, then ``marshal``).
from pirate_bt.trace.sink import frame as encode_message
from pirate_bt.trace.sink import unframe as decode_messages

__all__ = [
    "BOOL",
    "CLOSED",
    "DUTY",
    "FAILED",
    "FLUSH",
    "FLUSHED",
    "FRAME",
    "OFF",
    "READY",
    "SETUP",
    "decode_messages",
    "encode_message",
    "main",
]

# run's process -> publishing process
SETUP, FRAME, FLUSH = 0, 1, 2
# publishing process -> run's process
READY, FAILED, BOOL, OFF, FLUSHED, CLOSED, WARN = 10, 11, 12, 13, 14, 15, 16

DUTY = 0.02
"""The share of one core the publishing may take: after each batch of frames the
process rests 49 times as long as the batch took."""

LATCHED = frozenset({TREE})
"""Topics late joiners get the last message of (TRANSIENT_LOCAL, depth 1, like
py_trees_ros's snapshot streams)."""

ESTOP_TYPE = "std_msgs/msg/Bool"

MISS_HEARTBEAT_S = 0.5
"""rmw_zenoh's ``SAMPLE_MISS_DETECTION_HEARTBEAT_PERIOD`` for a latched publisher."""

ESTOP_GAP_NS = 2_000_000
"""The shortest time between two messages of the e-stop topic handed to the run's process.

The first after a quiet spell goes at once; those that come sooner are counted and go as
one when the gap is over (a ``true`` among them makes it ``true``). Until 2026-11-30 each
message went over the pipe on its own, and a peer publishing ``false`` as fast as Zenoh
delivers (about 140,000 a second) made the run's process read and count each one: its CPU
time over a 10 s run went from 0.5 s to 2.9 s, in the interpreter the tick runs in."""

WARN_EVERY_NS = 60_000_000_000
"""How often at most a warning about the e-stop topic's messages goes to the run's log."""

_READ_BYTES = 1 << 20


def _print_exc() -> None:
    import traceback  # only when something failed: it costs milliseconds to import

    traceback.print_exc()


def open_session(zenoh: Any, config: dict[str, Any]) -> Any:
    """The Zenoh session of ``config`` (a peer of ``endpoint``, as rmw_zenoh's are)."""
    settings = zenoh.Config()
    for key, value in (
        ("mode", "peer"),
        ("connect/endpoints", [config["endpoint"]]),
        ("listen/endpoints", list(config["listen"])),
        ("scouting/multicast/enabled", False),
        # Advanced publishers (the latched tree topic) sequence by timestamp.
        ("timestamping/enabled", True),
        # Return at once instead of waiting half a second for scouted peers: the
        # session goes on connecting (and reconnecting) in the background.
        ("open/return_conditions/connect_scouted", False),
    ):
        settings.insert_json5(key, json.dumps(value))
    return zenoh.open(settings)


class _Endpoint:
    __slots__ = ("gid", "publisher", "sequence", "token")

    def __init__(self, gid: bytes, publisher: Any, token: Any) -> None:
        self.gid = gid
        self.publisher = publisher
        self.token = token
        self.sequence = 0


class _EStopForward:
    """The e-stop topic's messages to the run's process, at most one every
    :data:`ESTOP_GAP_NS` (a flood of them is read by the run's process as a few).

    :meth:`add` (Zenoh's callback) sends a message at once when the last went at
    least the gap ago; otherwise it only counts it, and a thread of its own sends
    what was counted when the gap is over: a ``true`` is never lost, and waits at
    most the gap.
    """

    def __init__(self, out: PipeOutput, gap_ns: int = ESTOP_GAP_NS) -> None:
        self.out = out
        self.gap_ns = gap_ns
        self._cond = threading.Condition()
        self._count = 0
        self._true_ns = 0
        self._last_ns = 0
        self._sent_ns = -gap_ns
        self._thread: threading.Thread | None = None

    def add(self, data: bool, heard_ns: int) -> None:
        """One message (``data``) heard at ``heard_ns`` (``time.monotonic_ns``)."""
        with self._cond:
            self._count += 1
            self._last_ns = heard_ns
            if data and not self._true_ns:
                self._true_ns = heard_ns
            if time.monotonic_ns() - self._sent_ns < self.gap_ns:
                if self._thread is None:
                    self._thread = threading.Thread(
                        target=self._later, name="pirate-ros2-estop", daemon=True
                    )
                    self._thread.start()
                if self._count == 1:  # the first held back: the thread sends it in time
                    self._cond.notify()
                return
            message = self._take_locked()
        self.out.send(message)

    def _take_locked(self) -> tuple[Any, ...]:
        held = bool(self._true_ns)
        message = (BOOL, held, self._true_ns if held else self._last_ns, self._count)
        self._count = self._true_ns = 0
        self._sent_ns = time.monotonic_ns()
        return message

    def _later(self) -> None:
        while True:
            with self._cond:
                while not self._count:
                    self._cond.wait()
                wait_ns = self._sent_ns + self.gap_ns - time.monotonic_ns()
                if wait_ns > 0:
                    self._cond.wait(wait_ns / 1e9)
                    continue
                message = self._take_locked()
            self.out.send(message)


class Node:
    """The node's publishers, tokens and e-stop subscription in one Zenoh session."""

    def __init__(self, zenoh: Any, session: Any, config: dict[str, Any], out: PipeOutput) -> None:
        self.zenoh = zenoh
        self.session = session
        self.out = out
        self.domain_id = int(config["domain_id"])
        self.namespace = str(config["namespace"])
        self.name = str(config["name"])
        self.fq_estop = str(config["fq_estop"])
        self.estop = bool(config["estop"])
        self.fail_publishing = bool(config.get("fail_publishing"))
        self.session_id = str(session.zid())
        self.endpoints: dict[str, _Endpoint] = {}
        self.tokens: list[Any] = []
        self.subscriber: Any = None
        self._short = 0
        self._short_said_ns = -WARN_EVERY_NS
        self.forward = _EStopForward(out)
        self.published = 0
        self.enabled = True
        self.mappers: dict[int, tuple[Ros2Mapper, tuple[str, ...]]] = {}

    def declare(self) -> None:
        """Declare the node's token, each topic's publisher and token, the e-stop's."""
        zenoh = self.zenoh
        liveliness = self.session.liveliness()
        self.tokens.append(
            liveliness.declare_token(
                rmw_zenoh.node_token(self.domain_id, self.session_id, 0, self.namespace, self.name)
            )
        )
        entity = 0
        for topic, type_name in TOPIC_TYPES.items():
            entity += 1
            fq = rmw_zenoh.qualified_name(self.namespace, topic)
            dds, digest = dds_type_name(type_name), type_hash(type_name)
            key = rmw_zenoh.data_key(self.domain_id, fq, dds, digest)
            latched = topic in LATCHED
            qos = rmw_zenoh.Qos(
                durability=rmw_zenoh.TRANSIENT_LOCAL if latched else rmw_zenoh.VOLATILE,
                depth=1 if latched else 10,
            )
            token_key = rmw_zenoh.endpoint_token(
                self.domain_id,
                self.session_id,
                0,
                entity,
                "MP",
                self.namespace,
                self.name,
                fq,
                dds,
                digest,
                qos,
            )
            if latched:
                import zenoh.ext

                # As rmw_zenoh declares a RELIABLE + TRANSIENT_LOCAL publisher: a cache for
                # late joiners, and sample miss detection with a sporadic heartbeat (500 ms),
                # which its subscriptions' recovery of a lost last sample relies on.
                publisher = zenoh.ext.declare_advanced_publisher(
                    self.session,
                    key,
                    cache=zenoh.ext.CacheConfig(max_samples=1),
                    publisher_detection=True,
                    sample_miss_detection=zenoh.ext.MissDetectionConfig(
                        heartbeat=None, sporadic_heartbeat=MISS_HEARTBEAT_S
                    ),
                )
            else:
                publisher = self.session.declare_publisher(
                    key, congestion_control=zenoh.CongestionControl.DROP
                )
            token = liveliness.declare_token(token_key)
            self.endpoints[topic] = _Endpoint(rmw_zenoh.entity_gid(token_key), publisher, token)
        if self.estop:
            entity += 1
            dds, digest = dds_type_name(ESTOP_TYPE), type_hash(ESTOP_TYPE)
            key = rmw_zenoh.data_key(self.domain_id, self.fq_estop, dds, digest)
            self.tokens.append(
                liveliness.declare_token(
                    rmw_zenoh.endpoint_token(
                        self.domain_id,
                        self.session_id,
                        0,
                        entity,
                        "MS",
                        self.namespace,
                        self.name,
                        self.fq_estop,
                        dds,
                        digest,
                        rmw_zenoh.Qos(depth=10),
                    )
                )
            )
            # Any type hash: an e-stop that may have been meant is taken. A Humble node's
            # rmw_zenoh puts it under "TypeHashNotSupported" (Humble has no type hashes),
            # a node with another Bool definition under another hash; the exact key
            # would miss both, silently. The message is read the same way (_on_estop).
            any_hash = key.rsplit("/", 1)[0] + "/*"
            self.subscriber = self.session.declare_subscriber(any_hash, self._on_estop)

    def _on_estop(self, sample: Any) -> None:
        heard = time.monotonic_ns()
        try:
            payload = bytes(sample.payload.to_bytes())
            # CDR: 4-byte encapsulation header, then the bool as one byte.
            if len(payload) < 5:
                # said by the run's process, in its log (this one has none), once a
                # minute at most: a peer sending them in a loop wrote a line for each
                self._short += 1
                if heard - self._short_said_ns >= WARN_EVERY_NS:
                    more = f" ({self._short} since the last warning)" if self._short > 1 else ""
                    self.out.send(
                        (WARN, f"e-stop: a message too short to be a std_msgs/Bool{more}")
                    )
                    self._short, self._short_said_ns = 0, heard
                return
            self.forward.add(payload[4] != 0, heard)
        except Exception:  # Zenoh's thread must not die
            _print_exc()

    # --- frames ------------------------------------------------------------------------------

    def handle(self, batch: Sequence[tuple[Any, ...]]) -> None:
        """Publish a batch of messages, the newest frame of each run (module docstring)."""
        # A frame is left out when a newer one of its run follows, unless it holds the
        # tree and no newer one does (a tree goes out with the frame it was read in).
        newest: set[int] = set()
        newest_tree: set[int] = set()
        superseded: set[int] = set()
        for index in range(len(batch) - 1, -1, -1):
            message = batch[index]
            if message[0] == FLUSH:
                newest.clear()
                newest_tree.clear()
            elif message[0] == FRAME:
                run, has_tree = message[1], message[10] is not None
                if run in newest and (not has_tree or run in newest_tree):
                    superseded.add(index)
                newest.add(run)
                if has_tree:
                    newest_tree.add(run)
        for index, message in enumerate(batch):
            kind = message[0]
            if kind == SETUP:
                _, run, shape, start_ns, hardware_id, period_s = message
                tree = TreeShape.from_wire(shape)
                mapper = Ros2Mapper(
                    tree, int(start_ns), hardware_id=str(hardware_id), period_s=float(period_s)
                )
                self.mappers[run] = (mapper, tuple(n.id for n in tree))
                for old in [r for r in self.mappers if r < run - 3]:
                    del self.mappers[old]  # the runs before the last few are over
            elif kind == FRAME and index not in superseded:
                self._frame(message)
            elif kind == FLUSH:
                self.out.send((FLUSHED, message[1], self.published))

    def _frame(self, message: tuple[Any, ...]) -> None:
        if not self.enabled:
            return
        _, run, _final, n, t_s, state, link, sim, task, supervisor = message[:10]
        found = self.mappers.get(run)
        if found is None:
            return
        mapper, ids = found
        statuses, feedback, blackboard = message[10:13]
        frame = Frame(
            n=int(n),
            t_s=float(t_s),
            state=state or {},
            link=link or {},
            sim=sim or {},
            task=task or {},
            supervisor=supervisor or {},
        )
        if statuses is not None:
            frame.statuses = dict(zip(ids, statuses, strict=False))
            frame.feedback = {ids[i]: text for i, text in feedback or ()}
            frame.blackboard = blackboard or {}
        try:
            for out in mapper.messages(frame, changed=(TREE,), clock=True):
                self._publish(out.topic, out.data)
        except Exception as exc:
            self.enabled = False
            _print_exc()
            self.out.send((OFF, f"{type(exc).__name__}: {exc}"))

    def _publish(self, topic: str, data: bytes) -> None:
        if self.fail_publishing:
            raise RuntimeError("publishing fails on purpose (fail_publishing)")
        endpoint = self.endpoints.get(topic)
        if endpoint is None:
            return
        endpoint.sequence += 1
        endpoint.publisher.put(
            data,
            attachment=rmw_zenoh.attachment(endpoint.sequence, time.time_ns(), endpoint.gid),
        )
        self.published += 1

    def close(self) -> None:
        """Withdraw the node from the graph and close the session."""
        for endpoint in self.endpoints.values():
            with contextlib.suppress(Exception):
                endpoint.token.undeclare()
            with contextlib.suppress(Exception):
                endpoint.publisher.undeclare()
        for token in self.tokens:
            with contextlib.suppress(Exception):
                token.undeclare()
        if self.subscriber is not None:
            with contextlib.suppress(Exception):
                self.subscriber.undeclare()
        with contextlib.suppress(Exception):
            self.session.close()


def _batches(fd: int, wake_fd: int, poll_s: float) -> Iterator[list[tuple[Any, ...]]]:
    """Batches of messages off ``fd``, kept to the duty cycle, until it closes.

    The process does not wait on ``fd``: a frame written to a pipe whose reader
    waits on it wakes the reader at once, and on a busy machine the kernel then
    often runs the reader before the writer's ``os.write`` returns (the run's
    tick would pay for our publishing). So it looks at ``fd`` every ``poll_s``
    (the frame period) and is woken early only through ``wake_fd``, for what
    must not wait (a ``FLUSH``, a run's final frame, the end). A batch is what
    arrived since the last look; after it the process rests 49 times as long as
    it took, unless woken.
    """
    buffer = bytearray()
    pending: list[tuple[Any, ...]] = []
    rest_until = 0.0
    open_ = wake_open = True
    os.set_blocking(fd, False)
    while open_ or pending:
        woken = False
        if open_:
            wait = max(poll_s, rest_until - time.monotonic())
            if select.select([wake_fd] if wake_open else [fd], [], [], wait)[0]:
                woken = True
                if wake_open:
                    wake_open = bool(os.read(wake_fd, 4096))
            while True:
                try:
                    chunk = os.read(fd, _READ_BYTES)
                except BlockingIOError:
                    break
                if not chunk:
                    open_ = False
                    break
                buffer += chunk
            pending.extend(decode_messages(buffer))
        if pending and (woken or not open_ or time.monotonic() >= rest_until):
            started = time.monotonic()
            yield pending
            pending = []
            rest_until = time.monotonic() + (time.monotonic() - started) * (1.0 / DUTY - 1.0)


def main(argv: Sequence[str]) -> int:
    """The publishing process: ``ros2_process.py CONFIG`` (JSON); messages on stdin/stdout."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the run's Ctrl-C is for the run
    config = json.loads(argv[1])
    out = PipeOutput(sys.stdout.fileno())
    if config.get("sys_path"):
        sys.path[:] = config["sys_path"]  # find Zenoh where the run's process found it
    try:
        import zenoh
    except ImportError as exc:
        out.send((FAILED, f"cannot import zenoh: {exc}", "config"))
        return 1
    try:
        session = open_session(zenoh, config)
    except Exception as exc:  # zenoh's own error type for a bad endpoint or config
        out.send((FAILED, f"cannot open a Zenoh session: {exc}", "input"))
        return 1
    node = Node(zenoh, session, config, out)
    try:
        node.declare()
    except Exception as exc:
        _print_exc()
        out.send((FAILED, f"setting up the node failed: {type(exc).__name__}: {exc}", "setup"))
        node.close()
        return 1
    out.send((READY, node.session_id))
    watch = ReachWatch(session, out)
    watch.start()
    try:
        wake_fd = int(config["wake_fd"])
        for batch in _batches(sys.stdin.fileno(), wake_fd, float(config["poll_s"])):
            node.handle(batch)
    finally:
        watch.stop()
        node.close()
        out.send((CLOSED, node.published, time.process_time()))
    return 0


if __name__ == "__main__":
    status = main(sys.argv)
    sys.stderr.flush()
    os._exit(status)  # the session is closed: no interpreter teardown to wait for
