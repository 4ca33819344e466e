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

import logging
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

from pirate_bt.interop.ros2_node import ESTOP, EStopInput, Ros2Node
from pirate_bt.interop.ros2_option import (
    DEFAULT_ENDPOINT,
    DEFAULT_NAMESPACE,
    add_ros2_options,
    parse_endpoint,
)
from pirate_bt.interop.ros2_topics import Frame

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
