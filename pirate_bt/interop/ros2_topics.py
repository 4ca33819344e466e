"""One mapping from a run's moment to ROS 2 messages, for the live topics and for bags.

A :class:`Frame` is everything a ROS 2 tool is shown about one tick: the robot
state (flat, as the trace names it: ``joint_angle_rad.bend_1``...), link health,
simulator counters, the localiser's belief, every node's status and feedback
message, the blackboard and what the supervisor last decided. Live runs capture
frames from the running objects (:mod:`pirate_bt.interop.ros2_live`); a trace
gives one frame per tick record (:func:`frames_from_records`, for
:mod:`pirate_bt.interop.rosbag2`). :class:`Ros2Mapper` turns a frame into
messages, so both carry the same topics with the same values.

Topics (names relative to the namespace, ``/pirate`` by default):

- ``joint_states`` (``sensor_msgs/msg/JointState``): every joint's angle in rad
  (the bend modules, ``rotation``, ``front_tilt``, ``camera_tilt``,
  ``camera_pan``) and every drive's wheel speed as its velocity, in m/s (its
  position is NaN);
- ``imu`` (``sensor_msgs/msg/Imu``): the orientation from roll, pitch and yaw;
  no rates or accelerations (their covariance[0] is -1, ROS's "no estimate");
- ``clamp_forces`` (``sensor_msgs/msg/JointState``): each bend module's spring
  force, as its effort in N;
- ``diagnostics`` (``diagnostic_msgs/msg/DiagnosticArray``): link health, the
  supervisor (mode, last verdict, safe-state reason), motor currents, simulator
  counters;
- ``localisation`` and ``localisation/truth`` (``geometry_msgs/msg/PointStamped``):
  the belief along the route (``x``, m, frame ``route``), and the simulator's truth;
- ``tree/snapshots`` (``py_trees_ros_interfaces/msg/BehaviourTree``): the tree,
  every node with its status and feedback message, and the blackboard;
- ``/clock`` (``rosgraph_msgs/msg/Clock``): the run's clock (live only).

Every stamp is on the run's clock: the wall time the run started (whole
seconds, as a trace header's ``created_utc``) plus the seconds since, so a
simulated run of ten minutes spans ten minutes in RViz or a bag however fast it
ran, and ``/clock`` lets tools with ``use_sim_time`` follow it.
"""

from __future__ import annotations

import json
import math
import uuid
from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from pirate_bt.interop.ros2_types import typestore
from pirate_bt.trace.structure import TreeStructure

__all__ = [
    "CLAMP_FORCES",
    "CLOCK",
    "DIAGNOSTICS",
    "IMU",
    "JOINT_STATES",
    "LOCALISATION",
    "TOPIC_TYPES",
    "TREE",
    "TRUTH",
    "Frame",
    "Ros2Mapper",
    "Ros2Message",
    "frames_from_records",
    "start_ns_of",
]

JOINT_STATES = "joint_states"
IMU = "imu"
CLAMP_FORCES = "clamp_forces"
DIAGNOSTICS = "diagnostics"
LOCALISATION = "localisation"
TRUTH = "localisation/truth"
TREE = "tree/snapshots"
CLOCK = "/clock"

#: Topic -> ROS 2 type.
TOPIC_TYPES: dict[str, str] = {
    JOINT_STATES: "sensor_msgs/msg/JointState",
    IMU: "sensor_msgs/msg/Imu",
    CLAMP_FORCES: "sensor_msgs/msg/JointState",
    DIAGNOSTICS: "diagnostic_msgs/msg/DiagnosticArray",
    LOCALISATION: "geometry_msgs/msg/PointStamped",
    TRUTH: "geometry_msgs/msg/PointStamped",
    TREE: "py_trees_ros_interfaces/msg/BehaviourTree",
    CLOCK: "rosgraph_msgs/msg/Clock",
}

_STATUS = {"I": 1, "R": 2, "S": 3, "F": 4}
_OK, _WARN, _ERROR = 0, 1, 2
_NOT_A_BLACKBOX = 4
_JOINT_SINGLES = ("rotation_rad", "front_tilt_rad", "camera_tilt_rad", "camera_pan_rad")
_TASK = "task."


