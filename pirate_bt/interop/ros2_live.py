"""A run on a ROS 2 graph, over Zenoh, with no ROS installed.

``--ros2 [ENDPOINT]`` on ``pirate-bt run|mission|teleop|sim`` (and ``ros2=`` in
the API) opens a :class:`Ros2Node`: a Zenoh session (``eclipse-zenoh``, the
``ros2`` extra) that connects to a Zenoh router, by default rmw_zenoh's
``tcp/127.0.0.1:7447`` (``ros2 run rmw_zenoh_cpp rmw_zenohd``), and behaves as a
ROS 2 node there by following rmw_zenoh's conventions
(:mod:`pirate_bt.interop.rmw_zenoh`): every node on that router whose middleware
is ``rmw_zenoh_cpp`` sees our topics (:mod:`pirate_bt.interop.ros2_topics`) in
``ros2 topic list``, RViz, PlotJuggler or py_trees_ros's tree watcher.

**The robot comes first.** The tick does almost nothing: a post-tick hook looks
at the wall clock and, at most ``rate_hz`` times a wall-clock second (20 by
default), copies what the tools are shown (the state snapshot, link health,
counters, every node's status) into a single slot. A worker thread takes the
slot, builds the messages, serialises them and hands them to Zenoh, which sends
from its own threads. A slot the worker has not taken yet is overwritten by the
next one, so nothing queues up: a simulated run that goes a hundred times faster
than real time is shown at the rate, its messages stamped with the run's clock;
a real robot's run at 20 Hz is shown tick by tick. Any error in the worker is
logged once and switches the output off; it never reaches the tick.

**Nothing from the graph moves the robot.** The node subscribes to one topic,
``<namespace>/estop`` (``std_msgs/msg/Bool``). ``true`` there becomes an operator
:class:`~pirate_bt.safety.operator.EStop` on an
:class:`~pirate_bt.safety.operator.OperatorInput` that the supervisor drains at
the start of its next tick, exactly like the console's e-stop key: it latches,
stops the drives and the rotation, keeps the clamps holding, and only an
operator at the console releases it. ``false`` does nothing (an e-stop is not
released from the graph). No other topic, service or parameter is offered.
"""

from __future__ import annotations

import contextlib
import json
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop import rmw_zenoh
from pirate_bt.interop.ros2_option import (
    DEFAULT_ENDPOINT,
    DEFAULT_NAMESPACE,
    add_ros2_options,
    domain_from_env,
    parse_endpoint,
)
from pirate_bt.interop.ros2_topics import TOPIC_TYPES, TREE, Frame
from pirate_bt.interop.ros2_types import missing
from pirate_bt.safety.operator import EStop, OperatorAction

__all__ = [
    "DEFAULT_ENDPOINT",
    "DEFAULT_NAMESPACE",
    "ESTOP",
    "EStopInput",
    "Ros2Node",
    "add_ros2_options",
    "attach_ros2",
    "parse_endpoint",
    "publish_simulator",
    "serve_supervisor",
]

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


# --- capturing frames (the tick's side) ---------------------------------------------------------


