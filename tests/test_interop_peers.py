"""What an independent peer of each protocol does that the other interop tests do not.

Each test here is a defect a peer found: a client or reader written by someone
else (expat for the XML Groot2 and BT.CPP read, a Foxglove client of our own
test helper that connects after the run, ROS 2's naming rules as rmw applies
them) that got something our own round trips accepted.
"""

from __future__ import annotations

import struct
import xml.etree.ElementTree as ET
from pathlib import Path

import py_trees
import pytest

from pirate_bt.interop import rmw_zenoh
from pirate_bt.interop.btlog import btlog_bytes, read_btlog, structure_xml
from pirate_bt.trace.structure import TreeStructure, tree_structure

ROOT = Path(__file__).resolve().parent.parent

# Names a tree built in Python may have: XML's specials, text beyond ASCII, a long
# name, and what XML 1.0 cannot hold at all (control characters, a lone surrogate).
ODD = {
    "specials": "<&>\"' ]]>",
    "unicode": "ünï 🙂 名前",
    "long": "x" * 5000,
    "control": "a\x01b\x0bc",
    "surrogate": "half \ud800 a pair",
}
SHOWN = dict(ODD)
SHOWN["control"] = "a\ufffdb\ufffdc"
SHOWN["surrogate"] = "half \ufffd a pair"


def _odd_tree() -> py_trees.trees.BehaviourTree:
    leaves = [py_trees.behaviours.Success(name) for name in ODD.values()]
    many = [py_trees.behaviours.Success(f"n{i}") for i in range(1000)]
    root = py_trees.composites.Sequence(
        "root\x1f",
        memory=True,
        children=[*leaves, py_trees.composites.Sequence("many", True, many)],
    )
    return py_trees.trees.BehaviourTree(root)


def _names(xml: bytes | str) -> list[str]:
    """Node names in UID order, read by expat (as a strict peer reads the XML)."""
    tree = ET.fromstring(xml)
    nodes = [e for e in tree.iter() if e.get("_uid")]
    assert [int(e.get("_uid", "0")) for e in nodes] == list(range(1, len(nodes) + 1))
    return [e.get("name", "") for e in nodes]


# -- Groot2 and .btlog: the tree's XML -------------------------------------------------------


def test_groot2_serves_well_formed_xml_for_any_node_name() -> None:
    """Before: a control character went into the full-tree reply as it was (expat:
    "not well-formed"), and a lone surrogate made the request an error reply."""
    pytest.importorskip("zmq")
    pytest.importorskip("msgpack")
    from test_groot2 import Client

    from pirate_bt.interop.groot2_server import Groot2Server

    tree = _odd_tree()
    with Groot2Server(port=0) as server:
        server.serve(tree, name="odd <tree>")
        client = Client(server.port)
        try:
            reply = client.ask("T")
            assert len(reply) == 2 and reply[0] != b"error", reply[:2]
            names = _names(reply[1])
            assert names[0] == "root\ufffd"
            assert names[1 : 1 + len(ODD)] == list(SHOWN.values())
            assert len(names) == 1 + len(ODD) + 1 + 1000
            body = client.ask("S")[1]
            assert len(body) == 3 * len(names)
            assert struct.unpack_from("<H", body, 3 * (len(names) - 1))[0] == len(names)
        finally:
            client.close()


def test_btlog_of_any_node_name_is_well_formed_xml(tmp_path: Path) -> None:
    """Before: the same characters went into the .btlog's XML as they were; a node type
    that is no XML name (a trace is input) became a tag no parser reads."""
    structure = tree_structure(_odd_tree(), name="odd\x02tree")
    data = structure.to_json()
    data["nodes"][1]["type"] = "Not a name"
    xml = structure_xml(TreeStructure.from_json(data))
    path = tmp_path / "odd.btlog"
    path.write_bytes(btlog_bytes(xml, 0, ()))
    log = read_btlog(path)
    assert _names(log.xml)[1 : 1 + len(ODD)] == list(SHOWN.values())
    tree = ET.fromstring(log.xml).find("BehaviorTree")
    assert tree is not None and tree.get("ID") == "odd\ufffdtree"


