"""Probe 17: live peers speaking our protocols, written from their specs.

Other implementations of what pirate_bt speaks (a ROS 2 node over Zenoh publishing on
the e-stop topic, a Groot2 client, a Foxglove client, a strict MCAP reader) doing what
such peers do, the odd things included; the run must not notice them.
"""

from __future__ import annotations

import json
import socket
import threading
import time
from typing import Any

import pytest

from pirate_bt.interop import ros2_process
from pirate_bt.interop.ros2_node import EStopInput

pytestmark = pytest.mark.xdist_group("real-time")


# --- ROS 2: a flood on the e-stop topic ------------------------------------------------------


class _Out:
    """What the node's process sends to the run's process, kept."""

    def __init__(self) -> None:
        self.sent: list[tuple[Any, ...]] = []
        self.lock = threading.Lock()

    def send(self, message: tuple[Any, ...]) -> None:
        with self.lock:
            self.sent.append(message)

    def counted(self) -> int:
        with self.lock:
            return sum(_count(m) for m in self.sent if m[0] == ros2_process.BOOL)


def _count(message: tuple[Any, ...]) -> int:
    """How many e-stop messages one sent to the run's process stands for."""
    return int(message[3]) if len(message) > 3 else 1


class _Sample:
    def __init__(self, payload: bytes) -> None:
        self.payload = self

        self._bytes = payload

    def to_bytes(self) -> bytes:
        return self._bytes


class _Session:
    def zid(self) -> str:
        return "0123456789abcdef"


def _node(out: _Out) -> Any:
    config = {
        "domain_id": 0,
        "namespace": "/pirate",
        "name": "pirate_bt",
        "fq_estop": "/pirate/estop",
        "estop": True,
    }
    return ros2_process.Node(None, _Session(), config, out)  # type: ignore[arg-type]


FALSE = _Sample(b"\x00\x01\x00\x00\x00")
TRUE = _Sample(b"\x00\x01\x00\x00\x01")


def test_a_flood_on_the_estop_topic_reaches_the_run_as_a_few_messages_and_loses_no_true() -> None:
    # A ROS 2 peer publishing `false` on /pirate/estop as fast as Zenoh delivers (about
    # 140,000 a second): the node's process sent each over the pipe, and the run's
    # process read and counted each one in the interpreter its tick runs in (its CPU
    # over a 10 s paced run went from 0.5 s to 2.9 s). Now they go as a few messages,
    # with their count, and the one `true` among them is not lost.
    out = _Out()
    node = _node(out)
    for _ in range(10_000):
        node._on_estop(FALSE)
    node._on_estop(TRUE)
    for _ in range(10_000):
        node._on_estop(FALSE)
    deadline = time.monotonic() + 3.0
    while out.counted() < 20_001 and time.monotonic() < deadline:
        time.sleep(0.005)
    assert out.counted() == 20_001  # every message counted, none twice
    assert len(out.sent) < 500, f"{len(out.sent)} messages over the pipe for 20,001"
    assert [m[1] for m in out.sent].count(True) >= 1
    # the run's side reads them as what they were
    topic = EStopInput("/pirate/estop")
    for message in out.sent:
        topic.push(bool(message[1]), int(message[2]), _count(message))
    assert topic.received == 20_001 and len(topic.poll(1, 0.0)) == 1


def test_a_lone_true_after_a_quiet_spell_goes_at_once_and_one_held_back_goes_soon() -> None:
    out = _Out()
    node = _node(out)
    node._on_estop(TRUE)
    assert len(out.sent) == 1 and out.sent[0][1] is True and _count(out.sent[0]) == 1  # at once
    node._on_estop(TRUE)  # within the gap: held back, then sent by the forwarder's thread
    deadline = time.monotonic() + 2.0
    while len(out.sent) < 2 and time.monotonic() < deadline:
        time.sleep(0.001)
    assert [m[1] for m in out.sent] == [True, True] and out.counted() == 2


zenoh = pytest.importorskip("zenoh", reason="the ros2 extra (eclipse-zenoh) is not installed")


def _config(**settings: Any) -> Any:
    config = zenoh.Config()
    for key, value in {"scouting/multicast/enabled": False, **settings}.items():
        config.insert_json5(key, json.dumps(value))
    return config


