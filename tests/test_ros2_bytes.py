"""ROS 2 bytes checked against rosbags: our CDR byte for byte, and rosbag2 exports read back.

Split from ``tests/test_ros2.py`` (the live side, against zenoh-ros2-sdk and a
router). These need only ``rosbags``: every message of a run as rosbags writes it,
the publishing process's imports, joint states decoded by hand, and a mission
exported to a rosbag2 directory that rosbags reads back whole.
"""

from __future__ import annotations

import bisect
import json
import math
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("rosbags")

import pirate_bt
from pirate_bt.interop import rmw_zenoh
from pirate_bt.interop.ros2_topics import TOPIC_TYPES
from pirate_bt.trace import TickFrame

SHORT_BEND = Path(__file__).parent / "data" / "networks" / "bend-right-short.yaml"


def _rosbags_agrees(data: bytes, type_name: str) -> Any:
    """rosbags decodes ``data`` and, encoding what it decoded, writes the same bytes."""
    from pirate_bt.interop.ros2_types import typestore

    store = typestore()
    message = store.deserialize_cdr(data, type_name)
    assert bytes(store.serialize_cdr(message, type_name)) == data, type_name
    return message


def test_our_cdr_is_rosbags_cdr_byte_for_byte(tmp_path: Path) -> None:
    """Every message of a run (and of a frame with every odd value) as rosbags writes it."""
    from pirate_bt.interop.ros2_topics import Frame, Ros2Mapper
    from pirate_bt.interop.rosbag2 import frames_from_records
    from pirate_bt.trace.structure import TreeStructure

    trace_path = tmp_path / "run.jsonl"
    result = pirate_bt.simulate_tree("straight", params={"distance": "0.3 m"}, trace=trace_path)
    assert result.succeeded
    lines = [json.loads(line) for line in trace_path.read_text().splitlines() if line.strip()]
    seen: dict[str, int] = {}
    mapper: Any = None
    for record, frame in frames_from_records(lines):
        if record.get("type") == "header":
            structure = TreeStructure.from_json(record["tree"])
            mapper = Ros2Mapper(structure, 1_700_000_000 * 10**9, period_s=0.05)
        if frame is None:
            continue
        for message in mapper.messages(frame, changed=True, clock=True):
            _rosbags_agrees(message.data, message.type_name)
            seen[message.topic] = seen.get(message.topic, 0) + 1
    assert set(seen) >= {"joint_states", "imu", "clamp_forces", "diagnostics", "tree/snapshots"}

    # Odd values: NaN and infinities, text beyond ASCII, empty sequences, a 9-byte
    # string (padding before the next length), every diagnostic status, a tree with
    # feedback, a blackboard and parameters.
    structure = TreeStructure.from_json(
        {
            "name": "tree",
            "nodes": [
                {"id": "0", "name": "root", "type": "Sequence", "kind": "composite",
                 "parent": None, "children": ["0.0", "0.1"]},
                {"id": "0.0", "name": "größe", "type": "Timeout", "kind": "guard",
                 "parent": "0", "children": ["0.0.0"], "params": {"duration": 1.5}},
                {"id": "0.0.0", "name": "clamp", "type": "Clamp", "kind": "leaf",
                 "parent": "0.0", "children": []},
                {"id": "0.1", "name": "drive 12345", "type": "Drive", "kind": "leaf",
                 "parent": "0", "children": []},
            ],
        }
    )  # fmt: skip
    mapper = Ros2Mapper(structure, 1_700_000_123 * 10**9, hardware_id="π", period_s=0.05)
    frame = Frame(
        n=7,
        t_s=12.345678,
        state={
            "joint_angle_rad.bend_1": math.nan,
            "joint_angle_rad.bend_2": -0.5,
            "rotation_rad": 1.25,
            "drive_velocity_mps.d1": math.inf,
            "clamp_force_n.bend_1": 12.5,
            "imu_rad.roll": 0.1,
            "imu_rad.pitch": -0.2,
            "imu_rad.yaw": 3.0,
            "motor_current_a.rotate": 0.75,
        },
        link={"connected": True, "loss_ratio": 0.25, "rtt_s": None},
        sim={"damage": 1, "violations": 0},
        task={"belief_m": 2.5, "truth_m": 2.4},
        statuses={"0": "R", "0.0": "R", "0.0.0": "R", "0.1": "I"},
        feedback={"0.0.0": "clamping… 5 N"},
        blackboard={"x": 1.5, "name": "ünïcode", "list": [1, 2]},
        supervisor={"mode": "estop", "safe_state": "stale data", "last_verdict": None},
    )
    messages = {m.topic: m for m in mapper.messages(frame, clock=True)}
    assert set(messages) == set(TOPIC_TYPES)
    decoded = {t: _rosbags_agrees(m.data, m.type_name) for t, m in messages.items()}
    joints = decoded["joint_states"]
    assert list(joints.name) == ["bend_1", "bend_2", "rotation", "d1"]
    assert math.isnan(joints.position[0]) and joints.position[1] == -0.5
    assert joints.velocity[3] == math.inf and len(joints.effort) == 0
    assert (joints.header.stamp.sec, joints.header.stamp.nanosec) == (1_700_000_135, 345_678_000)
    assert list(decoded["clamp_forces"].effort) == [12.5]
    assert decoded["imu"].orientation_covariance[0] == 0.0
    assert decoded["imu"].angular_velocity_covariance[0] == -1.0
    statuses = decoded["diagnostics"].status
    assert [s.level for s in statuses] == [1, 2, 0, 1]
    assert statuses[0].hardware_id == "π"
    assert decoded["localisation/truth"].point.x == 2.4
    tree = decoded["tree/snapshots"]
    assert [b.name for b in tree.behaviours] == ["root", "größe", "clamp", "drive 12345"]
    assert [b.status for b in tree.behaviours] == [2, 2, 2, 1]
    assert tree.behaviours[2].message == "clamping… 5 N"
    assert json.loads(tree.behaviours[1].additional_detail) == {"duration": 1.5}
    assert bytes(tree.behaviours[0].tip_id.uuid) == bytes(tree.behaviours[2].own_id.uuid)
    assert {kv.key: kv.value for kv in tree.blackboard_on_visited_path}["name"] == "ünïcode"
    assert tree.statistics.count == 7
    assert tree.statistics.tick_interval == pytest.approx(0.05)


