"""ROS 2 over Zenoh, checked against an implementation that is not ours.

The oracle is ROBOTIS's ``zenoh-ros2-sdk`` (a ROS-2-over-Zenoh client in plain
Python, written to talk to rmw_zenoh nodes): it computes type hashes from
``.msg`` text with its own code, builds its own key expressions, subscribes and
decodes what we publish with ``rosbags``, and reads the graph from our
liveliness tokens. Its message definitions are the files under
``tests/data/ros2_msgs`` (``py_trees_ros_interfaces``' fields from its
repository; the standard ones as rosbags' Jazzy store spells them), not our
:data:`pirate_bt.interop.ros2_types.DEFINITIONS`. A Zenoh router runs in-process
on a free loopback port; no ROS install is involved.

What only a ROS 2 install could confirm (``ros2 topic list``, RViz, the
py_trees_ros viewer) is in ``docs/ros2.md`` as commands to run by hand.
"""

from __future__ import annotations

import json
import math
import re
import socket
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh")
pytest.importorskip("rosbags")
sdk = pytest.importorskip("zenoh_ros2_sdk")

from zenoh_ros2_sdk import message_registry  # noqa: E402
from zenoh_ros2_sdk.attachment import Attachment  # noqa: E402
from zenoh_ros2_sdk.utils import get_type_hash, load_dependencies_recursive  # noqa: E402

import pirate_bt  # noqa: E402
from pirate_bt.errors import ConfigurationError, InputError  # noqa: E402
from pirate_bt.interop import rmw_zenoh  # noqa: E402
from pirate_bt.interop.ros2_live import Ros2Node  # noqa: E402
from pirate_bt.interop.ros2_option import parse_endpoint  # noqa: E402
from pirate_bt.interop.ros2_topics import TOPIC_TYPES  # noqa: E402
from pirate_bt.interop.ros2_types import (  # noqa: E402
    DEFINITIONS,
    TYPE_HASHES,
    dds_type_name,
    rosbags_type_hash,
    type_hash,
)

MSGS = Path(__file__).parent / "data" / "ros2_msgs"

# the real-time group (tests/conftest.py): a live Zenoh session against the wall clock
pytestmark = pytest.mark.xdist_group("real-time")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.fixture(autouse=True)
def _sdk_reads_our_test_data() -> None:
    """The SDK's message files are ours (it would otherwise try to clone them)."""
    registry = message_registry._registry
    if registry is None or Path(registry.messages_dir) != MSGS:
        message_registry._registry = message_registry.MessageRegistry(str(MSGS))


@pytest.fixture(scope="module")
def router() -> Iterator[int]:
    """A Zenoh router in this process, on a free loopback port (as rmw_zenohd would be)."""
    port = _free_port()
    config = zenoh.Config()
    for key, value in (
        ("mode", "router"),
        ("listen/endpoints", [f"tcp/127.0.0.1:{port}"]),
        ("scouting/multicast/enabled", False),
    ):
        config.insert_json5(key, json.dumps(value))
    session = zenoh.open(config)
    yield port
    from zenoh_ros2_sdk import ZenohSession

    if ZenohSession._instance is not None:
        ZenohSession._instance.close()
    session.close()


def _subscribe(port: int, topic: str, type_name: str) -> tuple[Any, list[Any]]:
    from zenoh_ros2_sdk import ROS2Subscriber

    got: list[Any] = []
    sub = ROS2Subscriber(
        topic=topic,
        msg_type=type_name,
        callback=got.append,
        router_ip="127.0.0.1",
        router_port=port,
        domain_id=0,
    )
    return sub, got


def _sdk_hash(type_name: str) -> str:
    package, _, name = type_name.split("/")
    text = (MSGS / package / "msg" / f"{name}.msg").read_text()
    deps = load_dependencies_recursive(type_name, text, message_registry.get_registry())
    return str(get_type_hash(type_name, msg_definition=text, dependencies=deps))


# --- conventions, against rmw_zenoh's design document ------------------------------------------


