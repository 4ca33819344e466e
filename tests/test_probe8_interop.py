"""Probe 8, interop: what a hostile or careless peer of Groot2, ROS 2, MCAP and
Foxglove sends, and what pirate_bt must do with it (regressions of the bugs found)."""

from __future__ import annotations

import json
import logging
import os
import re
import socket
import struct
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError, LocatedError
from pirate_bt.interop import groot2_protocol as proto
from pirate_bt.interop import groot2_requests
from pirate_bt.interop.btcpp import tree_to_xml
from pirate_bt.interop.groot2_server import Groot2Server
from pirate_bt.interop.mcap_trace import compact_mcap, read_mcap_messages, read_mcap_records
from pirate_bt.interop.ros2_node import EStopInput, Ros2Node
from pirate_bt.interop.ros2_types import type_hash
from pirate_bt.interop.rosbag2 import read_rosbag2_records
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Mode, Supervisor
from pirate_bt.safety.testing import FakePort
from pirate_bt.trace import read_trace
from tests.trace_support import run_and_record

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


# -- MCAP -----------------------------------------------------------------------------------


def _rewrite_mcap(source: Path, target: Path, change: Any, encoding: str = "json") -> Path:
    """``source``'s messages, changed by ``change(list)``, in a new (complete) MCAP file."""
    writer_module = pytest.importorskip("mcap.writer")
    messages, _ = read_mcap_messages(source)
    messages = change(list(messages))
    with open(target, "wb") as stream:
        writer = writer_module.Writer(stream)
        writer.start()
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channels: dict[str, int] = {}
        for number, (topic, message) in enumerate(messages):
            if topic not in channels:
                channels[topic] = writer.register_channel(topic, encoding, schema)
            data = message if isinstance(message, bytes) else json.dumps(message).encode()
            writer.add_message(channels[topic], number, data, number)
        writer.finish()
    return target


@pytest.fixture(scope="module")
def run_mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    pytest.importorskip("mcap")
    path = tmp_path_factory.mktemp("mcap") / "run.mcap"
    run_and_record(path)
    return path


def test_a_damaged_message_in_a_whole_mcap_file_is_named_not_read_as_a_cut_off_run(
    run_mcap: Path, tmp_path: Path
) -> None:
    # One message that is not JSON, in a file with its footer, ended the reading there:
    # `trace summary` said "incomplete (no end record: the run was cut off)", ticks 3.
    whole = read_trace(run_mcap)
    assert whole.end is not None and len(whole.ticks) > 6
    damaged = _rewrite_mcap(
        run_mcap,
        tmp_path / "damaged.mcap",
        lambda m: [*m[:20], ("/pirate/tick", b"{oops"), *m[20:]],
    )
    with pytest.raises(
        InputError, match=r"damaged\.mcap: message 21 \(on /pirate/tick\) is not JSON"
    ):
        read_trace(damaged)
    listed = _rewrite_mcap(
        run_mcap, tmp_path / "list.mcap", lambda m: [*m[:1], ("/pirate/state", [1, 2]), *m[1:]]
    )
    # it was "cannot read this trace: AttributeError: 'list' object has no attribute 'get'"
    with pytest.raises(InputError, match=r"message 2 \(on /pirate/state\) is JSON list, not an"):
        read_mcap_records(listed)