@dataclass
class Frame:
    """What ROS 2 tools are shown about one tick (see the module docstring).

    Attributes:
        n: Tick number.
        t_s: Seconds since the run started, on its clock.
        state: Flat state values (``joint_angle_rad.bend_1`` -> rad...).
        link: Link health fields.
        sim: Simulator counters.
        task: The localiser's values (``belief_m``, ``truth_m``, ``error_m``, ``fixes``).
        statuses: Node path id -> ``S``/``F``/``R``/``I``.
        feedback: Node path id -> feedback message.
        blackboard: Key -> value.
        supervisor: ``mode``, ``safe_state`` (the reason, or ``None``) and the last
            verdict (``command``, ``verdict``, ``reason``, ``detail``, ``source``).
    """

    n: int
    t_s: float
    state: Mapping[str, Any] = field(default_factory=dict)
    link: Mapping[str, Any] = field(default_factory=dict)
    sim: Mapping[str, Any] = field(default_factory=dict)
    task: Mapping[str, Any] = field(default_factory=dict)
    statuses: Mapping[str, str] = field(default_factory=dict)
    feedback: Mapping[str, str] = field(default_factory=dict)
    blackboard: Mapping[str, Any] = field(default_factory=dict)
    supervisor: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class Ros2Message:
    """One message on one topic.

    Attributes:
        topic: The topic, relative to the namespace (``/clock`` is absolute).
        type_name: Its ROS 2 type.
        stamp_ns: When, on the run's clock, in ns since the Unix epoch.
        message: The message (a rosbags type store object).
    """

    topic: str
    type_name: str
    stamp_ns: int
    message: Any


def start_ns_of(header: Mapping[str, Any]) -> int:
    """The run's start in ns since the Unix epoch, from a trace header's ``created_utc``."""
    text = header.get("created_utc")
    if isinstance(text, str):
        try:
            return int(datetime.fromisoformat(text).timestamp()) * 1_000_000_000
        except ValueError:
            pass
    return 0


def _number(value: Any) -> float:
    if isinstance(value, bool):
        return float(value)
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str):  # the trace spells non-finite numbers as text
        try:
            return float(value)
        except ValueError:
            return math.nan
    return math.nan


def _text(value: Any) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(value)
    return json.dumps(value, ensure_ascii=False, default=str)