def test_type_hashes_agree_with_rosbags_jazzy_and_the_sdk() -> None:
    from rosbags.typesys import Stores, get_typestore

    jazzy = get_typestore(Stores.ROS2_JAZZY)
    for name in DEFINITIONS:
        if not name.startswith("py_trees_ros_interfaces/"):
            assert type_hash(name) == jazzy.hash_rihs01(name), name
    # the design document's own example, and a third party's published one
    assert type_hash("std_msgs/msg/String") == (
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    )
    for name in {*TOPIC_TYPES.values(), "std_msgs/msg/Bool"}:
        assert type_hash(name) == _sdk_hash(name), name


def test_the_hash_table_is_what_rosbags_computes_from_the_definitions() -> None:
    """Publishing reads the hashes from a table; rosbags recomputes every entry here."""
    assert set(TYPE_HASHES) == set(DEFINITIONS)
    computed = {name: rosbags_type_hash(name) for name in DEFINITIONS}
    assert computed == TYPE_HASHES, "\n".join(
        f'    "{name}": "{value}",' for name, value in computed.items()
    )


def test_keys_and_tokens_follow_the_design_document() -> None:
    # docs/design.md (rmw_zenoh 99a6a2bd), "Topic and Service name mapping" and
    # "Graph Cache" examples, rebuilt from their parts.
    string = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    dds = dds_type_name("std_msgs/msg/String")
    assert dds == "std_msgs::msg::dds_::String_"
    assert rmw_zenoh.data_key(0, "/chatter", dds, string) == f"0/chatter/{dds}/{string}"
    fq = rmw_zenoh.qualified_name("/robot1", "chatter")
    assert rmw_zenoh.data_key(0, fq, dds, string) == f"0/robot1/chatter/{dds}/{string}"
    zid = "aac3178e146ba6f1fc6e6a4085e77f21"
    assert (
        rmw_zenoh.node_token(2, zid, 0, "", "listener") == f"@ros2_lv/2/{zid}/0/0/NN/%/%/listener"
    )
    sub = rmw_zenoh.endpoint_token(
        2, zid, 0, 10, "MS", "", "listener", "/chatter", dds, string, rmw_zenoh.Qos(depth=10)
    )
    assert sub == f"@ros2_lv/2/{zid}/0/10/MS/%/%/listener/%chatter/{dds}/{string}/::,10:,:,:,,"
    pub = rmw_zenoh.endpoint_token(
        2, zid, 0, 10, "MP", "", "talker", "/chatter", dds, string, rmw_zenoh.Qos(depth=7)
    )
    assert pub.endswith("/MP/%/%/talker/%chatter/" + f"{dds}/{string}/::,7:,:,:,,")
    latched = rmw_zenoh.Qos(durability=rmw_zenoh.TRANSIENT_LOCAL, depth=1)
    assert rmw_zenoh.qos_text(latched) == ":1:,1:,:,:,,"
    assert rmw_zenoh.qos_text(rmw_zenoh.Qos(depth=42)) == "::,:,:,:,,"


def test_attachment_is_what_the_sdk_reads() -> None:
    gid = bytes(range(16))
    data = rmw_zenoh.attachment(7, 1_700_000_000_123_456_789, gid)
    assert len(data) == 8 + 8 + 1 + 16
    other = Attachment.from_bytes(data)
    assert (other.sequence_id, other.timestamp_ns, other.gid) == (7, 1_700_000_000_123_456_789, gid)
    assert rmw_zenoh.parse_attachment(Attachment(3, 4, gid).to_bytes()) == (3, 4, gid)


def test_names_and_endpoints() -> None:
    assert parse_endpoint(None) == "tcp/127.0.0.1:7447"
    assert parse_endpoint("7448") == "tcp/127.0.0.1:7448"
    assert parse_endpoint("router.lan:7447") == "tcp/router.lan:7447"
    assert parse_endpoint("tcp/10.0.0.2:7447") == "tcp/10.0.0.2:7447"
    with pytest.raises(InputError):
        parse_endpoint("foo/1")
    with pytest.raises(InputError):
        parse_endpoint("host:99999")
    with pytest.raises(InputError):
        parse_endpoint("unixsock-stream/")
    assert rmw_zenoh.qualified_name("/pirate", "tree/snapshots") == "/pirate/tree/snapshots"
    assert rmw_zenoh.qualified_name("", "/clock") == "/clock"
    with pytest.raises(ValueError):
        rmw_zenoh.qualified_name("/pi-rate", "imu")