def test_an_mcap_file_of_another_encoding_is_not_called_a_cut_off_trace(
    run_mcap: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a rosbag2 bag's MCAP (CDR) read as "the header record is cut off (the run was cut
    # off before it was written, or this is not a trace)"; every CDR message was read
    # as JSON, and the first failure ended the reading as a cut-off
    cdr = _rewrite_mcap(
        run_mcap,
        tmp_path / "bag.mcap",
        lambda m: [("/pirate/trace", b"\x00\x01\x00\x00\x03\x00\x00\x00{}\x00")] * 3,
        encoding="cdr",
    )
    assert read_mcap_messages(cdr) == ([], False)
    assert main(["trace", "summary", str(cdr)]) == 2
    err = capsys.readouterr().err
    assert "not a pirate_bt trace: no JSON /pirate/run channel" in err
    assert "/pirate/trace (cdr)" in err and "read_rosbag2_records" in err
    assert "cut off" not in err


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _zenoh_session(zenoh: Any, mode: str, **endpoints: list[str]) -> Any:
    config = zenoh.Config()
    for key, value in (
        ("mode", mode),
        *((f"{kind}/endpoints", where) for kind, where in endpoints.items()),
        ("scouting/multicast/enabled", False),
    ):
        config.insert_json5(key, json.dumps(value))
    return zenoh.open(config)


def test_an_estop_from_a_humble_node_or_another_bool_hash_is_heard() -> None:
    # rmw_zenoh on Humble puts every message under the type hash "TypeHashNotSupported";
    # the node subscribed to the exact Jazzy key, so a Humble operator station's
    # `ros2 topic pub /pirate/estop std_msgs/msg/Bool "{data: true}"` was never heard.
    zenoh = pytest.importorskip("zenoh")
    port = _free_port()
    router = _zenoh_session(zenoh, "router", listen=[f"tcp/127.0.0.1:{port}"])
    node = Ros2Node(f"tcp/127.0.0.1:{port}")
    peer = _zenoh_session(zenoh, "peer", connect=[f"tcp/127.0.0.1:{port}"])
    try:
        assert node.wait_ready() and node.estop is not None
        for hash_part in ("TypeHashNotSupported", "RIHS01_" + "0" * 64):
            key = f"0/pirate/estop/std_msgs::msg::dds_::Bool_/{hash_part}"
            before = node.estop.received
            deadline = time.monotonic() + 20  # until the router routes to the node
            while node.estop.received == before and time.monotonic() < deadline:
                peer.put(key, b"\x00\x01\x00\x00\x01")
                time.sleep(0.05)
            assert node.estop.received > before, hash_part
            assert [type(a).__name__ for a in node.estop.poll(1, 0.0)] == ["EStop"]
    finally:
        node.close()
        peer.close()
        router.close()


def test_a_client_that_never_reads_its_replies_holds_few_of_them() -> None:
    # A client asking for the tree hundreds of times without reading made ZeroMQ keep
    # up to 1,000 replies per connection in the run's process: 3,000 asks for a tree
    # of 2,000 nodes (200 kB of XML) grew the process by 190 MB, more per connection.
    zmq = pytest.importorskip("zmq")
    pytest.importorskip("msgpack")
    leaves = [py_trees.behaviours.Success(f"leaf number {i} of many") for i in range(1000)]
    root = py_trees.composites.Sequence("root", memory=True, children=leaves)
    asked = 300
    with Groot2Server(port=0) as server:
        server.serve(py_trees.trees.BehaviourTree(root))
        context = zmq.Context()
        try:
            hostile = context.socket(zmq.DEALER)
            hostile.setsockopt(zmq.RCVHWM, 1)  # reads nothing off the wire
            hostile.setsockopt(zmq.RCVBUF, 4096)
            hostile.setsockopt(zmq.LINGER, 0)
            hostile.connect(f"tcp://127.0.0.1:{server.port}")
            for _ in range(asked):
                hostile.send_multipart([b"", proto.pack_request(ord("T"))])
            deadline = time.monotonic() + 60
            while server.requests < asked and time.monotonic() < deadline:
                time.sleep(0.02)
            assert server.requests == asked
            held = 0
            while hostile.poll(500):
                hostile.recv_multipart()
                held += 1
            # what ZeroMQ held (4) and the kernel's socket buffers: nothing like all
            assert 0 < held < asked // 2, held
            # and the server answers a well-behaved client as before
            client = context.socket(zmq.REQ)
            client.setsockopt(zmq.RCVTIMEO, 20000)
            client.setsockopt(zmq.LINGER, 0)
            client.connect(f"tcp://127.0.0.1:{server.port}")
            client.send_multipart([proto.pack_request(ord("S"))])
            assert len(client.recv_multipart()) == 2
        finally:
            context.destroy(linger=0)


# -- BehaviorTree.CPP export ----------------------------------------------------------------


@pytest.mark.parametrize("param", ["ID", "name", "_while", "_autoremap", "_x"])
def test_export_refuses_a_parameter_name_bt_cpp_takes_for_no_port(
    tmp_path: Path, param: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # <SubTree ID="s" name="call" ID="y"/>: BT.CPP looked for a tree named y; `name`
    # renamed the call and its value was lost; `_x` was ignored, `_while` ran as a script
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "s.yaml").write_text(
        f"name: s\nparams:\n  {param}: {{type: string, default: a}}\n"
        f"root: {{type: log, message: ${param}}}\n"
    )
    tree = tmp_path / "main.yaml"
    tree.write_text(
        "name: m\nroot:\n  type: sequence\n  children:\n"
        f"    - {{type: subtree, name: call, ref: lib/s.yaml, params: {{{param}: x}}}}\n"
    )
    assert main(["validate", str(tree)]) == 0  # a fine pirate_bt tree
    capsys.readouterr()
    with pytest.raises(LocatedError, match=f"parameter '{param}': BehaviorTree.CPP takes no"):
        tree_to_xml(tree)
    assert main(["export", "btcpp", str(tree), "-o", str(tmp_path / "out.xml")]) == 2
    assert f"s.yaml:3:3: parameter '{param}'" in capsys.readouterr().err
    assert not (tmp_path / "out.xml").exists()


# -- Foxglove -------------------------------------------------------------------------------


def test_a_client_sending_invalid_messages_writes_few_lines_to_the_runs_terminal(
    capfd: pytest.CaptureFixture[str],
) -> None:
    # The SDK logs every invalid client message; unconfigured, the server process's
    # Python wrote each one to the run's standard error: a client in a loop filled the
    # operator's terminal (and garbled the console) as fast as it could send.
    pytest.importorskip("foxglove")
    from foxglove_ws import FoxgloveClient

    from pirate_bt.interop.foxglove_live import FoxgloveServer
    from pirate_bt.interop.foxglove_process import LOG_LINES

    err = ""
    with FoxgloveServer("127.0.0.1", 0) as server:
        client = FoxgloveClient("127.0.0.1", server.port)
        try:
            assert client.wait_for(lambda c: "/pirate/end" in c.channels, 10.0)
            for _ in range(300):
                client.send_json({"op": "no such operation"})
            deadline = time.monotonic() + 20  # until the server has said something
            while "Invalid message" not in err and time.monotonic() < deadline:
                client.pump(0.2)
                err += capfd.readouterr().err
            client.pump(0.5)
            client.subscribe("/pirate/run")  # the server still serves
        finally:
            client.close()
    err += capfd.readouterr().err
    lines = [line for line in err.splitlines() if "Invalid message" in line]
    assert 0 < len(lines) <= LOG_LINES, err[-2000:]
    assert all(line.startswith("foxglove server: ") for line in lines)


def test_an_mcap_trace_may_have_a_name_as_long_as_the_system_allows(tmp_path: Path) -> None:
    # The chunked twin beside the file was named after the whole name: with a dot
    # before and ".XXXXXXXX.part" after, a 245-byte name went over the system's 255, and
    # `--trace NAME.mcap` failed the run (SinkError: File name too long) after it had
    # moved the robot for 86 ticks; `.jsonl` took the same name.
    pytest.importorskip("mcap")
    path = tmp_path / ("a" * 245 + ".mcap")
    run_and_record(path, ticks=3)
    assert read_trace(path).end is not None
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no twin left


def test_a_bag_may_have_a_name_as_long_as_its_mcap_file_allows(tmp_path: Path) -> None:
    # the bag was made in a temporary folder named ".NAME.XXXXXXXX": a 246-byte NAME
    # was refused (File name too long) though the bag, and its NAME.mcap, fit
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import export_rosbag2

    trace = tmp_path / "run.jsonl"
    run_and_record(trace, ticks=3)
    bag = export_rosbag2(trace, tmp_path / ("c" * 242 + "_bag"))
    assert len(read_rosbag2_records(bag)) == len(read_trace(trace).ticks) + 2
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([bag.name, "run.jsonl"])


@pytest.mark.parametrize("namespace", ["bad ns", "/9x", "a//b", "/pirate/", "//pirate"])
def test_a_namespace_ros_2_refuses_is_an_input_error_for_bags(
    tmp_path: Path, namespace: str
) -> None:
    # a ValueError from rmw_zenoh.qualified_name, raised once the trace had been read
    pytest.importorskip("rosbags")
    from pirate_bt.interop.rosbag2 import export_rosbag2

    trace = tmp_path / "run.jsonl"
    run_and_record(trace, ticks=2)
    # the live node's rules and words since 2026-11-30 (ros2_option.check_names)
    said = f"namespace {re.escape(repr(namespace))}: .*(no ROS name|no repeated '/'|end with '/')"
    with pytest.raises(InputError, match=said):
        export_rosbag2(trace, tmp_path / "x_bag", namespace=namespace)
    with pytest.raises(InputError, match=said):
        read_rosbag2_records(tmp_path / "x_bag", namespace=namespace)
    assert [p.name for p in tmp_path.iterdir()] == ["run.jsonl"]


def test_short_messages_on_the_estop_topic_are_warned_of_once_a_minute(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # each message shorter than a Bool was one warning line in the run's log (stderr)
    zenoh = pytest.importorskip("zenoh")
    port = _free_port()
    router = _zenoh_session(zenoh, "router", listen=[f"tcp/127.0.0.1:{port}"])
    node = Ros2Node(f"tcp/127.0.0.1:{port}")
    peer = _zenoh_session(zenoh, "peer", connect=[f"tcp/127.0.0.1:{port}"])
    key = f"0/pirate/estop/std_msgs::msg::dds_::Bool_/{type_hash('std_msgs/msg/Bool')}"
    caplog.set_level(logging.WARNING, logger="pirate_bt.interop.ros2_node")

    def heard(payload: bytes) -> None:
        assert node.estop is not None
        before = node.estop.received
        deadline = time.monotonic() + 20  # until the router routes to the node
        while node.estop.received == before and time.monotonic() < deadline:
            peer.put(key, payload)
            time.sleep(0.05)
        assert node.estop.received > before

    try:
        assert node.wait_ready()
        heard(b"\x00\x01\x00\x00\x00")  # routed
        for _ in range(200):
            peer.put(key, b"\x00\x01\x00")
        heard(b"\x00\x01\x00\x00\x00")  # after the short ones, in order
        warnings = [r.getMessage() for r in caplog.records if "too short" in r.getMessage()]
        assert len(warnings) == 1, warnings[:3]
    finally:
        node.close()
        peer.close()
        router.close()


def test_the_twin_of_a_killed_mcap_writer_is_deleted_by_the_next_writer(tmp_path: Path) -> None:
    # a writer process killed with SIGKILL left its chunked twin (.NAME.*.part) behind
    # for good: one more hidden file for every kill, as large as the run's chunks
    pytest.importorskip("mcap")
    path = tmp_path / "run.mcap"
    killed = subprocess.run(
        [
            sys.executable,
            "-c",
            "import os, sys\n"
            "from pirate_bt.interop.mcap_writer import McapTraceWriter\n"
            "McapTraceWriter(sys.argv[1])\n"
            "os._exit(9)\n",
            str(path),
        ],
        check=False,
    )
    assert killed.returncode == 9
    left = [p.name for p in tmp_path.iterdir() if p.name.endswith(".part")]
    assert len(left) == 1 and left[0].startswith(".run.mcap.")
    running = tmp_path / f".run.mcap.{os.getpid()}.abcdefgh.part"  # a live writer's
    running.write_bytes(b"")
    run_and_record(path, ticks=2)
    assert read_trace(path).end is not None
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["run.mcap", running.name])


@pytest.mark.parametrize("name", ["a#b", "x.yaml", "y.yml"])
def test_an_exported_tree_id_is_one_import_btcpp_takes_back(tmp_path: Path, name: str) -> None:
    # BT.CPP took <BehaviorTree ID="a#b">, but pirate_bt's own import refused the file:
    # "tree ID 'a#b' would read as a file in a pirate_bt subtree reference"
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "s.yaml").write_text(f'name: "{name}"\nroot: {{type: log, message: hi}}\n')
    tree = tmp_path / "main.yaml"
    tree.write_text(
        f'name: "m{name}"\nroot:\n  type: sequence\n  children:\n'
        "    - {type: subtree, name: call, ref: lib/s.yaml}\n"
    )
    out = tmp_path / "out.xml"
    assert main(["export", "btcpp", str(tree), "-o", str(out)]) == 0
    ids = {e.get("ID") for e in ET.parse(out).getroot().iter("BehaviorTree")}
    assert all("#" not in i and not i.endswith((".yaml", ".yml")) for i in ids), ids
    back = tmp_path / "back.yaml"
    assert main(["import", "btcpp", str(out), "-o", str(back)]) == 0
    assert main(["validate", str(back)]) == 0


