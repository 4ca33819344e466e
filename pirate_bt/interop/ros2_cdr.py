"""CDR for the handful of ROS 2 message types pirate_bt publishes, by hand.

A ROS 2 message on the wire (rmw_zenoh's payload, a rosbag2 record) is the
message in CDR as Fast-CDR writes it for ``rmw``: a 4-byte encapsulation header
(``00 01 00 00``: plain CDR, little-endian), then the fields in order, each
primitive aligned to its own size counted from the end of that header (1 for
``bool``, ``byte`` and ``uint8``, 4 for ``int32``, ``uint32`` and ``float32``,
8 for ``int64`` and ``float64``), with zero bytes as padding:

- a ``string`` is a ``uint32`` length that counts its UTF-8 bytes and the
  terminating NUL, then those bytes and the NUL;
- a sequence (``T[]``) is a ``uint32`` element count, then the elements; an
  empty one is the count alone (no padding for the elements that are not there);
- a fixed array (``T[9]``) is its elements, with no count;
- a nested message is its fields, in place; nothing is padded at the end.

This is the whole of CDR that :data:`pirate_bt.interop.ros2_types.DEFINITIONS`
needs, written with ``struct`` so that publishing imports neither numpy nor
rosbags and generates no code. ``tests/test_ros2.py`` holds every message the
mapper makes byte for byte against rosbags' own serialiser, and decodes them
with rosbags, so rosbags stays the independent reference.

The encoders take plain Python values (``stamp`` is ``(sec, nanosec)``); the
tree's behaviours are encoded one by one with :func:`behaviour` so that the
parts that never change can be kept (see its docstring).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Sequence

__all__ = [
    "ENCAPSULATION",
    "CdrWriter",
    "behaviour",
    "behaviour_tree",
    "bool_message",
    "clock",
    "diagnostic_array",
    "imu",
    "joint_state",
    "point_stamped",
    "string_message",
]

ENCAPSULATION = b"\x00\x01\x00\x00"
"""CDR_LE: plain CDR, little-endian, no options."""

_ZEROS = tuple(bytes(n) for n in range(8))
_U32 = struct.Struct("<I")
_I32 = struct.Struct("<i")
_I64 = struct.Struct("<q")
_F64 = struct.Struct("<d")
_TIME = struct.Struct("<iI")
_F32X6 = struct.Struct("<6f")

Stamp = tuple[int, int]
"""A ``builtin_interfaces/msg/Time``: ``(sec, nanosec)``."""


def _utf8(text: str) -> bytes:
    return text.encode("utf-8", "replace")


class CdrWriter:
    """Appends CDR fields to a buffer, aligned from the start of the body.

    Args:
        header: Start with the encapsulation header (a whole message); without it,
            a part whose alignment is counted from its own first byte (it must then
            go where the same alignment holds, see :func:`behaviour`).
    """

    __slots__ = ("_base", "buf")

    def __init__(self, header: bool = True) -> None:
        self.buf = bytearray(ENCAPSULATION if header else b"")
        self._base = len(self.buf)

    def align(self, size: int) -> None:
        """Pad with zero bytes up to a multiple of ``size`` from the body's start."""
        pad = (self._base - len(self.buf)) % size
        if pad:
            self.buf += _ZEROS[pad]

    def octet(self, value: int) -> None:
        """A ``bool``, ``byte`` or ``uint8``."""
        self.buf.append(value)

    def boolean(self, value: bool) -> None:
        self.buf.append(1 if value else 0)

    def raw(self, data: bytes) -> None:
        """Bytes written as they are (``uint8[N]``, or a part encoded before)."""
        self.buf += data

    def int32(self, value: int) -> None:
        self.align(4)
        self.buf += _I32.pack(value)

    def uint32(self, value: int) -> None:
        self.align(4)
        self.buf += _U32.pack(value)

    def int64(self, value: int) -> None:
        self.align(8)
        self.buf += _I64.pack(value)

    def float64(self, value: float) -> None:
        self.align(8)
        self.buf += _F64.pack(value)

    def float64s(self, values: Sequence[float]) -> None:
        """A ``float64[N]`` (no count; aligned only when there is something)."""
        if values:
            self.align(8)
            self.buf += struct.pack(f"<{len(values)}d", *values)

    def float64_sequence(self, values: Sequence[float]) -> None:
        """A ``float64[]``."""
        self.uint32(len(values))
        self.float64s(values)

    def string(self, text: str) -> None:
        data = _utf8(text)
        self.align(4)
        self.buf += _U32.pack(len(data) + 1)
        self.buf += data
        self.buf.append(0)

    def strings(self, texts: Sequence[str]) -> None:
        """A ``string[]``."""
        self.uint32(len(texts))
        for text in texts:
            self.string(text)

    def time(self, stamp: Stamp) -> None:
        """A ``builtin_interfaces/msg/Time``."""
        self.align(4)
        self.buf += _TIME.pack(*stamp)

    def header(self, stamp: Stamp, frame_id: str) -> None:
        """A ``std_msgs/msg/Header``."""
        self.time(stamp)
        self.string(frame_id)

    def key_values(self, pairs: Iterable[tuple[str, str]]) -> None:
        """A ``KeyValue[]`` (``diagnostic_msgs`` or ``py_trees_ros_interfaces``: both are
        ``string key, string value``)."""
        items = list(pairs)
        self.uint32(len(items))
        for key, value in items:
            self.string(key)
            self.string(value)

    def getvalue(self) -> bytes:
        return bytes(self.buf)


# --- whole messages --------------------------------------------------------------------------


def string_message(text: str) -> bytes:
    """``std_msgs/msg/String``."""
    out = CdrWriter()
    out.string(text)
    return out.getvalue()