def test_the_publishing_process_needs_no_numpy_rosbags_or_py_trees() -> None:

    from pirate_bt.interop import ros2_process

    probe = (
        "import runpy, sys; runpy.run_path(sys.argv[1], run_name='probe');"
        " print(sorted({m.split('.')[0] for m in sys.modules}"
        " & {'numpy', 'rosbags', 'py_trees', 'zenoh'}))"
    )
    done = subprocess.run(
        [sys.executable, "-I", "-c", probe, ros2_process.__file__],
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.strip() == "[]"  # zenoh comes when the process runs, the rest never


def test_joint_state_bytes_decode_by_hand() -> None:
    """The CDR of one JointState, read with struct alone (no rosbags on this side)."""
    from pirate_bt.interop.ros2_topics import Frame, Ros2Mapper
    from pirate_bt.trace.structure import TreeStructure

    mapper = Ros2Mapper(TreeStructure(name="t", nodes=()), 1_700_000_000 * 10**9)
    frame = Frame(
        n=1, t_s=1.5, state={"joint_angle_rad.bend_1": 0.25, "drive_velocity_mps.d": 0.08}
    )
    (message,) = [m for m in mapper.messages(frame) if m.topic == "joint_states"]
    data = message.data
    assert data[:4] == b"\x00\x01\x00\x00"  # CDR, little-endian
    body = data[4:]
    sec, nanosec, length = struct.unpack_from("<iII", body, 0)
    assert (sec, nanosec) == (1_700_000_001, 500_000_000)
    assert body[12 : 12 + length] == b"pirate\x00"


# --- rosbag2 --------------------------------------------------------------------------------------


@pytest.mark.slow
def test_a_mission_exports_to_a_rosbag2_directory_that_rosbags_reads_back_whole(
    tmp_path: Path,
) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    from pirate_bt.cli import main
    from pirate_bt.interop.rosbag2 import read_rosbag2_records

    # A mission of two PABs (the bend, which the robot starts near enough to take at
    # once, and an inspection) on the short bend network: what is checked (every record
    # and message read back whole) does not depend on how far the robot goes, and this
    # is under half the ticks of the bundled bend-right route.
    (tmp_path / SHORT_BEND.name).write_text(SHORT_BEND.read_text())
    route = tmp_path / "short-bend.route"
    route.write_text(f"network {SHORT_BEND.stem}\nat the bend turn right\ninspect 0.3 m\n")
    trace_path = tmp_path / "run.jsonl"
    result = pirate_bt.simulate_mission(route, trace=trace_path)
    assert result.succeeded
    assert [p.kind for p in result.pabs] == ["bend", "straight"]
    bag = tmp_path / "run_bag"
    assert main(["trace", "export", str(trace_path), "-o", f"{bag}/"]) == 0
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "run_bag.mcap"]
    lines = [json.loads(line) for line in trace_path.read_text().splitlines() if line.strip()]
    assert read_rosbag2_records(bag) == lines  # every record, whole

    jazzy = get_typestore(Stores.ROS2_JAZZY)
    trace = pirate_bt.read_trace(trace_path)
    # Every frame once, in order (trace.frame_at(n) walks the frames from the start on
    # each call): the frame at tick n is the last one recorded at or before n.
    frames = list(trace.frames())
    numbers = [f.n for f in frames]

    def frame_at(n: int) -> TickFrame:
        return frames[bisect.bisect_right(numbers, n) - 1]

    for n in (0, 1, numbers[len(numbers) // 2], numbers[-1]):
        assert (frame_at(n).state, frame_at(n).status) == (
            trace.frame_at(n).state,
            trace.frame_at(n).status,
        )
    with AnyReader([bag], default_typestore=jazzy) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == {
            rmw_zenoh.qualified_name("/pirate", t): ty
            for t, ty in {**TOPIC_TYPES, "trace": "std_msgs/msg/String"}.items()
            if t != "/clock"
        }
        import yaml

        meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        assert meta["storage_identifier"] == "mcap"
        for topic in meta["topics_with_message_count"]:
            info = topic["topic_metadata"]
            assert info["serialization_format"] == "cdr"
            if not info["type"].startswith("py_trees"):
                assert info["type_description_hash"] == jazzy.hash_rihs01(info["type"])
        by_tick: dict[float, int] = {}
        counts: dict[str, int] = {}
        trace_msgs = [c for c in reader.connections if c.topic == "/pirate/trace"]
        start_ns = 0
        for c, stamp, raw in reader.messages(connections=trace_msgs):
            record = json.loads(reader.deserialize(raw, c.msgtype).data)
            if record["type"] == "header":
                start_ns = stamp
            elif record["type"] == "tick":
                by_tick[round((stamp - start_ns) / 1e9, 6)] = record["n"]
        for c, stamp, raw in reader.messages():
            counts[c.topic] = counts.get(c.topic, 0) + 1
            message = reader.deserialize(raw, c.msgtype)
            if c.topic == "/pirate/joint_states":
                n = by_tick[round((stamp - start_ns) / 1e9, 6)]
                state = frame_at(n).state
                for name, position in zip(message.name, message.position, strict=True):
                    key = f"joint_angle_rad.{name}"
                    if key in state:
                        assert position == pytest.approx(state[key], abs=1e-9)
            elif c.topic == "/pirate/tree/snapshots":
                n = int(message.statistics.count)
                codes = {1: "I", 2: "R", 3: "S", 4: "F"}
                status = frame_at(n).status
                for info, behaviour in zip(trace.structure, message.behaviours, strict=True):
                    assert codes[behaviour.status] == status.get(info.id, "I")
        assert counts["/pirate/trace"] == len(lines)
        assert counts["/pirate/joint_states"] > 10 and counts["/pirate/tree/snapshots"] > 10
