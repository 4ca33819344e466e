"""Probe 8, interop: what a hostile or careless peer of Groot2, ROS 2, MCAP and
Foxglove sends, and what pirate_bt must do with it (regressions of the bugs found)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import py_trees
import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError
from pirate_bt.interop import groot2_protocol as proto
from pirate_bt.interop import groot2_requests
from pirate_bt.interop.groot2_server import Groot2Server
from pirate_bt.interop.ros2_node import EStopInput
from pirate_bt.interop.rosbag2 import read_rosbag2_records
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Mode, Supervisor
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


# -- ROS 2 ----------------------------------------------------------------------------------


def test_a_flood_on_the_estop_topic_is_one_estop_per_tick() -> None:
    # A peer publishing `true` on /pirate/estop as fast as Zenoh goes queued one
    # EStop per message: the supervisor's next tick then sent thousands of e-stop
    # frames to the bridge and logged thousands of lines, holding up the tick.
    clock = SimClock(10.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    supervisor = Supervisor(port, clock)
    topic = EStopInput("/pirate/estop")
    supervisor.add_input(topic)
    for _ in range(5000):
        topic.push(True, 1)
    supervisor.tick()
    assert supervisor.mode is Mode.ESTOP
    assert port.estops == 1 and topic.received == 5000 and topic.estops == 1
    # later ones are not lost: the next message e-stops again at the next tick
    topic.push(False)
    supervisor.tick()
    assert port.estops == 1
    for _ in range(3):
        topic.push(True, 2)
    supervisor.tick()
    assert port.estops == 2 and topic.estops == 2 and topic.heard_ns == 2


# -- Groot2 ---------------------------------------------------------------------------------


def test_a_blackboard_request_naming_one_board_many_times_reads_it_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # B with a second part of a million ';' (a million empty names, each the main
    # tree's) copied the live blackboard a million times: 6 s of the server's thread,
    # holding the interpreter the tick runs in, for one request under 1 MiB.
    zmq = pytest.importorskip("zmq")
    msgpack = pytest.importorskip("msgpack")
    reads = []
    live = groot2_requests._live_blackboard

    def counted() -> dict[str, Any]:
        reads.append(1)
        return live()

    monkeypatch.setattr(groot2_requests, "_live_blackboard", counted)
    with Groot2Server(port=0) as server:
        server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
        context = zmq.Context()
        req = context.socket(zmq.REQ)
        req.setsockopt(zmq.RCVTIMEO, 20000)
        req.setsockopt(zmq.LINGER, 0)
        try:
            req.connect(f"tcp://127.0.0.1:{server.port}")
            req.send_multipart([proto.pack_request(ord("B")), b";" * 100_000 + b"ok;ok;nope"])
            reply = req.recv_multipart()
        finally:
            context.destroy(linger=0)
    assert len(reply) == 2 and reply[0][1:2] == b"B"
    assert set(msgpack.unpackb(reply[1])) == {"", "ok"}
    assert len(reads) == 1


@pytest.mark.parametrize(
    ("msgtype", "payload", "said"),
    [
        ("std_msgs/msg/String", b"\x00\x01\x00\x00\xff\xff\xff\x7f", "message 1 on /pirate/trace"),
        ("std_msgs/msg/String", b"\x00", "message 1 on /pirate/trace"),
        ("std_msgs/msg/String", b"\x00\x01\x00\x00\x05\x00\x00\x00nope\x00", "message 1"),
        ("std_msgs/msg/String", b"\x00\x01\x00\x00\x06\x00\x00\x00[1,2]\x00", "JSON list"),
        ("std_msgs/msg/Bool", b"\x00\x01\x00\x00\x01", "holds std_msgs/msg/Bool"),
    ],
    ids=["string-length", "no-encapsulation", "not-json", "json-list", "other-type"],
)
def test_a_bag_whose_trace_topic_holds_no_records_is_an_input_error(
    tmp_path: Path, msgtype: str, payload: bytes, said: str
) -> None:
    # rosbags' SerdeError, JSON's error and a TypeError escaped read_rosbag2_records,
    # and a JSON list came back as a "record"
    rosbag2 = pytest.importorskip("rosbags.rosbag2")
    from pirate_bt.interop.ros2_types import typestore

    bag = tmp_path / "run_bag"
    with rosbag2.Writer(bag, version=9, storage_plugin=rosbag2.StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/pirate/trace", msgtype, typestore=typestore())
        writer.write(connection, 1, payload)
    with pytest.raises(InputError, match=re.escape(said)) as caught:
        read_rosbag2_records(bag)
    assert str(caught.value).startswith(f"{bag}: ")
    with pytest.raises(InputError, match="not a readable rosbag2 bag"):
        read_rosbag2_records(tmp_path / "no_bag")