def test_missing_extra_is_one_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "zenoh", None)
    with pytest.raises(ConfigurationError, match=r"pip install 'pirate-bt\[ros2\]'"):
        Ros2Node("tcp/127.0.0.1:1")


# --- live: a mission received by the independent client -----------------------------------------


_TOKEN = re.compile(
    r"^@ros2_lv/(?P<domain>\d+)/(?P<zid>[0-9a-f]+)/(?P<nid>\d+)/(?P<id>\d+)/(?P<kind>NN|MP|MS)/%/"
    r"(?P<ns>[^/]+)/(?P<node>[^/]+)(/(?P<topic>%[^/]+)/(?P<type>[^/]+)/(?P<hash>RIHS01_[0-9a-f]{64})"
    r"/(?P<qos>[^/]*))?$"
)


def _tokens(port: int, session_id: str, count: int) -> list[str]:
    """The liveliness tokens of one session, once ``count`` of them have reached the SDK."""
    from zenoh_ros2_sdk import ZenohSession

    session = ZenohSession.get_instance("127.0.0.1", port).session
    deadline = time.monotonic() + 10.0
    while True:
        tokens = [
            str(r.ok.key_expr)
            for r in session.liveliness().get("@ros2_lv/0/**")
            if r.ok is not None and f"/{session_id}/" in str(r.ok.key_expr)
        ]
        if len(tokens) >= count or time.monotonic() > deadline:
            return tokens
        time.sleep(0.05)


def test_a_mission_reaches_an_independent_client_with_the_trace_values(
    router: int, tmp_path: Path
) -> None:
    subs = {
        topic: _subscribe(router, rmw_zenoh.qualified_name("/pirate", topic), type_name)
        for topic, type_name in TOPIC_TYPES.items()
    }
    trace_path = tmp_path / "mission.jsonl"
    node = Ros2Node(f"tcp/127.0.0.1:{router}", rate_hz=200.0)
    try:
        assert node.wait_ready()
        # the graph, as the SDK reads it from our liveliness tokens
        from zenoh_ros2_sdk import get_topic_names_and_types

        # the tokens reach the router on their own; a loaded machine may answer the
        # first graph query before the last one arrived: ask again, up to 10 s
        wanted = {rmw_zenoh.qualified_name("/pirate", t): [n] for t, n in TOPIC_TYPES.items()}
        deadline = time.monotonic() + 10.0
        while True:
            topics = dict(get_topic_names_and_types(router_ip="127.0.0.1", router_port=router))
            if set(wanted) <= set(topics) or time.monotonic() > deadline:
                break
            time.sleep(0.05)
        assert {name: topics.get(name) for name in wanted} == wanted
        tokens = _tokens(router, node.session_id, len(TOPIC_TYPES) + 2)
        assert all(_TOKEN.match(t) for t in tokens), tokens
        kinds = sorted(_TOKEN.match(t)["kind"] for t in tokens)  # type: ignore[index]
        assert kinds == ["MP"] * len(TOPIC_TYPES) + ["MS", "NN"]
        result = pirate_bt.simulate_mission("bend-right", ros2=node, trace=trace_path)
        assert node.flush()
    finally:
        node.close()
    assert result.succeeded, result.why
    time.sleep(0.5)
    for sub, _ in subs.values():
        sub.close()
    got = {topic: received for topic, (_, received) in subs.items()}
    for topic, received in got.items():
        assert received, f"nothing received on {topic}"
    trace = pirate_bt.read_trace(trace_path)
    period = float(trace.header["tick_period_s"])

    # The run's clock: a tree snapshot names its tick, which fixes the stamps' origin.
    snapshot = got["tree/snapshots"][-1]
    n = int(snapshot.statistics.count)
    start_ns = _ns(snapshot.statistics.stamp) - round(trace.frame_at(n).t_s * 1e9)

    def tick_of(stamp: Any) -> int:
        return round((_ns(stamp) - start_ns) / 1e9 / period) + 1

    for message in got["joint_states"]:
        state = trace.frame_at(tick_of(message.header.stamp)).state
        for name, position, velocity in zip(
            message.name, message.position, message.velocity, strict=True
        ):
            if f"joint_angle_rad.{name}" in state:
                assert position == pytest.approx(state[f"joint_angle_rad.{name}"], abs=1e-9)
            elif f"{name}_rad" in state:
                assert position == pytest.approx(state[f"{name}_rad"], abs=1e-9)
            else:
                assert math.isnan(position)
                assert velocity == pytest.approx(state[f"drive_velocity_mps.{name}"], abs=1e-9)
    for message in got["clamp_forces"]:
        state = trace.frame_at(tick_of(message.header.stamp)).state
        for name, force in zip(message.name, message.effort, strict=True):
            assert force == pytest.approx(state[f"clamp_force_n.{name}"], abs=1e-9)
    for message in got["localisation"]:
        sim = trace.frame_at(tick_of(message.header.stamp)).sim
        assert message.point.x == pytest.approx(sim["task.belief_m"], abs=1e-9)
    for message in got["tree/snapshots"]:
        frame = trace.frame_at(int(message.statistics.count))
        by_name = {n.name: n for n in message.behaviours}
        assert len(message.behaviours) == len(trace.structure)
        codes = {1: "I", 2: "R", 3: "S", 4: "F"}
        for info, behaviour in zip(trace.structure, message.behaviours, strict=True):
            assert behaviour.name == info.name and behaviour.class_name == info.type
            assert codes[behaviour.status] == frame.status.get(info.id, "I")
        assert by_name  # names survive the round trip
    diagnostics = got["diagnostics"][-1]
    names = {s.name for s in diagnostics.status}
    assert {"pirate_bt: link", "pirate_bt: supervisor", "pirate_bt: simulator"} <= names
    ticks = [_ns(m.clock) for m in got["/clock"]]
    assert ticks == sorted(ticks)