def test_compacting_a_file_that_is_not_mcap_or_is_damaged_keeps_it(
    run_mcap: Path, tmp_path: Path
) -> None:
    # compact_mcap(path) "recovered" a .jsonl (or any file) given by mistake as an
    # empty MCAP file written over it: the trace was gone
    jsonl = tmp_path / "run.jsonl"
    run_and_record(jsonl, ticks=2)
    before = jsonl.read_bytes()
    with pytest.raises(InputError, match=r"run\.jsonl: not a readable MCAP file .*nothing written"):
        compact_mcap(jsonl)
    assert jsonl.read_bytes() == before
    # damaged inside (not cut off): in place it would lose what follows the damage
    damaged = tmp_path / "damaged.mcap"
    data = bytearray(run_mcap.read_bytes())
    chunk = data.index(b"\x03\x00\x00\x00lz4") + 7 + 8  # the first chunk's records
    data[chunk + 40 : chunk + 56] = b"\xff" * 16
    damaged.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"damaged\.mcap: damaged after \d+ record"):
        compact_mcap(damaged)
    assert damaged.read_bytes() == bytes(data)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["damaged.mcap", "run.jsonl"]


def test_an_mcap_file_damaged_before_its_end_is_named_not_read_as_a_cut_off_run(
    tmp_path: Path,
) -> None:
    # a record's length field damaged in the middle of an unchunked file: the reading
    # stopped there and the whole run read as "incomplete", 6 ticks of 14
    pytest.importorskip("mcap")
    from pirate_bt.interop.mcap_writer import McapTraceWriter

    source = tmp_path / "run.jsonl"
    run_and_record(source)
    path = tmp_path / "run.mcap"
    writer = McapTraceWriter(path, compact=False)
    for line in source.read_text().splitlines():
        writer.write_line(line)
    writer.close()
    data = bytearray(path.read_bytes())
    position, messages = 8, 0
    while messages < 30:  # the 30th message record
        opcode, length = data[position], struct.unpack_from("<Q", data, position + 1)[0]
        messages += opcode == 5
        if messages < 30:
            position += 9 + length
    data[position + 1 : position + 9] = b"\xff" * 8
    path.write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"run\.mcap: damaged after 29 messages"):
        read_trace(path)