def test_a_live_flood_of_false_on_the_estop_topic_is_read_as_few_messages_then_true_stops(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from pirate_bt.interop import rmw_zenoh
    from pirate_bt.interop.ros2_live import Ros2Node
    from pirate_bt.interop.ros2_types import dds_type_name, type_hash

    read: list[int] = []
    heard = Ros2Node._heard

    def counting(self: Ros2Node, message: tuple[Any, ...]) -> None:
        if message[0] == ros2_process.BOOL:
            read.append(1)
        heard(self, message)

    monkeypatch.setattr(Ros2Node, "_heard", counting)
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    router = zenoh.open(_config(mode="router", **{"listen/endpoints": [f"tcp/127.0.0.1:{port}"]}))
    node: Ros2Node | None = None
    try:
        node = Ros2Node(f"tcp/127.0.0.1:{port}")
        assert node.wait_ready() and node.estop is not None
        bool_type = "std_msgs/msg/Bool"
        key = rmw_zenoh.data_key(0, "/pirate/estop", dds_type_name(bool_type), type_hash(bool_type))
        publisher = router.declare_publisher(key)
        deadline = time.monotonic() + 3.0
        while node.estop.received == 0 and time.monotonic() < deadline:
            publisher.put(FALSE.to_bytes())  # until routing is up
            time.sleep(0.01)
        started = time.monotonic()
        while time.monotonic() - started < 0.5:
            for _ in range(1000):
                publisher.put(FALSE.to_bytes())
        # a dropped sample is Zenoh's (a put under congestion): this one waits for room
        router.put(key, TRUE.to_bytes(), congestion_control=zenoh.CongestionControl.BLOCK)
        elapsed = time.monotonic() - started
        deadline = time.monotonic() + 3.0
        while node.estop.estops + len(node.estop.poll(0, 0.0)) == 0:
            assert time.monotonic() < deadline, (
                f"the true after the flood was lost ({node.estop.received} heard, {len(read)} read)"
            )
            time.sleep(0.005)
        assert node.estop.received > 5_000, "no flood arrived"
        allowed = (elapsed + 0.5) / 0.002 + 50  # one message every 2 ms at most
        assert len(read) < allowed, f"{len(read)} messages read for {node.estop.received}"
    finally:
        if node is not None:
            node.close()
        router.close()


# --- MCAP: another writer's file, compacted -------------------------------------------------


def test_compacting_another_writers_mcap_file_keeps_its_profile_metadata_and_attachments(
    tmp_path: Any,
) -> None:
    # compact_mcap copied schemas, channels and messages only: a rosbag2 bag's MCAP
    # file lost its 'ros2' profile and its 'rosbag2' metadata record, and a recording's
    # attachments were dropped, all without a word.
    writer_module = pytest.importorskip("mcap.writer")
    from mcap.reader import make_reader

    from pirate_bt.interop.mcap_writer import compact_mcap

    source = tmp_path / "recorded.mcap"
    with open(source, "wb") as stream:
        writer = writer_module.Writer(stream)
        writer.start(profile="ros2", library="another recorder")
        schema = writer.register_schema("std_msgs/msg/Bool", "ros2msg", b"bool data")
        channel = writer.register_channel("/pirate/estop", "cdr", schema)
        writer.add_message(channel, 5, b"\x00\x01\x00\x00\x01", 5)
        writer.add_metadata("rosbag2", {"serialized_metadata": "version: 9"})
        writer.add_attachment(1, 2, "calibration.yaml", "text/yaml", b"a: 1\n")
        writer.finish()
    out = compact_mcap(source, tmp_path / "compacted.mcap")
    with open(out, "rb") as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == "ros2"
        assert [(m.name, m.metadata) for m in reader.iter_metadata()] == [
            ("rosbag2", {"serialized_metadata": "version: 9"})
        ]
        attachments = list(reader.iter_attachments())
        assert [(a.name, a.media_type, a.data, a.log_time) for a in attachments] == [
            ("calibration.yaml", "text/yaml", b"a: 1\n", 2)
        ]
        assert [m.data for _, _, m in reader.iter_messages()] == [b"\x00\x01\x00\x00\x01"]