def _ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


# --- e-stop from the graph ------------------------------------------------------------------------


def test_an_estop_published_on_zenoh_stops_the_drive_through_the_supervisor(router: int) -> None:
    from zenoh_ros2_sdk import ROS2Publisher

    node = Ros2Node(f"tcp/127.0.0.1:{router}")
    assert node.wait_ready()
    publisher = ROS2Publisher(
        topic="/pirate/estop",
        msg_type="std_msgs/msg/Bool",
        router_ip="127.0.0.1",
        router_port=router,
        domain_id=0,
    )
    seen: dict[str, Any] = {}

    def observe(runner: Any, connection: Any) -> None:
        sim = connection.simulator

        def at_tick(info: Any) -> None:
            if "sent" in seen or sim.truth().velocity_mps < 0.01:
                return  # until the robot drives
            seen["velocity_before"] = sim.truth().velocity_mps
            seen["front_m"] = sim.truth().front_m
            seen["sent"] = True
            deadline = time.monotonic() + 10.0
            assert node.estop is not None
            while node.estop.received == 0 and time.monotonic() < deadline:
                publisher.publish(data=True)  # until routing is up; each one is an e-stop
                time.sleep(0.05)
            seen["supervisor"] = connection.supervisor

        def finish(_result: Any) -> None:
            truth = sim.truth()
            seen["velocity_after"], seen["moved_m"] = truth.velocity_mps, truth.front_m
            seen["bridge_estopped"] = sim.bridge.estopped

        runner.add_post_tick(at_tick)
        runner.add_finish(finish)

    try:
        result = pirate_bt.simulate_tree(
            "straight", params={"distance": "2 m"}, ros2=node, observe=observe, max_time="60 s"
        )
    finally:
        publisher.close()
        node.close()
    assert seen["velocity_before"] > 0.01  # it was driving
    # and it stopped: the bridge's e-stop latched (every motor off from its next
    # physics step). The run ends at the tick the supervisor takes the e-stop, before
    # the simulator has stepped again; it waited for the drive's failure, the robot
    # at rest, while the e-stop topic counted as an operator who could reset it.
    assert seen["bridge_estopped"] is True
    assert seen["moved_m"] - seen["front_m"] < 0.05  # well short of the 2 m asked for
    assert not result.succeeded
    assert node.estop is not None and node.estop.estops >= 1
    supervisor = seen["supervisor"]
    assert supervisor.mode.value == "estop"  # latched: only an operator releases it
    estops = [v for v in supervisor.verdicts.since(seq=0) if v.reason == "estop_latched"]
    assert estops and "ROS 2 e-stop on /pirate/estop" in str(estops[0].detail)
    assert result.safe_state


