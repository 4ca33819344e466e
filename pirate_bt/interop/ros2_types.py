"""The ROS 2 message types pirate_bt speaks, their CDR encoding and their type hashes.

A ROS 2 message on the wire is the message in CDR (little-endian, with the
4-byte encapsulation header), and a topic is matched by its type's *name* as DDS
spells it (``sensor_msgs::msg::dds_::JointState_``) and its *type hash*
(``RIHS01_`` and a SHA-256 over the type's description, REP-2016). Both are
made here with `rosbags <https://gitlab.com/ternaris/rosbags>`_: its type store
serialises messages to CDR and computes RIHS01 hashes (``hash_rihs01``); we do
neither by hand.

The definitions below are the field lists of the standard messages we use
(``common_interfaces``, ``rcl_interfaces``, ``unique_identifier_msgs``, as in
ROS 2 Jazzy) and of ``py_trees_ros_interfaces`` 2.1 (the messages py_trees_ros's
tree watcher and viewer read), without their comments. Only the fields and
their types enter a type hash, so these lists decide our hashes:
``tests/test_ros2.py`` checks every standard one against rosbags' own Jazzy type
store and against an independent ROS-2-over-Zenoh client's hash code. They are
parsed into an otherwise empty type store, which costs a few milliseconds
instead of the 0.2 s of loading rosbags' whole Jazzy store.
"""

from __future__ import annotations

import threading
from functools import cache
from typing import Any

from pirate_bt.errors import ConfigurationError

__all__ = [
    "DEFINITIONS",
    "EXTRA_HINT",
    "dds_type_name",
    "missing",
    "serialize",
    "type_hash",
    "typestore",
]

EXTRA_HINT = "pip install 'pirate-bt[ros2]'"

#: ROS 2 type name -> its fields (``.msg`` syntax, comments left out).
DEFINITIONS: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "std_msgs/msg/Bool": "bool data\n",
    "std_msgs/msg/String": "string data\n",
    "rosgraph_msgs/msg/Clock": "builtin_interfaces/Time clock\n",
    "geometry_msgs/msg/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/msg/PointStamped": "std_msgs/Header header\ngeometry_msgs/Point point\n",
    "geometry_msgs/msg/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
    "geometry_msgs/msg/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "sensor_msgs/msg/JointState": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n"
        "float64[] effort\n"
    ),
    "sensor_msgs/msg/Imu": (
        "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n"
        "float64[9] orientation_covariance\ngeometry_msgs/Vector3 angular_velocity\n"
        "float64[9] angular_velocity_covariance\ngeometry_msgs/Vector3 linear_acceleration\n"
        "float64[9] linear_acceleration_covariance\n"
    ),
    "diagnostic_msgs/msg/KeyValue": "string key\nstring value\n",
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n"
        "byte level\nstring name\nstring message\nstring hardware_id\n"
        "diagnostic_msgs/KeyValue[] values\n"
    ),
    "diagnostic_msgs/msg/DiagnosticArray": (
        "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status\n"
    ),
    "unique_identifier_msgs/msg/UUID": "uint8[16] uuid\n",
    "py_trees_ros_interfaces/msg/KeyValue": "string key\nstring value\n",
    "py_trees_ros_interfaces/msg/ActivityItem": (
        'string READ="READ"\nstring INITIALISED="INITIALISED"\nstring WRITE="WRITE"\n'
        'string ACCESSED="ACCESSED"\nstring ACCESS_DENIED="ACCESS_DENIED"\n'
        'string NO_KEY="NO_KEY"\nstring NO_OVERWRITE="NO_OVERWRITE"\nstring UNSET="UNSET"\n'
        "string key\nstring client_name\nstring activity_type\nstring previous_value\n"
        "string current_value\n"
    ),
    "py_trees_ros_interfaces/msg/Statistics": (
        "int64 count\nbuiltin_interfaces/Time stamp\nfloat32 tick_duration\n"
        "float32 tick_duration_average\nfloat32 tick_duration_variance\n"
        "float32 tick_interval\nfloat32 tick_interval_average\nfloat32 tick_interval_variance\n"
    ),
    "py_trees_ros_interfaces/msg/Behaviour": (
        "uint8 INVALID=1\nuint8 RUNNING=2\nuint8 SUCCESS=3\nuint8 FAILURE=4\n"
        "uint8 UNKNOWN_TYPE=0\nuint8 BEHAVIOUR=1\nuint8 SEQUENCE=2\nuint8 SELECTOR=3\n"
        "uint8 PARALLEL=4\nuint8 CHOOSER=5\nuint8 DECORATOR=6\n"
        "uint8 BLACKBOX_LEVEL_DETAIL=1\nuint8 BLACKBOX_LEVEL_COMPONENT=2\n"
        "uint8 BLACKBOX_LEVEL_BIG_PICTURE=3\nuint8 BLACKBOX_LEVEL_NOT_A_BLACKBOX=4\n"
        'string BLACKBOARD_ACCESS_READ="r"\nstring BLACKBOARD_ACCESS_WRITE="w"\n'
        'string BLACKBOARD_ACCESS_EXCLUSIVE_WRITE="x"\n'
        "string name\nstring class_name\nunique_identifier_msgs/UUID own_id\n"
        "unique_identifier_msgs/UUID parent_id\nunique_identifier_msgs/UUID tip_id\n"
        "unique_identifier_msgs/UUID[] child_ids\nunique_identifier_msgs/UUID current_child_id\n"
        "uint8 type\nstring additional_detail\nuint8 blackbox_level\nuint8 status\n"
        "string message\nbool is_active\npy_trees_ros_interfaces/KeyValue[] blackboard_access\n"
    ),
    "py_trees_ros_interfaces/msg/BehaviourTree": (
        "py_trees_ros_interfaces/Behaviour[] behaviours\nbool changed\n"
        "diagnostic_msgs/KeyValue[] blackboard_on_visited_path\n"
        "py_trees_ros_interfaces/ActivityItem[] blackboard_activity\n"
        "py_trees_ros_interfaces/Statistics statistics\n"
    ),
}

_lock = threading.Lock()


def missing(what: str, module: str) -> str:
    """The one-line message for a missing optional dependency of the ROS 2 bridge."""
    return f"{what} needs the '{module}' package: {EXTRA_HINT}"


@cache
def typestore() -> Any:
    """A rosbags type store holding :data:`DEFINITIONS` (built once).

    Raises:
        ConfigurationError: ``rosbags`` is not installed.
    """
    with _lock:
        try:
            from rosbags.typesys import Stores, get_types_from_msg, get_typestore
        except ImportError:
            raise ConfigurationError(missing("ROS 2 output", "rosbags")) from None
        store = get_typestore(Stores.EMPTY)
        types: dict[str, Any] = {}
        for name, text in DEFINITIONS.items():
            types.update(get_types_from_msg(text, name))
        store.register(types)
        return store


@cache
def type_hash(type_name: str) -> str:
    """The RIHS01 type hash of ``type_name`` (``RIHS01_`` + 64 hex digits), by rosbags."""
    return str(typestore().hash_rihs01(type_name))


def dds_type_name(type_name: str) -> str:
    """``sensor_msgs/msg/JointState`` -> ``sensor_msgs::msg::dds_::JointState_``."""
    package, kind, name = type_name.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def serialize(message: Any, type_name: str) -> bytes:
    """``message`` (a type store message object) in CDR, little-endian, with its header."""
    return bytes(typestore().serialize_cdr(message, type_name))
