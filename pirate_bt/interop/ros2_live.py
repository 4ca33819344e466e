"""A run on a ROS 2 graph, over Zenoh, with no ROS installed.

``--ros2 [ENDPOINT]`` on ``pirate-bt run|mission|teleop|sim`` (and ``ros2=`` in
the API) opens a :class:`Ros2Node`: a process of its own
(:mod:`pirate_bt.interop.ros2_process`) with a Zenoh session (``eclipse-zenoh``,
the ``ros2`` extra) that connects to a Zenoh router, by default rmw_zenoh's
``tcp/127.0.0.1:7447`` (``ros2 run rmw_zenoh_cpp rmw_zenohd``), and behaves as a
ROS 2 node there by following rmw_zenoh's conventions
(:mod:`pirate_bt.interop.rmw_zenoh`): every node on that router whose middleware
is ``rmw_zenoh_cpp`` sees our topics (:mod:`pirate_bt.interop.ros2_topics`) in
``ros2 topic list``, RViz, PlotJuggler or py_trees_ros's tree watcher.

**The robot comes first.** The node's process starts when the option is opened
and sets itself up while the run is prepared. In the tick, a post-tick hook
looks at the wall clock and, at most ``rate_hz`` times a wall-clock second (20
by default), reads what the tools are shown (the state snapshot, link health,
counters, the supervisor's mode and last verdict; every node's status, feedback
and the blackboard at most once a second) and hands it to the node's process as
plain values over a pipe (:meth:`Ros2Node.offer`). That process builds the
messages, encodes them and hands them to Zenoh, on another core; when it lags,
frames are dropped, never queued in the run. A simulated run that goes a hundred
times faster than real time is shown at the rate, its messages stamped with the
run's clock; a real robot's run at 20 Hz is shown tick by tick. Any error in the
output is logged once and switches it off; it never reaches the tick.

**Nothing from the graph moves the robot.** The node subscribes to one topic,
``<namespace>/estop`` (``std_msgs/msg/Bool``). ``true`` there comes back over
the pipe and becomes an operator :class:`~pirate_bt.safety.operator.EStop` on
an :class:`~pirate_bt.safety.operator.OperatorInput` (:class:`EStopInput`)
that the supervisor drains at the start of its next tick, exactly like the
console's e-stop key: it latches, stops the drives and the rotation, keeps the
clamps holding, and only an operator at the console releases it. ``false`` does
nothing (an e-stop is not released from the graph). No other topic, service or
parameter is offered.
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
from pirate_bt.interop.ros2_topics import TreeShape

__all__ = [
    "DEFAULT_ENDPOINT",
    "DEFAULT_NAMESPACE",
    "ESTOP",
    "TREE_PERIOD_S",
    "EStopInput",
    "Ros2Node",
    "add_ros2_options",
    "attach_ros2",
    "parse_endpoint",
    "publish_simulator",
    "serve_supervisor",
]

logger = logging.getLogger(__name__)

TREE_PERIOD_S = 1.0
"""Every node's status, feedback and the blackboard are read at most once per this many
wall seconds (and at a run's end): the tree topic shows no more than that."""


# --- capturing frames (the tick's side) ---------------------------------------------------------


class _Capture:
    """Reads a frame's values from the running objects, in the tick's thread.

    Only plain values are made here (what ``marshal`` carries); the rest is the
    node's process's work.
    """

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

        self._nodes = [node for _, node in iter_with_ids(tree)] if tree is not None else []
        self._code = STATUS_CODE
        self._storage = py_trees.blackboard.Blackboard.storage
        self.clock = clock
        self.start_s = clock.now()
        self.supervisor = supervisor
        self.counters = counters
        self.more = more
        self.last_verdict: Any = None
        self._verdict_seen: Any = None
        self._verdict_values: dict[str, Any] = {}
        if supervisor is not None:
            supervisor.add_listener(self._verdict)

    def _verdict(self, verdict: Any) -> None:
        self.last_verdict = verdict  # one assignment per verdict: the whole cost in the tick

    def values(
        self, n: int, *, tree: bool, statuses: tuple[str, ...] | None = None
    ) -> tuple[Any, ...]:
        """``FRAME``'s values from ``n`` on (:mod:`pirate_bt.interop.ros2_process`); the
        tree's three only with ``tree``."""
        from pirate_bt.trace.attach import counter_values
        from pirate_bt.trace.records import flatten_state, link_health_values

        state: Any = None
        link: Any = None
        supervisor: Any = None
        sup = self.supervisor
        if sup is not None:
            snapshot = sup.state()
            if snapshot is not None:
                state = flatten_state(snapshot)
            link = link_health_values(sup.health())
            supervisor = {
                "mode": str(getattr(sup.mode, "value", sup.mode)),
                "safe_state": sup.safe_state_reason,
            }
            verdict = self.last_verdict
            if verdict is not None:
                if verdict is not self._verdict_seen:
                    record = verdict.to_record()
                    self._verdict_seen = verdict
                    self._verdict_values = {
                        "last_command": record.get("command"),
                        "last_verdict": record.get("outcome"),
                        "last_reason": record.get("reason"),
                        "last_detail": record.get("detail"),
                        "last_source": record.get("source"),
                    }
                supervisor.update(self._verdict_values)
        sim = counter_values(self.counters()) if self.counters is not None else None
        task = None
        if self.more is not None:
            task = {k.removeprefix("task."): v for k, v in self.more().items()}
        feedback: Any = None
        blackboard: Any = None
        if tree:
            from pirate_bt.trace.structure import jsonable

            nodes = self._nodes
            if statuses is None:
                code = self._code
                statuses = tuple([code[node.status] for node in nodes])
            feedback = tuple(
                [
                    (i, str(node.feedback_message))
                    for i, node in enumerate(nodes)
                    if node.feedback_message
                ]
            )
            blackboard = {str(k): jsonable(v) for k, v in self._storage.items()}
        else:
            statuses = None
        t_s = round(self.clock.now() - self.start_s, 6)
        return (n, t_s, state, link, sim, task, supervisor, statuses, feedback, blackboard)


def _hardware_id(robot: Any) -> str:
    return str(getattr(robot, "name", None) or "pirate")


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

    Waits (at most ``ready_timeout_s``) until the node's process is set up, so that
    the e-stop topic is heard from the first tick (it started when the node was
    opened, so it usually is by now); then attaches a post-tick hook that hands
    the node a frame at most ``rate_hz`` times a wall-clock second, and a finish
    hook that hands it the last one.

    Args:
        runner: A :class:`pirate_bt.runner.Runner` (not yet run).
        node: The node.
        supervisor: The run's supervisor (state, link, verdicts; it drains the e-stop).
        counters: The simulator's ``counters`` callable, when simulated.
        more: Extra values (a mission's localiser: ``task.belief_m``...).
        robot: The robot description (its name is the diagnostics' hardware id).
        ready_timeout_s: How long to wait for the node's set-up.

    Raises:
        InputError: the node's Zenoh session could not be opened (a bad endpoint).
    """
    from pirate_bt.trace.structure import tree_structure

    if not node.check_opened(ready_timeout_s):
        logger.warning("ROS 2 output: the node is not set up; this run is not shown")
    node.attach_supervisor(supervisor)
    if not node.enabled:
        return
    capture = _Capture(
        runner.tree, runner.clock, supervisor=supervisor, counters=counters, more=more
    )
    start_ns = int(time.time()) * 1_000_000_000
    shape = TreeShape.of(tree_structure(runner.tree))
    run = node.begin(shape, start_ns, _hardware_id(robot), runner.period_s)
    period_s = node.period_s
    due = [0.0, 0.0]  # the next frame, the next tree
    clock = time.perf_counter

    def post_tick(info: Any) -> None:
        now = clock()
        if now < due[0]:
            return
        due[0] = now + period_s
        tree = now >= due[1]
        if tree:
            due[1] = now + TREE_PERIOD_S
        try:
            node.offer(run, capture.values(info.tick, tree=tree))
        except Exception:
            node.enabled = False
            logger.exception("ROS 2 output: reading the run failed; it is switched off")

    def finish(result: Any) -> None:
        try:
            node.offer(run, capture.values(int(getattr(result, "ticks", 0)), tree=True), final=True)
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

    if not node.check_opened():
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
    shape = TreeShape.of(tree_structure(root))
    run = node.begin(shape, int(time.time()) * 1_000_000_000, _hardware_id(robot), 0.0)
    due = [0.0, 0.0]
    steps = [0]

    def tick() -> None:
        steps[0] += 1
        now = time.perf_counter()
        if now < due[0] or not node.enabled:
            return
        due[0] = now + node.period_s
        tree = now >= due[1]
        if tree:
            due[1] = now + TREE_PERIOD_S
        try:
            node.offer(run, capture.values(steps[0], tree=tree, statuses=("R",)))
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

    node.check_opened()
    stop = threading.Event()
    clock0 = simulator.clock.now()
    start_ns = int(time.time()) * 1_000_000_000
    run = node.begin(TreeShape("sim", ()), start_ns, "pirate", 0.0)

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
                node.offer(run, (n, t_s, state, None, sim, None, None, None, None, None))
            except Exception:
                logger.exception("ROS 2 output: reading the simulator failed; stopped")
                return

    thread = threading.Thread(target=loop, name="pirate-ros2-sim", daemon=True)
    thread.start()

    def halt() -> None:
        stop.set()
        thread.join(timeout=2.0)

    return halt