class _Capture:
    """Reads a frame from the running objects; the cheap part, in the tick's thread."""

    def __init__(
        self,
        tree: Any,
        clock: Any,
        *,
        supervisor: Any = None,
        counters: Callable[[], Any] | None = None,
        more: Callable[[], Mapping[str, float]] | None = None,
    ) -> None:
        import py_trees

        from pirate_bt.trace.records import STATUS_CODE
        from pirate_bt.trace.structure import iter_with_ids

        self._nodes = list(iter_with_ids(tree)) if tree is not None else []
        self._code = STATUS_CODE
        self._storage = py_trees.blackboard.Blackboard.storage
        self.clock = clock
        self.start_s = clock.now()
        self.supervisor = supervisor
        self.counters = counters
        self.more = more
        self.last_verdict: Any = None
        self.n = 0
        if supervisor is not None:
            supervisor.add_listener(self._verdict)

    def _verdict(self, verdict: Any) -> None:
        self.last_verdict = verdict  # one assignment per verdict: the whole cost in the tick

    def frame(self, n: int | None = None, statuses: Mapping[str, str] | None = None) -> Frame:
        from pirate_bt.trace.attach import counter_values
        from pirate_bt.trace.records import flatten_state, link_health_values
        from pirate_bt.trace.structure import jsonable

        code = self._code
        if statuses is None:
            statuses = {node_id: code[node.status] for node_id, node in self._nodes}
        feedback = {
            node_id: str(node.feedback_message)
            for node_id, node in self._nodes
            if node.feedback_message
        }
        frame = Frame(
            n=self.n if n is None else n,
            t_s=round(self.clock.now() - self.start_s, 6),
            statuses=statuses,
            feedback=feedback,
            blackboard={str(k): jsonable(v) for k, v in self._storage.items()},
        )
        sup = self.supervisor
        if sup is not None:
            state = sup.state()
            if state is not None:
                frame.state = flatten_state(state)
            frame.link = link_health_values(sup.health())
            info: dict[str, Any] = {
                "mode": str(getattr(sup.mode, "value", sup.mode)),
                "safe_state": sup.safe_state_reason,
            }
            verdict = self.last_verdict
            if verdict is not None:
                record = verdict.to_record()
                info.update(
                    last_command=record.get("command"),
                    last_verdict=record.get("outcome"),
                    last_reason=record.get("reason"),
                    last_detail=record.get("detail"),
                    last_source=record.get("source"),
                )
            frame.supervisor = info
        if self.counters is not None:
            frame.sim = counter_values(self.counters())
        if self.more is not None:
            values = self.more()
            frame.task = {k.removeprefix("task."): v for k, v in values.items()}
        return frame


def _mapper_factory(structure: Any, start_ns: int, robot: Any, period_s: float) -> Any:
    name = getattr(robot, "name", None) or "pirate"

    def make() -> Any:
        from pirate_bt.interop.ros2_topics import Ros2Mapper

        return Ros2Mapper(structure, start_ns, hardware_id=str(name), period_s=period_s)

    holder: dict[str, Any] = {}

    def get() -> Any:
        # Called by the worker: the mapper (numpy, rosbags) is built off the tick, once.
        if "mapper" not in holder:
            holder["mapper"] = make()
        return holder["mapper"]

    return get


def attach_ros2(
    runner: Any,
    node: Ros2Node,
    *,
    supervisor: Any = None,
    counters: Callable[[], Any] | None = None,
    more: Callable[[], Mapping[str, float]] | None = None,
    robot: Any = None,
    ready_timeout_s: float = 10.0,
) -> None:
    """Show ``runner``'s run on the ROS 2 graph through ``node`` (see the module docstring).

    Waits (at most ``ready_timeout_s``) until the node is set up, so that the
    e-stop topic is heard from the first tick; then attaches a post-tick hook
    that hands the worker a frame at most ``rate_hz`` times a wall-clock second,
    and a finish hook that hands it the last one and waits for it to go out.

    Args:
        runner: A :class:`pirate_bt.runner.Runner` (not yet run).
        node: The node.
        supervisor: The run's supervisor (state, link, verdicts; it drains the e-stop).
        counters: The simulator's ``counters`` callable, when simulated.
        more: Extra values (a mission's localiser: ``task.belief_m``...).
        robot: The robot description (its name is the diagnostics' hardware id).
        ready_timeout_s: How long to wait for the node's set-up.
    """
    from pirate_bt.trace.structure import tree_structure

    if not node.wait_ready(ready_timeout_s):
        logger.warning("ROS 2 output: the node is not set up; this run is not shown")
    node.attach_supervisor(supervisor)
    if not node.enabled:
        return
    capture = _Capture(
        runner.tree, runner.clock, supervisor=supervisor, counters=counters, more=more
    )
    start_ns = int(time.time()) * 1_000_000_000
    mapper = _mapper_factory(tree_structure(runner.tree), start_ns, robot, runner.period_s)
    period_s = node.period_s
    due = [0.0]
    clock = time.perf_counter

    def post_tick(info: Any) -> None:
        now = clock()
        if now < due[0]:
            return
        due[0] = now + period_s
        try:
            node.offer(mapper, capture.frame(info.tick))
        except Exception:
            node.enabled = False
            logger.exception("ROS 2 output: reading the run failed; it is switched off")

    def finish(result: Any) -> None:
        try:
            node.offer(mapper, capture.frame(int(getattr(result, "ticks", 0))), final=True)
            node.flush()
        except Exception:
            logger.exception("ROS 2 output: the last frame failed")

    runner.add_post_tick(post_tick)
    runner.add_finish(finish)