# -- ROS 2 names -------------------------------------------------------------------------------


@pytest.mark.parametrize("namespace", ["/pirate\n", "/pirate/\n", "/pi rate", "/1pirate", "/p~"])
def test_a_namespace_ros_2_refuses_is_refused(namespace: str) -> None:
    """Before: a trailing newline passed (``$`` matches before it), and went into every
    key expression and liveliness token."""
    with pytest.raises(ValueError):
        rmw_zenoh.qualified_name(namespace, "joint_states")


def test_a_node_name_is_one_part() -> None:
    """Before: ``Ros2Node(name="a/b")`` was accepted, a node rmw_zenoh's graph shows as
    ``/pirate/a/b``: a namespace and a name that are not the ones declared."""
    pytest.importorskip("zenoh")
    from pirate_bt.errors import InputError
    from pirate_bt.interop.ros2_node import Ros2Node

    for name in ("a/b", "a\n", "1node"):
        with pytest.raises(InputError):
            Ros2Node(name=name).close()


# -- Foxglove: a client that connects after the run ----------------------------------------------


def test_a_foxglove_client_that_subscribes_after_the_run_gets_its_snapshot() -> None:
    """Before: the snapshots for late subscribers went out with the next record only, so
    a client of a server that outlives its run (or of a tree held at a breakpoint) got
    nothing at all."""
    pytest.importorskip("foxglove")
    from foxglove_ws import FoxgloveClient

    import pirate_bt
    from pirate_bt.interop.foxglove_live import FoxgloveServer

    with FoxgloveServer("127.0.0.1", 0) as server:
        result = pirate_bt.simulate_tree(ROOT / "trees/examples/patrol.yaml", foxglove=server)
        assert result.status == "success"
        client = FoxgloveClient("127.0.0.1", server.port)
        try:
            assert client.wait_for(lambda c: "/pirate/end" in c.channels, 10.0)
            client.subscribe("/pirate/run", "/pirate/tree", "/pirate/end")
            assert client.wait_for(lambda c: len(c.messages) >= 3, 5.0), client.messages
            assert client.of("/pirate/run")[0]["tree"]["name"] == "patrol"
            assert client.of("/pirate/end")[0]["outcome"] == "success"
            snapshot = client.of("/pirate/tree")[0]
            assert snapshot["snapshot"] is True
            assert snapshot["status"] and snapshot["active"] == ""
        finally:
            client.close()


# -- rosbag2: what ros2 bag play offers ---------------------------------------------------------


def test_a_bag_offers_the_qos_the_live_node_offers(tmp_path: Path) -> None:
    """Before: every topic's ``offered_qos_profiles`` was empty, so ``ros2 bag play``
    offered the default (volatile) QoS, and a subscriber asking for the latched tree as
    py_trees_ros's tree watcher does (transient local) was incompatible: no tree."""
    pytest.importorskip("rosbags")
    from rosbags.interfaces import QosDurability, QosReliability
    from rosbags.rosbag2 import Reader

    from pirate_bt.cli import main

    trace, bag = tmp_path / "run.jsonl", tmp_path / "run_bag"
    assert (
        main(["run", str(ROOT / "trees/examples/patrol.yaml"), "--trace", str(trace), "--quiet"])
        == 0
    )
    assert main(["trace", "export", str(trace), "-o", f"{bag}/"]) == 0
    with Reader(bag) as reader:  # reads metadata.yaml
        offered = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
    assert "/pirate/tree/snapshots" in offered and "/pirate/trace" in offered
    for topic, profiles in offered.items():
        assert len(profiles) == 1, topic
        latched = topic == "/pirate/tree/snapshots"
        (qos,) = profiles
        assert qos.reliability == QosReliability.RELIABLE
        assert qos.durability == (
            QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE
        )
        assert qos.depth == (1 if latched else 10)
    # rosbag2's MCAP storage reads the QoS from the channel's metadata, not the YAML
    from mcap.reader import make_reader

    with open(bag / "run_bag.mcap", "rb") as stream:
        summary = make_reader(stream, validate_crcs=True).get_summary()
    assert summary is not None
    channels = {c.topic: c.metadata for c in summary.channels.values()}
    assert (
        "durability: transient_local" in channels["/pirate/tree/snapshots"]["offered_qos_profiles"]
    )


