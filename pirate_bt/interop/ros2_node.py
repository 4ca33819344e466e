"""The ROS 2 node of ``--ros2``: a Zenoh session that behaves as a ROS 2 node.

:class:`Ros2Node` connects to a Zenoh router (rmw_zenoh's conventions,
:mod:`pirate_bt.interop.rmw_zenoh`), declares the publishers of
:mod:`pirate_bt.interop.ros2_topics` and their liveliness tokens, and subscribes
to the e-stop topic (:class:`EStopInput`, drained by the supervisor). A worker
thread builds, serialises and publishes the frames handed to :meth:`Ros2Node.offer`.
What is captured from a run, and when, is :mod:`pirate_bt.interop.ros2_live`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop import rmw_zenoh
from pirate_bt.interop.ros2_option import (
    DEFAULT_ENDPOINT,
    DEFAULT_NAMESPACE,
    domain_from_env,
    parse_endpoint,
)
from pirate_bt.interop.ros2_topics import TOPIC_TYPES, TREE, Frame
from pirate_bt.interop.ros2_types import missing
from pirate_bt.safety.operator import EStop, OperatorAction

__all__ = ["DUTY", "ESTOP", "TREE_PERIOD_S", "EStopInput", "Ros2Node"]

logger = logging.getLogger(__name__)

ESTOP = "estop"
"""The e-stop topic, relative to the namespace."""
DUTY = 0.02
"""The share of wall time the worker may spend: after each frame it rests 49 times as
long as the frame took (the slot keeps only the newest frame meanwhile)."""
TREE_PERIOD_S = 1.0
"""At most one tree snapshot per this many wall seconds (each is the whole tree)."""

_LATCHED = {TREE}
"""Topics late joiners get the last message of (TRANSIENT_LOCAL, depth 1, like
py_trees_ros's snapshot streams)."""


def _load_zenoh() -> Any:
    try:
        import zenoh
    except ImportError:
        raise ConfigurationError(missing("--ros2", "eclipse-zenoh")) from None
    return zenoh


class EStopInput:
    """The e-stop topic as an operator input (see the module docstring).

    Zenoh's threads :meth:`push`; the supervisor's tick :meth:`poll`\\ s.
    """

    def __init__(self, topic: str) -> None:
        self.topic = topic
        self._due: deque[OperatorAction] = deque()
        self.received = 0
        """``std_msgs/Bool`` messages received (``true`` or not)."""
        self.estops = 0
        """E-stops handed to a supervisor so far."""

    def push(self, data: bool) -> None:
        """One ``std_msgs/Bool`` arrived."""
        self.received += 1
        if data:
            self._due.append(EStop(f"ROS 2 e-stop on {self.topic}"))

    def poll(self, tick: int, now_s: float) -> list[OperatorAction]:
        due: list[OperatorAction] = []
        while self._due:
            due.append(self._due.popleft())
        self.estops += len(due)
        return due


@dataclass
class _Endpoint:
    topic: str
    type_name: str
    key: str
    gid: bytes
    publisher: Any
    token: Any
    sequence: int = 0


class Ros2Node:
    """One ROS 2 node over Zenoh (rmw_zenoh's conventions) publishing pirate_bt's topics.

    The Zenoh session opens at once (it connects to ``endpoint`` as a peer, and
    keeps trying in the background if nothing listens there yet); the type hashes,
    publishers, liveliness tokens and the e-stop subscription are set up by the
    node's worker thread (:meth:`wait_ready`).

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
        ConfigurationError: ``eclipse-zenoh`` or ``rosbags`` is missing.
        InputError: a bad endpoint, domain id or namespace.
    """

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
        zenoh = _load_zenoh()
        try:
            import rosbags  # noqa: F401
        except ImportError:
            raise ConfigurationError(missing("--ros2", "rosbags")) from None
        self.endpoint = parse_endpoint(endpoint)
        self.domain_id = domain_from_env() if domain_id is None else int(domain_id)
        if not 0 <= self.domain_id <= 232:
            raise InputError(f"--ros-domain-id {self.domain_id}: ROS domain ids go from 0 to 232")
        try:
            self.fq_estop = rmw_zenoh.qualified_name(namespace, ESTOP)
            rmw_zenoh.qualified_name(namespace, name)
        except ValueError as exc:
            raise InputError(f"--ros-namespace {namespace!r}: {exc}") from None
        self.namespace = "/" + namespace.strip("/") if namespace.strip("/") else ""
        self.name = name
        if rate_hz <= 0:
            raise InputError("the ROS 2 rate must be positive")
        self.period_s = 1.0 / rate_hz
        config = zenoh.Config()
        for key, value in (
            ("mode", "peer"),
            ("connect/endpoints", [self.endpoint]),
            ("listen/endpoints", list(listen)),
            ("scouting/multicast/enabled", False),
            # Advanced publishers (the latched tree topic) sequence by timestamp.
            ("timestamping/enabled", True),
            # Return at once instead of waiting half a second for scouted peers: the
            # session goes on connecting (and reconnecting) in the background.
            ("open/return_conditions/connect_scouted", False),
        ):
            config.insert_json5(key, json.dumps(value))
        try:
            self.session = zenoh.open(config)
        except Exception as exc:  # zenoh's own error type for a bad endpoint or config
            raise InputError(
                f"--ros2 {self.endpoint}: cannot open a Zenoh session: {exc}"
            ) from None
        self.session_id = str(self.session.zid())
        self.estop = EStopInput(self.fq_estop) if estop else None
        self.enabled = True
        """False once publishing failed (the run goes on without the ROS 2 output)."""
        self.published = 0
        """Messages handed to Zenoh so far."""
        self._endpoints: dict[str, _Endpoint] = {}
        self._tokens: list[Any] = []
        self._subscriber: Any = None
        self._supervisors: list[Any] = []
        self._slot: tuple[Any, Frame, bool] | None = None
        self._hurry = threading.Event()
        self._next_tree = 0.0
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._idle = threading.Event()
        self._idle.set()
        self._ready = threading.Event()
        self._closed = False
        self._setup_error: BaseException | None = None
        self._thread = threading.Thread(target=self._work, name="pirate-ros2", daemon=True)
        self._thread.start()
        logger.info(
            "ROS 2 node %s/%s on Zenoh %s, domain %d",
            self.namespace,
            name,
            self.endpoint,
            self.domain_id,
        )

    # --- set-up (worker thread) ------------------------------------------------------------

    def _setup(self) -> None:
        from pirate_bt.interop.ros2_types import dds_type_name, type_hash, typestore

        zenoh = _load_zenoh()
        typestore()
        liveliness = self.session.liveliness()
        self._tokens.append(
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
            latched = topic in _LATCHED
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

                publisher = zenoh.ext.declare_advanced_publisher(
                    self.session,
                    key,
                    cache=zenoh.ext.CacheConfig(max_samples=1),
                    publisher_detection=True,
                )
            else:
                publisher = self.session.declare_publisher(
                    key, congestion_control=zenoh.CongestionControl.DROP
                )
            token = liveliness.declare_token(token_key)
            self._endpoints[topic] = _Endpoint(
                topic, type_name, key, rmw_zenoh.entity_gid(token_key), publisher, token
            )
        if self.estop is not None:
            entity += 1
            type_name = "std_msgs/msg/Bool"
            dds, digest = dds_type_name(type_name), type_hash(type_name)
            key = rmw_zenoh.data_key(self.domain_id, self.fq_estop, dds, digest)
            qos = rmw_zenoh.Qos(depth=10)
            self._tokens.append(
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
                        qos,
                    )
                )
            )
            self._subscriber = self.session.declare_subscriber(key, self._on_estop)

    def _on_estop(self, sample: Any) -> None:
        estop = self.estop
        if estop is None:
            return
        try:
            payload = bytes(sample.payload.to_bytes())
            # CDR: 4-byte encapsulation header, then the bool as one byte.
            if len(payload) < 5:
                logger.warning("ROS 2 e-stop: a message too short to be a std_msgs/Bool")
                return
            estop.push(payload[4] != 0)
        except Exception:  # Zenoh's thread must not die; the supervisor never sees this
            logger.exception("ROS 2 e-stop: reading a message failed")

    def wait_ready(self, timeout_s: float = 10.0) -> bool:
        """Wait until the publishers, tokens and the e-stop subscription exist.

        Returns:
            True when ready; False on time-out or when the set-up failed (logged).
        """
        return self._ready.wait(timeout_s) and self._setup_error is None

    # --- supervisors -------------------------------------------------------------------------

    def attach_supervisor(self, supervisor: Any) -> None:
        """Let ``supervisor`` drain the e-stop topic (once per supervisor)."""
        if self.estop is None or supervisor is None:
            return
        if any(s is supervisor for s in self._supervisors):
            return
        self._supervisors.append(supervisor)
        supervisor.add_input(self.estop)

    # --- publishing --------------------------------------------------------------------------

    def offer(self, mapper: Any, frame: Frame, *, final: bool = False) -> None:
        """Hand one frame to the worker; it replaces one the worker has not taken yet.

        A ``final`` frame (a run's last) goes out at once, tree and all.
        """
        if not self.enabled:
            return
        with self._lock:
            self._slot = (mapper, frame, final)
            self._idle.clear()
        if final:
            self._hurry.set()
        self._wake.set()

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Wait until the worker has published everything offered (True) or time is up."""
        return self._idle.wait(timeout_s)

    def _work(self) -> None:
        try:
            self._setup()
        except BaseException as exc:
            self._setup_error = exc
            self.enabled = False
            logger.exception("ROS 2 output: setting up the node failed; it is switched off")
            self._ready.set()
            self._idle.set()
            return
        self._ready.set()
        while True:
            self._wake.wait()
            self._wake.clear()
            with self._lock:
                item, self._slot = self._slot, None
            if item is None:
                if self._closed:
                    return
                self._idle.set()
                continue
            mapper, frame, final = item
            started = time.perf_counter()
            try:
                tree = final or started >= self._next_tree
                messages = mapper().messages(frame, changed=(TREE,), clock=True, tree=tree)
                for message in messages:
                    self._publish(message)
                if any(m.topic == TREE for m in messages):
                    spent = time.perf_counter() - started
                    self._next_tree = time.perf_counter() + max(TREE_PERIOD_S, spent / DUTY)
            except Exception:
                self.enabled = False
                logger.exception("ROS 2 output: publishing failed; it is switched off")
            with self._lock:
                if self._slot is None:
                    self._idle.set()
                else:
                    self._wake.set()
            # Keep to the duty cycle: rest in proportion to the work just done (a final
            # frame or close cuts the rest short).
            rest = (time.perf_counter() - started) * (1.0 / DUTY - 1.0)
            if not self._closed and self._hurry.wait(rest):
                self._hurry.clear()

    def _publish(self, message: Any) -> None:
        from pirate_bt.interop.ros2_types import serialize

        endpoint = self._endpoints.get(message.topic)
        if endpoint is None:
            return
        payload = serialize(message.message, message.type_name)
        endpoint.sequence += 1
        endpoint.publisher.put(
            payload,
            attachment=rmw_zenoh.attachment(endpoint.sequence, time.time_ns(), endpoint.gid),
        )
        self.published += 1

    def close(self) -> None:
        """Publish what is pending, withdraw the node from the graph, close (idempotent)."""
        if self._closed:
            return
        self.flush(2.0)
        self._closed = True
        self._hurry.set()
        self._wake.set()
        self._thread.join(timeout=10.0)
        for endpoint in self._endpoints.values():
            with contextlib.suppress(Exception):
                endpoint.token.undeclare()
            with contextlib.suppress(Exception):
                endpoint.publisher.undeclare()
        for token in self._tokens:
            with contextlib.suppress(Exception):
                token.undeclare()
        if self._subscriber is not None:
            with contextlib.suppress(Exception):
                self._subscriber.undeclare()
        try:
            self.session.close()
        except Exception:  # pragma: no cover - closing must not fail a run's end
            logger.exception("ROS 2 output: closing the Zenoh session failed")

    def __enter__(self) -> Ros2Node:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