def _quaternion(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """Roll, pitch, yaw (rad; Z-Y-X) -> quaternion ``(x, y, z, w)``."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def node_uuid(tree_name: str, node_id: str) -> bytes:
    """A node's UUID in tree messages: the same for the same tree and path id, every run."""
    return uuid.uuid5(uuid.NAMESPACE_URL, f"pirate-bt:{tree_name}:{node_id}").bytes


_ZERO_UUID = bytes(16)


class Ros2Mapper:
    """Turns :class:`Frame` values into :class:`Ros2Message` values.

    Args:
        structure: The tree's shape (its nodes by path id).
        start_ns: The run's start, ns since the Unix epoch (stamps are this plus ``t_s``).
        frame_id: The ``frame_id`` of stamped messages.
        hardware_id: The diagnostics' hardware id (the robot's name).
        period_s: The tick period, for the tree's statistics.
    """

    def __init__(
        self,
        structure: TreeStructure,
        start_ns: int,
        *,
        frame_id: str = "pirate",
        hardware_id: str = "pirate",
        period_s: float = 0.0,
    ) -> None:
        import numpy

        self._np = numpy
        self.store = typestore()
        self.types = self.store.types
        self.structure = structure
        self.start_ns = start_ns
        self.frame_id = frame_id
        self.hardware_id = hardware_id
        self.period_s = period_s
        self._uuids = {n.id: node_uuid(structure.name, n.id) for n in structure}
        self._last_tree: tuple[Any, ...] | None = None
        self._last: dict[str, Any] = {}

    def stamp(self, t_s: float) -> Any:
        """A ``builtin_interfaces/Time`` at ``t_s`` seconds into the run."""
        ns = self.start_ns + round(t_s * 1e9)
        return self.types["builtin_interfaces/msg/Time"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000
        )

    def _header(self, t_s: float) -> Any:
        return self.types["std_msgs/msg/Header"](stamp=self.stamp(t_s), frame_id=self.frame_id)

    def messages(
        self,
        frame: Frame,
        *,
        changed: bool | Collection[str] = False,
        clock: bool = False,
        tree: bool = True,
    ) -> list[Ros2Message]:
        """The messages of one frame.

        Args:
            frame: The frame.
            changed: Leave out the topics (all with ``True``) whose content is what it
                was last time: a bag stores changes; the live output sends every topic
                of each frame it gets but the tree, which goes out when it changed.
            clock: Add ``/clock``.
            tree: Include the tree snapshot (when there is one to send).
        """
        out: list[Ros2Message] = []
        ns = self.start_ns + round(frame.t_s * 1e9)
        for topic, key, build in (
            (JOINT_STATES, self._joints_key, self._joint_states),
            (CLAMP_FORCES, self._clamp_key, self._clamp_forces),
            (IMU, self._imu_key, self._imu),
            (DIAGNOSTICS, self._diagnostics_key, self._diagnostics),
            (LOCALISATION, self._belief_key, self._belief),
            (TRUTH, self._truth_key, self._truth),
        ):
            content = key(frame)
            if content is None:
                continue
            only_changes = changed is True or (changed is not False and topic in changed)
            if only_changes and self._last.get(topic) == content:
                continue
            self._last[topic] = content
            out.append(Ros2Message(topic, TOPIC_TYPES[topic], ns, build(frame)))
        tree_key = (tuple(frame.statuses.items()), tuple(frame.feedback.items()))
        moved = tree_key != self._last_tree
        only_changes = changed is True or (changed is not False and TREE in changed)
        if tree and frame.statuses and (moved or not only_changes):
            self._last_tree = tree_key
            out.append(Ros2Message(TREE, TOPIC_TYPES[TREE], ns, self._tree(frame, moved)))
        if clock:
            message = self.types["rosgraph_msgs/msg/Clock"](clock=self.stamp(frame.t_s))
            out.append(Ros2Message(CLOCK, TOPIC_TYPES[CLOCK], ns, message))
        return out

    # --- the state ---------------------------------------------------------------------

    @staticmethod
    def _view(state: Mapping[str, Any], view: str) -> list[tuple[str, Any]]:
        prefix = view + "."
        return [(k[len(prefix) :], v) for k, v in state.items() if k.startswith(prefix)]

    def _joints_key(self, frame: Frame) -> Any:
        state = frame.state
        if not state:
            return None
        return tuple(
            (k, v)
            for k, v in state.items()
            if k.startswith(("joint_angle_rad.", "drive_velocity_mps.")) or k in _JOINT_SINGLES
        )

    def _joint_states(self, frame: Frame) -> Any:
        names: list[str] = []
        position: list[float] = []
        velocity: list[float] = []
        for name, value in self._view(frame.state, "joint_angle_rad"):
            names.append(name)
            position.append(_number(value))
            velocity.append(math.nan)
        for single in _JOINT_SINGLES:
            if single in frame.state:
                names.append(single.removesuffix("_rad"))
                position.append(_number(frame.state[single]))
                velocity.append(math.nan)
        for name, value in self._view(frame.state, "drive_velocity_mps"):
            names.append(name)
            position.append(math.nan)
            velocity.append(_number(value))
        np = self._np
        return self.types["sensor_msgs/msg/JointState"](
            header=self._header(frame.t_s),
            name=names,
            position=np.array(position, dtype=np.float64),
            velocity=np.array(velocity, dtype=np.float64),
            effort=np.array([], dtype=np.float64),
        )

    def _clamp_key(self, frame: Frame) -> Any:
        forces = self._view(frame.state, "clamp_force_n")
        return tuple(forces) or None

    def _clamp_forces(self, frame: Frame) -> Any:
        forces = self._view(frame.state, "clamp_force_n")
        np = self._np
        empty = np.array([], dtype=np.float64)
        return self.types["sensor_msgs/msg/JointState"](
            header=self._header(frame.t_s),
            name=[name for name, _ in forces],
            position=empty,
            velocity=empty,
            effort=np.array([_number(v) for _, v in forces], dtype=np.float64),
        )

    def _imu_key(self, frame: Frame) -> Any:
        imu = tuple(self._view(frame.state, "imu_rad"))
        return imu or None

    def _imu(self, frame: Frame) -> Any:
        imu = dict(self._view(frame.state, "imu_rad"))
        x, y, z, w = _quaternion(
            _number(imu.get("roll", 0.0)),
            _number(imu.get("pitch", 0.0)),
            _number(imu.get("yaw", 0.0)),
        )
        np = self._np
        unknown = np.zeros(9, dtype=np.float64)
        none = np.zeros(9, dtype=np.float64)
        none[0] = -1.0  # REP-145 / sensor_msgs: "no estimate for this element"
        t = self.types
        return t["sensor_msgs/msg/Imu"](
            header=self._header(frame.t_s),
            orientation=t["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w),
            orientation_covariance=unknown,
            angular_velocity=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
            angular_velocity_covariance=none,
            linear_acceleration=t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
            linear_acceleration_covariance=none.copy(),
        )

    # --- diagnostics ---------------------------------------------------------------------

    def _diagnostics_key(self, frame: Frame) -> Any:
        currents = tuple(self._view(frame.state, "motor_current_a"))
        content = (
            tuple(frame.link.items()),
            tuple(frame.supervisor.items()),
            currents,
            tuple(frame.sim.items()),
        )
        return content if any(content) else None

    def _status(
        self, level: int, name: str, message: str, values: Iterable[tuple[str, Any]]
    ) -> Any:
        t = self.types
        return t["diagnostic_msgs/msg/DiagnosticStatus"](
            level=level,
            name=name,
            message=message,
            hardware_id=self.hardware_id,
            values=[t["diagnostic_msgs/msg/KeyValue"](key=k, value=_text(v)) for k, v in values],
        )

    def _diagnostics(self, frame: Frame) -> Any:
        statuses = []
        link = frame.link
        if link:
            if not link.get("connected", True):
                level, message = _ERROR, "link lost"
            elif link.get("estopped"):
                level, message = _ERROR, "the bridge reports its e-stop latched"
            elif _number(link.get("loss_ratio", 0.0)) > 0:
                level, message = _WARN, "link retrying"
            else:
                level, message = _OK, "link healthy"
            statuses.append(self._status(level, "pirate_bt: link", message, link.items()))
        sup = frame.supervisor
        if sup:
            mode = str(sup.get("mode") or "")
            reason = sup.get("safe_state")
            if mode == "estop":
                level, message = _ERROR, "e-stop latched"
            elif reason:
                level, message = _WARN, f"safe state: {reason}"
            else:
                level, message = _OK, mode or "running"
            values = [(k, "" if v is None else v) for k, v in sup.items()]
            statuses.append(self._status(level, "pirate_bt: supervisor", message, values))
        currents = self._view(frame.state, "motor_current_a")
        if currents:
            statuses.append(self._status(_OK, "pirate_bt: motor currents (A)", "", currents))
        if frame.sim:
            damage = _number(frame.sim.get("damage", 0)) + _number(frame.sim.get("violations", 0))
            level, message = (_WARN, "violations or damage") if damage > 0 else (_OK, "simulated")
            statuses.append(self._status(level, "pirate_bt: simulator", message, frame.sim.items()))
        return self.types["diagnostic_msgs/msg/DiagnosticArray"](
            header=self._header(frame.t_s), status=statuses
        )

    # --- localisation ----------------------------------------------------------------------

    def _belief_key(self, frame: Frame) -> Any:
        return frame.task.get("belief_m")

    def _truth_key(self, frame: Frame) -> Any:
        return frame.task.get("truth_m")

    def _point(self, frame: Frame, x: Any) -> Any:
        t = self.types
        header = t["std_msgs/msg/Header"](stamp=self.stamp(frame.t_s), frame_id="route")
        point = t["geometry_msgs/msg/Point"](x=_number(x), y=0.0, z=0.0)
        return t["geometry_msgs/msg/PointStamped"](header=header, point=point)

    def _belief(self, frame: Frame) -> Any:
        return self._point(frame, frame.task.get("belief_m"))

    def _truth(self, frame: Frame) -> Any:
        return self._point(frame, frame.task.get("truth_m"))

    # --- the tree ---------------------------------------------------------------------------

    def _tree(self, frame: Frame, changed: bool) -> Any:
        t = self.types
        uuid_type = t["unique_identifier_msgs/msg/UUID"]
        np = self._np
        uuids = self._uuids
        statuses = frame.statuses

        def as_uuid(node_id: str | None) -> Any:
            raw = uuids.get(node_id, _ZERO_UUID) if node_id is not None else _ZERO_UUID
            return uuid_type(uuid=np.frombuffer(raw, dtype=np.uint8).copy())

        tips: dict[str, str | None] = {}

        def tip(node_id: str) -> str | None:
            if node_id in tips:
                return tips[node_id]
            info = self.structure.node(node_id)
            status = statuses.get(node_id, "I")
            found: str | None = None
            if status != "I":
                current = _current_child(info.children, statuses)
                found = tip(current) if current is not None else node_id
                found = found or node_id
            tips[node_id] = found
            return found

        behaviours = []
        for info in self.structure:
            status = statuses.get(info.id, "I")
            current = _current_child(info.children, statuses)
            params = dict(info.params)
            behaviours.append(
                t["py_trees_ros_interfaces/msg/Behaviour"](
                    name=info.name,
                    class_name=info.type,
                    own_id=as_uuid(info.id),
                    parent_id=as_uuid(info.parent),
                    tip_id=as_uuid(tip(info.id)),
                    child_ids=[as_uuid(c) for c in info.children],
                    current_child_id=as_uuid(current),
                    type=_behaviour_type(info.kind, info.type),
                    additional_detail=json.dumps(params, default=str) if params else "",
                    blackbox_level=_NOT_A_BLACKBOX,
                    status=_STATUS.get(status, 1),
                    message=str(frame.feedback.get(info.id, "")),
                    is_active=status != "I",
                    blackboard_access=[],
                )
            )
        blackboard = [
            t["diagnostic_msgs/msg/KeyValue"](key=str(k), value=_text(v))
            for k, v in sorted(frame.blackboard.items())
        ]
        period = float(self.period_s)
        statistics = t["py_trees_ros_interfaces/msg/Statistics"](
            count=int(frame.n),
            stamp=self.stamp(frame.t_s),
            tick_duration=0.0,
            tick_duration_average=0.0,
            tick_duration_variance=0.0,
            tick_interval=period,
            tick_interval_average=period,
            tick_interval_variance=0.0,
        )
        return t["py_trees_ros_interfaces/msg/BehaviourTree"](
            behaviours=behaviours,
            changed=changed,
            blackboard_on_visited_path=blackboard,
            blackboard_activity=[],
            statistics=statistics,
        )


def _current_child(children: Iterable[str], statuses: Mapping[str, str]) -> str | None:
    """The running child, else the last child that ran this time (py_trees' current child)."""
    last = None
    for child in children:
        code = statuses.get(child, "I")
        if code == "R":
            return child
        if code != "I":
            last = child
    return last


def _behaviour_type(kind: str, class_name: str) -> int:
    if kind in ("decorator", "guard"):
        return 6
    if kind == "leaf":
        return 1
    for word, code in (("Sequence", 2), ("Selector", 3), ("Parallel", 4), ("Chooser", 5)):
        if word in class_name:
            return code
    return 0


def frames_from_records(records: Iterable[Mapping[str, Any]]) -> Iterator[tuple[Any, Frame | None]]:
    """One frame per tick record of a trace, values accumulated as the trace says.

    Yields ``(record, frame)`` pairs; a header yields ``(header, None)`` first. The
    supervisor's part is read from the verdicts (``commands``): the last one, the
    reason of the last safe state (cleared by an operator's resume), and ``estop``
    as the mode once an e-stop latched.
    """
    state: dict[str, Any] = {}
    link: dict[str, Any] = {}
    sim: dict[str, Any] = {}
    task: dict[str, Any] = {}
    statuses: dict[str, str] = {}
    feedback: dict[str, str] = {}
    blackboard: dict[str, Any] = {}
    supervisor: dict[str, Any] = {}
    for record in records:
        kind = record.get("type")
        if kind == "header":
            state, link, sim, task = {}, {}, {}, {}
            statuses, feedback, blackboard, supervisor = {}, {}, {}, {}
            yield record, None
            continue
        if kind != "tick":
            yield record, None
            continue
        if record.get("status"):
            statuses.update(record["status"])
        if record.get("feedback"):
            feedback.update(record["feedback"])
        if record.get("bb"):
            blackboard.update(record["bb"])
        for key in record.get("bb_unset") or ():
            blackboard.pop(key, None)
        if record.get("state") is not None:
            if record.get("full"):
                state = dict(record["state"])
            else:
                state.update(record["state"])
        if record.get("link") is not None:
            link.update(record["link"])
        for key, value in (record.get("sim") or {}).items():
            if key.startswith(_TASK):
                task[key[len(_TASK) :]] = value
            else:
                sim[key] = value
        for command in record.get("commands") or ():
            supervisor["last_command"] = command.get("command")
            supervisor["last_verdict"] = command.get("verdict")
            supervisor["last_reason"] = command.get("reason")
            supervisor["last_detail"] = command.get("detail")
            supervisor["last_source"] = command.get("source")
            reason = command.get("reason")
            if command.get("source") == "supervisor" and reason == "safe_state":
                supervisor["safe_state"] = command.get("detail") or "safe state"
            if reason == "estop_latched" and command.get("source") == "supervisor":
                supervisor["mode"] = "estop"
        yield (
            record,
            Frame(
                n=int(record.get("n", 0)),
                t_s=_number(record.get("t_s", 0.0)),
                state=dict(state),
                link=dict(link),
                sim=dict(sim),
                task=dict(task),
                statuses=dict(statuses),
                feedback=dict(feedback),
                blackboard=dict(blackboard),
                supervisor=dict(supervisor),
            ),
        )