# -- Groot2 over IPv6 ------------------------------------------------------------------------------


def _ipv6_loopback() -> bool:
    import socket

    try:
        with socket.socket(socket.AF_INET6) as probe:
            probe.bind(("::1", 0))
    except OSError:
        return False
    return True


def test_groot2_serves_an_ipv6_address() -> None:
    """Before: ``--groot2 [::1]:PORT`` was parsed, and then the server could not listen
    ("No such device"): ZeroMQ binds IPv6 addresses only on sockets with ``IPV6`` set."""
    zmq = pytest.importorskip("zmq")
    pytest.importorskip("msgpack")
    if not _ipv6_loopback():
        pytest.skip("no IPv6 loopback here")
    from pirate_bt.interop import groot2_protocol as proto
    from pirate_bt.interop.groot2_option import parse_groot2_address
    from pirate_bt.interop.groot2_server import Groot2Server

    host, _ = parse_groot2_address("[::1]:1667")
    with Groot2Server(host, 0) as server:
        server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
        assert server.address == f"[::1]:{server.port}"
        context = zmq.Context()
        try:
            req = context.socket(zmq.REQ)
            req.setsockopt(zmq.IPV6, 1)
            req.setsockopt(zmq.RCVTIMEO, 5000)
            req.setsockopt(zmq.LINGER, 0)
            req.connect(f"tcp://[::1]:{server.port}")
            req.send(proto.pack_request(ord("S"), 5))
            reply = req.recv_multipart()
            assert proto.unpack_reply_header(reply[0])[0].unique_id == 5
            assert reply[1] == b"\x01\x00\x00"
        finally:
            context.destroy(linger=0)


@pytest.mark.parametrize("text", ["h:²", "[::1]:٣", "h:１６６７"])
def test_a_port_in_other_digits_is_refused_in_one_line(text: str) -> None:
    # str.isdigit() takes '²' (int() then raised a bare ValueError) and '٣' (a port
    # ROS and ZeroMQ would not read); ports and domain ids are ASCII digits only
    from pirate_bt.errors import InputError
    from pirate_bt.interop import foxglove_option, groot2_option, ros2_option

    for parse in (groot2_option.parse_groot2_address, foxglove_option.parse_address):
        with pytest.raises(InputError, match="the port must be a number"):
            parse(text)
    with pytest.raises(InputError, match="the port must be a number"):
        ros2_option.parse_endpoint(f"tcp/{text}")


def test_a_ros_domain_id_in_other_digits_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    from pirate_bt.errors import InputError
    from pirate_bt.interop.ros2_option import domain_from_env

    monkeypatch.setenv("ROS_DOMAIN_ID", "٣")
    with pytest.raises(InputError, match="is not a number"):
        domain_from_env()
    monkeypatch.setenv("ROS_DOMAIN_ID", "3")
    assert domain_from_env() == 3


def test_an_export_through_a_symlink_replaces_its_target_and_keeps_the_link(
    tmp_path: Path,
) -> None:
    # the atomic rename replaced the link itself with a regular file
    from pirate_bt.atomic import write_atomically

    target = tmp_path / "store" / "run.mcap"
    target.parent.mkdir()
    target.write_bytes(b"old")
    link = tmp_path / "run.mcap"
    link.symlink_to(target)
    written = write_atomically(link, lambda stream: stream.write(b"new"))
    assert link.is_symlink() and target.read_bytes() == b"new"
    assert written == target