def bool_message(value: bool) -> bytes:
    """``std_msgs/msg/Bool``."""
    out = CdrWriter()
    out.boolean(value)
    return out.getvalue()


def clock(stamp: Stamp) -> bytes:
    """``rosgraph_msgs/msg/Clock``."""
    out = CdrWriter()
    out.time(stamp)
    return out.getvalue()


def joint_state(
    stamp: Stamp,
    frame_id: str,
    names: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float],
    effort: Sequence[float],
) -> bytes:
    """``sensor_msgs/msg/JointState``."""
    out = CdrWriter()
    out.header(stamp, frame_id)
    out.strings(names)
    out.float64_sequence(position)
    out.float64_sequence(velocity)
    out.float64_sequence(effort)
    return out.getvalue()


def imu(
    stamp: Stamp,
    frame_id: str,
    orientation: Sequence[float],
    orientation_covariance: Sequence[float],
    angular_velocity: Sequence[float],
    angular_velocity_covariance: Sequence[float],
    linear_acceleration: Sequence[float],
    linear_acceleration_covariance: Sequence[float],
) -> bytes:
    """``sensor_msgs/msg/Imu`` (``orientation`` is ``(x, y, z, w)``; vectors ``(x, y, z)``,
    covariances nine values each)."""
    out = CdrWriter()
    out.header(stamp, frame_id)
    for values, size in (
        (orientation, 4),
        (orientation_covariance, 9),
        (angular_velocity, 3),
        (angular_velocity_covariance, 9),
        (linear_acceleration, 3),
        (linear_acceleration_covariance, 9),
    ):
        if len(values) != size:
            raise ValueError(f"sensor_msgs/msg/Imu: {size} values expected, not {len(values)}")
        out.float64s(values)
    return out.getvalue()


DiagnosticStatus = tuple[int, str, str, str, Sequence[tuple[str, str]]]
"""``(level, name, message, hardware_id, [(key, value), ...])``."""


def diagnostic_array(stamp: Stamp, frame_id: str, statuses: Sequence[DiagnosticStatus]) -> bytes:
    """``diagnostic_msgs/msg/DiagnosticArray``."""
    out = CdrWriter()
    out.header(stamp, frame_id)
    out.uint32(len(statuses))
    for level, name, message, hardware_id, values in statuses:
        out.octet(level)
        out.string(name)
        out.string(message)
        out.string(hardware_id)
        out.key_values(values)
    return out.getvalue()


def point_stamped(stamp: Stamp, frame_id: str, point: Sequence[float]) -> bytes:
    """``geometry_msgs/msg/PointStamped`` (``point`` is ``(x, y, z)``)."""
    out = CdrWriter()
    out.header(stamp, frame_id)
    out.float64s(point)
    return out.getvalue()


# --- the tree ---------------------------------------------------------------------------------


def behaviour(
    fixed: tuple[bytes, bytes, bytes],
    tip_id: bytes,
    current_child_id: bytes,
    status: int,
    message: str,
    is_active: bool,
) -> bytes:
    """One ``py_trees_ros_interfaces/msg/Behaviour`` of a snapshot, from its fixed parts.

    A behaviour's widest field is 4 bytes and it starts with a string, so it
    always starts 4-aligned and its bytes do not depend on where in the snapshot
    it goes: it is encoded on its own (alignment counted from its first byte).
    The parts that are the same in every snapshot are :func:`behaviour_parts`.
    """
    head, children, middle = fixed
    out = CdrWriter(header=False)
    out.raw(head)  # name, class_name, own_id, parent_id
    out.raw(tip_id)
    out.raw(children)  # padding, child_ids (the offset here is fixed)
    out.raw(current_child_id)
    out.raw(middle)  # type, padding, additional_detail, blackbox_level
    out.octet(status)
    out.string(message)
    out.boolean(is_active)
    out.uint32(0)  # blackboard_access: empty
    return out.getvalue()


def behaviour_parts(
    name: str,
    class_name: str,
    own_id: bytes,
    parent_id: bytes,
    child_ids: Sequence[bytes],
    kind: int,
    additional_detail: str,
    blackbox_level: int,
) -> tuple[bytes, bytes, bytes]:
    """The parts of a behaviour that do not change between snapshots (see :func:`behaviour`)."""
    out = CdrWriter(header=False)
    out.string(name)
    out.string(class_name)
    out.raw(own_id)
    out.raw(parent_id)
    head = out.getvalue()
    out.raw(bytes(16))  # tip_id's place
    at = len(out.buf)
    out.uint32(len(child_ids))
    for child in child_ids:
        out.raw(child)
    children = bytes(out.buf[at:])
    out.raw(bytes(16))  # current_child_id's place
    at = len(out.buf)
    out.octet(kind)
    out.string(additional_detail)
    out.octet(blackbox_level)
    middle = bytes(out.buf[at:])
    return head, children, middle


def behaviour_tree(
    behaviours: Sequence[bytes],
    changed: bool,
    blackboard: Sequence[tuple[str, str]],
    count: int,
    stamp: Stamp,
    tick_interval: float,
) -> bytes:
    """``py_trees_ros_interfaces/msg/BehaviourTree`` from behaviours made by :func:`behaviour`.

    No blackboard activity; the statistics carry the tick count, the stamp and the
    tick period as interval (durations and variances 0).
    """
    out = CdrWriter()
    out.uint32(len(behaviours))
    for item in behaviours:
        out.raw(item)  # each starts and ends 4-aligned
    out.boolean(changed)
    out.key_values(blackboard)
    out.uint32(0)  # blackboard_activity: empty
    out.int64(count)
    out.time(stamp)
    out.buf += _F32X6.pack(0.0, 0.0, 0.0, tick_interval, tick_interval, 0.0)
    return out.getvalue()