@pytest.mark.parametrize(
    ("record", "field", "value", "suffix"),
    [
        (0, "tick_period_s", "abc", "_bag"),
        (1, "t_s", "soon", "_bag"),
        (-1, "t_s", 1e300, "_bag"),
        (-1, "t_s", 1e300, ".mcap"),
        (1, "status", 3.5, "_bag"),
    ],
    ids=["period-text", "time-text", "time-huge-bag", "time-huge-mcap", "status-number"],
)
def test_exporting_a_trace_with_a_value_of_the_wrong_kind_names_the_record(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    record: int,
    field: str,
    value: Any,
    suffix: str,
) -> None:
    # `pirate-bt trace export` of a hand-edited trace: "internal error: ValueError:
    # could not convert string to float: 'abc' (rerun with --debug)", exit 1
    pytest.importorskip("rosbags" if suffix == "_bag" else "mcap")
    source = tmp_path / "good.jsonl"
    run_and_record(source, ticks=3)
    lines = source.read_text().splitlines()
    changed = json.loads(lines[record])
    changed[field] = value
    lines[record] = json.dumps(changed)
    trace = tmp_path / "bad.jsonl"
    trace.write_text("\n".join(lines) + "\n")
    line = record % len(lines) + 1
    assert main(["trace", "export", str(trace), "-o", str(tmp_path / f"out{suffix}")]) == 2
    err = capsys.readouterr().err
    # refused as it is read (a bad tick record, since the readers check every record),
    # or when converted; either way at its line
    assert f"bad.jsonl:{line}: cannot convert this record" in err or (
        f"bad.jsonl:{line}:1: bad tick record" in err
    ), err
    assert "internal error" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.jsonl", "good.jsonl"]


def test_a_btlog_export_of_a_status_that_is_a_list_names_the_tick(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # "internal error: TypeError: unhashable type: 'list'", exit 1
    source = tmp_path / "good.jsonl"
    run_and_record(source, ticks=3)
    lines = source.read_text().splitlines()
    tick = json.loads(lines[1])
    tick["status"] = {next(iter(tick["status"])): ["R"]}
    lines[1] = json.dumps(tick)
    trace = tmp_path / "bad.jsonl"
    trace.write_text("\n".join(lines) + "\n")
    assert main(["trace", "export", str(trace), "-o", str(tmp_path / "out.btlog")]) == 2
    err = capsys.readouterr().err
    # (the trace reader now refuses it first, at its line; export_btlog says it too)
    assert "status ['R']" in err and "bad.jsonl" in err and "internal error" not in err, err
