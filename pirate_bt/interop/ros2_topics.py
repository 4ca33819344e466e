"""One mapping from a run's moment to ROS 2 messages, for the live topics and for bags.

A :class:`Frame` is everything a ROS 2 tool is shown about one tick: the robot
state (flat, as the trace names it: ``joint_angle_rad.bend_1``...), link health,
simulator counters, the localiser's belief, every node's status and feedback
message, the blackboard and what the supervisor last decided. Live runs capture
frames from the running objects (:mod:`pirate_bt.interop.ros2_live`); a trace
gives one frame per tick record (:func:`pirate_bt.interop.rosbag2.frames_from_records`).
:class:`Ros2Mapper` turns a frame into messages, so both carry the same topics
with the same values.

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

Messages come out as CDR bytes (:mod:`pirate_bt.interop.ros2_cdr`). This module
imports nothing outside the standard library but that, so the publishing
process (:mod:`pirate_bt.interop.ros2_process`) loads it in milliseconds; a
tree's shape reaches it as a :class:`TreeShape`.
"""

from __future__ import annotations

import json
import math
import uuid
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pirate_bt.interop import ros2_cdr as cdr

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
    "ShapeNode",
    "TreeShape",
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
        data: The message in CDR, with its encapsulation header.
    """

    topic: str
    type_name: str
    stamp_ns: int
    data: bytes


@dataclass(frozen=True, slots=True)
class ShapeNode:
    """One node of a :class:`TreeShape` (the fields of a trace's ``NodeInfo`` we show)."""

    id: str
    name: str
    type: str
    kind: str
    parent: str | None
    children: tuple[str, ...]
    params: Mapping[str, Any]


@dataclass(frozen=True)
class TreeShape:
    """A tree's nodes in depth-first order: what the tree topic shows of its structure.

    :meth:`of` reads it from a :class:`pirate_bt.trace.structure.TreeStructure`;
    :meth:`to_wire` and :meth:`from_wire` carry it to the publishing process as
    plain values (``marshal`` can send them).
    """

    name: str
    nodes: tuple[ShapeNode, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_id", {n.id: n for n in self.nodes})

    def node(self, node_id: str) -> ShapeNode:
        """The node with ``node_id`` (``KeyError`` if there is none)."""
        by_id: dict[str, ShapeNode] = self._by_id  # type: ignore[attr-defined]
        return by_id[node_id]

    def __iter__(self) -> Iterator[ShapeNode]:
        return iter(self.nodes)

    def __len__(self) -> int:
        return len(self.nodes)

    @classmethod
    def of(cls, structure: Any) -> TreeShape:
        """The shape of a ``TreeStructure`` (or a ``TreeShape``, returned as it is)."""
        if isinstance(structure, TreeShape):
            return structure
        return cls(
            str(structure.name),
            tuple(
                ShapeNode(n.id, n.name, n.type, n.kind, n.parent, tuple(n.children), dict(n.params))
                for n in structure
            ),
        )

    def to_wire(self) -> tuple[Any, ...]:
        """Plain values: ``(name, ((id, name, type, kind, parent, children, params), ...))``."""
        return (
            self.name,
            tuple(
                (n.id, n.name, n.type, n.kind, n.parent, n.children, dict(n.params))
                for n in self.nodes
            ),
        )

    @classmethod
    def from_wire(cls, data: Sequence[Any]) -> TreeShape:
        """The inverse of :meth:`to_wire`."""
        name, nodes = data
        return cls(
            str(name),
            tuple(
                ShapeNode(str(i), str(n), str(t), str(k), p, tuple(str(c) for c in ch), dict(pa))
                for i, n, t, k, p, ch, pa in nodes
            ),
        )


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
    # a lone surrogate (a tree built in Python) as its escape: it has no UTF-8, and
    # uuid5 raised UnicodeEncodeError (the bag export failed, the live topics went off)
    name = f"pirate-bt:{tree_name}:{node_id}".encode("utf-8", "backslashreplace")
    return uuid.uuid5(uuid.NAMESPACE_URL, name.decode("utf-8")).bytes


_ZERO_UUID = bytes(16)


class Ros2Mapper:
    """Turns :class:`Frame` values into :class:`Ros2Message` values (CDR bytes).

    Args:
        structure: The tree's shape: a :class:`TreeShape` or a trace's ``TreeStructure``.
        start_ns: The run's start, ns since the Unix epoch (stamps are this plus ``t_s``).
        frame_id: The ``frame_id`` of stamped messages.
        hardware_id: The diagnostics' hardware id (the robot's name).
        period_s: The tick period, for the tree's statistics.
    """

    def __init__(
        self,
        structure: Any,
        start_ns: int,
        *,
        frame_id: str = "pirate",
        hardware_id: str = "pirate",
        period_s: float = 0.0,
    ) -> None:
        self.structure = TreeShape.of(structure)
        self.start_ns = start_ns
        self.frame_id = frame_id
        self.hardware_id = hardware_id
        self.period_s = period_s
        self._uuids = {n.id: node_uuid(self.structure.name, n.id) for n in self.structure}
        self._fixed: dict[str, tuple[bytes, bytes, bytes]] | None = None
        self._last_tree: tuple[Any, ...] | None = None
        self._last: dict[str, Any] = {}

    def stamp(self, t_s: float) -> cdr.Stamp:
        """A ``builtin_interfaces/Time`` ``(sec, nanosec)`` at ``t_s`` seconds into the run."""
        ns = self.start_ns + round(t_s * 1e9)
        return ns // 1_000_000_000, ns % 1_000_000_000

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
            out.append(Ros2Message(CLOCK, TOPIC_TYPES[CLOCK], ns, cdr.clock(self.stamp(frame.t_s))))
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

    def _joint_states(self, frame: Frame) -> bytes:
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
        return cdr.joint_state(self.stamp(frame.t_s), self.frame_id, names, position, velocity, ())

    def _clamp_key(self, frame: Frame) -> Any:
        forces = self._view(frame.state, "clamp_force_n")
        return tuple(forces) or None

    def _clamp_forces(self, frame: Frame) -> bytes:
        forces = self._view(frame.state, "clamp_force_n")
        return cdr.joint_state(
            self.stamp(frame.t_s),
            self.frame_id,
            [name for name, _ in forces],
            (),
            (),
            [_number(v) for _, v in forces],
        )

    def _imu_key(self, frame: Frame) -> Any:
        imu = tuple(self._view(frame.state, "imu_rad"))
        return imu or None

    def _imu(self, frame: Frame) -> bytes:
        imu = dict(self._view(frame.state, "imu_rad"))
        orientation = _quaternion(
            _number(imu.get("roll", 0.0)),
            _number(imu.get("pitch", 0.0)),
            _number(imu.get("yaw", 0.0)),
        )
        unknown = (0.0,) * 9
        none = (-1.0,) + (0.0,) * 8  # REP-145 / sensor_msgs: "no estimate for this element"
        zero = (0.0, 0.0, 0.0)
        return cdr.imu(
            self.stamp(frame.t_s), self.frame_id, orientation, unknown, zero, none, zero, none
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
    ) -> cdr.DiagnosticStatus:
        return level, name, message, self.hardware_id, [(k, _text(v)) for k, v in values]

    def _diagnostics(self, frame: Frame) -> bytes:
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
        return cdr.diagnostic_array(self.stamp(frame.t_s), self.frame_id, statuses)

    # --- localisation ----------------------------------------------------------------------

    def _belief_key(self, frame: Frame) -> Any:
        return frame.task.get("belief_m")

    def _truth_key(self, frame: Frame) -> Any:
        return frame.task.get("truth_m")

    def _point(self, frame: Frame, x: Any) -> bytes:
        return cdr.point_stamped(self.stamp(frame.t_s), "route", (_number(x), 0.0, 0.0))

    def _belief(self, frame: Frame) -> bytes:
        return self._point(frame, frame.task.get("belief_m"))

    def _truth(self, frame: Frame) -> bytes:
        return self._point(frame, frame.task.get("truth_m"))

    # --- the tree ---------------------------------------------------------------------------

    def _fixed_parts(self) -> dict[str, tuple[bytes, bytes, bytes]]:
        """Each behaviour's parts that are the same in every snapshot (made once)."""
        if self._fixed is None:
            uuids = self._uuids

            def as_uuid(node_id: str | None) -> bytes:
                return uuids.get(node_id, _ZERO_UUID) if node_id is not None else _ZERO_UUID

            self._fixed = {
                info.id: cdr.behaviour_parts(
                    info.name,
                    info.type,
                    as_uuid(info.id),
                    as_uuid(info.parent),
                    [as_uuid(c) for c in info.children],
                    _behaviour_type(info.kind, info.type),
                    json.dumps(dict(info.params), default=str) if info.params else "",
                    _NOT_A_BLACKBOX,
                )
                for info in self.structure
            }
        return self._fixed

    def _tree(self, frame: Frame, changed: bool) -> bytes:
        fixed = self._fixed_parts()
        uuids = self._uuids
        statuses = frame.statuses
        feedback = frame.feedback
        structure = self.structure

        def as_uuid(node_id: str | None) -> bytes:
            return uuids.get(node_id, _ZERO_UUID) if node_id is not None else _ZERO_UUID

        tips: dict[str, str | None] = {}

        def tip(node_id: str) -> str | None:
            if node_id in tips:
                return tips[node_id]
            info = structure.node(node_id)
            status = statuses.get(node_id, "I")
            found: str | None = None
            if status != "I":
                current = _current_child(info.children, statuses)
                found = tip(current) if current is not None else node_id
                found = found or node_id
            tips[node_id] = found
            return found

        behaviours = []
        for info in structure:
            status = statuses.get(info.id, "I")
            behaviours.append(
                cdr.behaviour(
                    fixed[info.id],
                    as_uuid(tip(info.id)),
                    as_uuid(_current_child(info.children, statuses)),
                    _STATUS.get(status, 1),
                    str(feedback.get(info.id, "")),
                    status != "I",
                )
            )
        blackboard = [(str(k), _text(v)) for k, v in sorted(frame.blackboard.items())]
        return cdr.behaviour_tree(
            behaviours,
            changed,
            blackboard,
            int(frame.n),
            self.stamp(frame.t_s),
            float(self.period_s),
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