def test_a_false_estop_changes_nothing_and_nothing_else_is_subscribed(router: int) -> None:
    node = Ros2Node(f"tcp/127.0.0.1:{router}")
    try:
        assert node.wait_ready()
        assert node.estop is not None
        node.estop.push(False)
        assert node.estop.poll(1, 0.0) == []
        tokens = _tokens(router, node.session_id, len(TOPIC_TYPES) + 2)
        subscriptions = [t for t in tokens if "/MS/" in t]
        assert (
            len(subscriptions) == 1
            and "%pirate%estop/std_msgs::msg::dds_::Bool_/" in (subscriptions[0])
        )
    finally:
        node.close()


def test_a_failing_publisher_never_reaches_the_tick(
    router: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Publishing raises in the node's process: the output switches off, the run succeeds,
    and the e-stop subscription stays."""
    from zenoh_ros2_sdk import ROS2Publisher

    monkeypatch.setattr(Ros2Node, "_PROCESS_OPTIONS", {"fail_publishing": True})
    node = Ros2Node(f"tcp/127.0.0.1:{router}", rate_hz=1000.0)
    publisher = None
    try:
        assert node.wait_ready()
        result = pirate_bt.simulate_tree("straight", params={"distance": "0.3 m"}, ros2=node)
        deadline = time.monotonic() + 10.0
        while node.enabled and time.monotonic() < deadline:
            time.sleep(0.02)  # the process says so over the pipe
        assert not node.enabled and node.published == 0
        publisher = ROS2Publisher(
            topic="/pirate/estop",
            msg_type="std_msgs/msg/Bool",
            router_ip="127.0.0.1",
            router_port=router,
            domain_id=0,
        )
        assert node.estop is not None
        while node.estop.received == 0 and time.monotonic() < deadline + 10.0:
            publisher.publish(data=True)  # until routing is up
            time.sleep(0.05)
        assert node.estop.received > 0  # the e-stop still comes through
    finally:
        if publisher is not None:
            publisher.close()
        node.close()
    assert result.succeeded


def test_a_failing_hand_over_never_reaches_the_tick(router: int) -> None:
    node = Ros2Node(f"tcp/127.0.0.1:{router}", rate_hz=1000.0)
    calls = threading.Event()

    def broken(*args: Any, **kwargs: Any) -> None:
        calls.set()
        raise RuntimeError("the pipe is on fire")

    try:
        assert node.wait_ready()
        node.offer = broken  # type: ignore[method-assign]
        result = pirate_bt.simulate_tree("straight", params={"distance": "0.3 m"}, ros2=node)
    finally:
        node.close()
    assert result.succeeded
    assert calls.is_set() and not node.enabled


def test_a_session_that_cannot_open_is_an_input_error(monkeypatch: pytest.MonkeyPatch) -> None:
    """Zenoh refuses the endpoint in the node's process: the run's side hears it and says so."""
    monkeypatch.setattr(Ros2Node, "_PROCESS_OPTIONS", {"endpoint": "unixsock-stream/"})
    node = Ros2Node("tcp/127.0.0.1:7447")
    try:
        with pytest.raises(InputError, match="cannot open a Zenoh session"):
            node.check_opened()
        assert not node.enabled and not node.wait_ready()
    finally:
        node.close()


def test_frames_are_dropped_and_counted_when_the_process_lags() -> None:
    """A stopped publishing process never holds up the run: the pipe fills, frames are
    dropped and counted, and once the process goes on, so does the output."""
    import os
    import signal

    from pirate_bt.interop.ros2_topics import TreeShape

    node = Ros2Node(f"tcp/127.0.0.1:{_free_port()}")  # nothing listens there; no matter
    try:
        assert node.wait_ready()
        run = node.begin(TreeShape("t", ()), 0, "pirate", 0.05)
        big = {f"joint_angle_rad.j{i}": float(i) for i in range(2000)}
        os.kill(node.pid, signal.SIGSTOP)
        try:
            for n in range(2000):  # 2000 frames of ~40 kB: far more than the pipe holds
                node.offer(run, (n, n * 0.05, big, None, None, None, None, None, None, None))
                if node.dropped:
                    break
        finally:
            os.kill(node.pid, signal.SIGCONT)
        assert node.dropped > 0 and node.enabled
        assert node.flush()
    finally:
        node.close()
