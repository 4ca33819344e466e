"""The ROS 2 message types pirate_bt speaks, their CDR encoding and their type hashes.

A ROS 2 message on the wire is the message in CDR (little-endian, with the
4-byte encapsulation header), and a topic is matched by its type's *name* as DDS
spells it (``sensor_msgs::msg::dds_::JointState_``) and its *type hash*
(``RIHS01_`` and a SHA-256 over the type's description, REP-2016).

The definitions below are the field lists of the standard messages we use
(``common_interfaces``, ``rcl_interfaces``, ``unique_identifier_msgs``, as in
ROS 2 Jazzy) and of ``py_trees_ros_interfaces`` 2.1 (the messages py_trees_ros's
tree watcher and viewer read), without their comments. Only the fields and
their types enter a type hash, so these lists decide our hashes.

Publishing needs neither numpy nor `rosbags <https://gitlab.com/ternaris/rosbags>`_:
the CDR is :mod:`pirate_bt.interop.ros2_cdr`, and the hashes are the table
:data:`TYPE_HASHES`, computed once by rosbags from :data:`DEFINITIONS`
(:func:`rosbags_type_hash`). ``tests/test_ros2.py`` recomputes every entry with
rosbags, and holds the standard ones against rosbags' own Jazzy type store and an
independent ROS-2-over-Zenoh client's hash code. rosbags' type store
(:func:`typestore`, parsed from :data:`DEFINITIONS` in a few milliseconds
instead of the 0.2 s of its whole Jazzy store) serves the rosbag2 writer and
reader and the tests.
"""

from __future__ import annotations

import threading
from functools import cache
from typing import Any

from pirate_bt.errors import ConfigurationError

__all__ = [
    "DEFINITIONS",
    "EXTRA_HINT",
    "TYPE_HASHES",
    "dds_type_name",
    "missing",
    "rosbags_type_hash",
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

#: ROS 2 type name -> its RIHS01 type hash: :func:`rosbags_type_hash` of each of
#: :data:`DEFINITIONS`, written out so that publishing needs no rosbags (the tests
#: recompute every entry; change a definition, run them, and copy what they print).
TYPE_HASHES: dict[str, str] = {
    "builtin_interfaces/msg/Time": (
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197"
    ),
    "std_msgs/msg/Header": (
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01"
    ),
    "std_msgs/msg/Bool": (
        "RIHS01_feb91e995ff9ebd09c0cb3d2aed18b11077585839fb5db80193b62d74528f6c9"
    ),
    "std_msgs/msg/String": (
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    ),
    "rosgraph_msgs/msg/Clock": (
        "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564"
    ),
    "geometry_msgs/msg/Point": (
        "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881"
    ),
    "geometry_msgs/msg/PointStamped": (
        "RIHS01_4c0296af86e01e562e9e0405d138a01537247580076c58ea38d7923ac1045897"
    ),
    "geometry_msgs/msg/Quaternion": (
        "RIHS01_8a765f66778c8ff7c8ab94afcc590a2ed5325a1d9a076ffff38fbce36f458684"
    ),
    "geometry_msgs/msg/Vector3": (
        "RIHS01_cc12fe83e4c02719f1ce8070bfd14aecd40f75a96696a67a2a1f37f7dbb0765d"
    ),
    "sensor_msgs/msg/JointState": (
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e"
    ),
    "sensor_msgs/msg/Imu": (
        "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b"
    ),
    "diagnostic_msgs/msg/KeyValue": (
        "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42"
    ),
    "diagnostic_msgs/msg/DiagnosticStatus": (
        "RIHS01_b0e3e692ea2d54a8af2f4ef1930e81556a2db55216b771f8a7d2724ed47bf0e4"
    ),
    "diagnostic_msgs/msg/DiagnosticArray": (
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e"
    ),
    "unique_identifier_msgs/msg/UUID": (
        "RIHS01_1b8e8aca958cbea28fe6ef60bf6c19b683c97a9ef60bb34752067d0f2f7ab437"
    ),
    "py_trees_ros_interfaces/msg/KeyValue": (
        "RIHS01_c680be290238ebb510a3110c658c225d342d0d2ce9967c47a39cb832463aa9e6"
    ),
    "py_trees_ros_interfaces/msg/ActivityItem": (
        "RIHS01_28c7d519bcdd437b108a2571669ef7e48a0ff005dcaf2f990d775fac820f6da9"
    ),
    "py_trees_ros_interfaces/msg/Statistics": (
        "RIHS01_6afd684b110c2e82e17d9755673ecb90beacea2e87babe4fa15e82f9a9355807"
    ),
    "py_trees_ros_interfaces/msg/Behaviour": (
        "RIHS01_591a951497cabdf423bafa33b69bc9de974154a3d52b53fccacbfdc911d9e772"
    ),
    "py_trees_ros_interfaces/msg/BehaviourTree": (
        "RIHS01_fbea5f031e37fdce7feb9f63dd16665db8d2a8f4150d907bd4b5c1f93ed49afa"
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


def type_hash(type_name: str) -> str:
    """The RIHS01 type hash of ``type_name`` (``RIHS01_`` + 64 hex digits), from the table.

    Raises:
        KeyError: not one of :data:`DEFINITIONS`.
    """
    return TYPE_HASHES[type_name]


@cache
def rosbags_type_hash(type_name: str) -> str:
    """The RIHS01 type hash of ``type_name`` as rosbags computes it from :data:`DEFINITIONS`."""
    return str(typestore().hash_rihs01(type_name))


def dds_type_name(type_name: str) -> str:
    """``sensor_msgs/msg/JointState`` -> ``sensor_msgs::msg::dds_::JointState_``."""
    package, kind, name = type_name.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def serialize(message: Any, type_name: str) -> bytes:
    """``message`` (a type store message object) in CDR, little-endian, with its header."""
    return bytes(typestore().serialize_cdr(message, type_name))