def serve_supervisor(node: Ros2Node, supervisor: Any, *, robot: Any = None) -> Callable[[], None]:
    """A function to call once per console step that shows a supervisor (``pirate-bt teleop``).

    The tree topic shows one node, ``teleop``. The supervisor drains the e-stop topic.
    """
    import py_trees

    from pirate_bt.trace.structure import tree_structure

    if not node.wait_ready():
        logger.warning("ROS 2 output: the node is not set up; the console is not shown")
    node.attach_supervisor(supervisor)
    simulator = getattr(supervisor, "simulator", None)
    root = py_trees.behaviours.Running(name="teleop")
    capture = _Capture(
        root,
        supervisor.clock,
        supervisor=supervisor,
        counters=simulator.counters if simulator is not None else None,
    )
    mapper = _mapper_factory(tree_structure(root), int(time.time()) * 1_000_000_000, robot, 0.0)
    due = [0.0]
    steps = [0]

    def tick() -> None:
        steps[0] += 1
        now = time.perf_counter()
        if now < due[0] or not node.enabled:
            return
        due[0] = now + node.period_s
        try:
            node.offer(mapper, capture.frame(steps[0], {"0": "R"}))
        except Exception:
            node.enabled = False
            logger.exception("ROS 2 output: reading the console failed; it is switched off")

    return tick


def publish_simulator(node: Ros2Node, simulator: Any) -> Callable[[], None]:
    """Show a simulator's truth and counters from a thread (``pirate-bt sim``, no tree).

    ``joint_states`` carries the simulated joints, ``diagnostics`` the counters and
    the truth. There is no supervisor, so nothing drains the e-stop topic.

    Returns:
        A function that stops the thread.
    """
    from pirate_bt.trace.attach import counter_values
    from pirate_bt.trace.structure import TreeStructure

    node.wait_ready()
    stop = threading.Event()
    clock0 = simulator.clock.now()
    start_ns = int(time.time()) * 1_000_000_000
    mapper = _mapper_factory(TreeStructure(name="sim", nodes=()), start_ns, None, 0.0)

    def loop() -> None:
        n = 0
        while not stop.wait(node.period_s):
            try:
                truth = simulator.truth()
                n += 1
                state = {f"joint_angle_rad.{k}": v for k, v in dict(truth.joint_angle_rad).items()}
                state["rotation_rad"] = truth.rotation_rad
                sim: dict[str, Any] = dict(counter_values(simulator.counters()))
                sim.update(
                    front_m=truth.front_m,
                    velocity_mps=truth.velocity_mps,
                    slipping=truth.slipping,
                    sliding=truth.sliding,
                    diameter_m=truth.diameter_m,
                    slope_rad=truth.slope_rad,
                )
                t_s = round(simulator.clock.now() - clock0, 6)
                node.offer(mapper, Frame(n=n, t_s=t_s, state=state, sim=sim))
            except Exception:
                logger.exception("ROS 2 output: reading the simulator failed; stopped")
                return

    thread = threading.Thread(target=loop, name="pirate-ros2-sim", daemon=True)
    thread.start()

    def halt() -> None:
        stop.set()
        thread.join(timeout=2.0)

    return halt
