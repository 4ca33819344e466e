"""Probe 13: pirate_bt's ROS 2 node held against rmw_zenoh's own rules, field by field.

What rmw_zenoh's sources (``liveliness_utils.cpp``, ``rmw_publisher_data.cpp``,
``rmw_subscription_data.cpp``) and rcl (``rcl_get_default_domain_id``,
``rmw_validate_namespace``) do, where ``tests/test_ros2.py`` does not look: the
environment's domain id as ``strtoul(text, &end, 0)`` reads it, names rmw refuses,
the latched publisher's options, and a live node's every token, attachment,
late joiner, many and vanishing subscribers and its withdrawal from the graph.
"""

from __future__ import annotations

import itertools
import json
import socket
import time
from typing import Any

import pytest

zenoh = pytest.importorskip("zenoh", reason="the ros2 extra (eclipse-zenoh) is not installed")

import pirate_bt  # noqa: E402
from pirate_bt.errors import InputError  # noqa: E402
from pirate_bt.interop import rmw_zenoh, ros2_process  # noqa: E402
from pirate_bt.interop.ros2_live import Ros2Node  # noqa: E402
from pirate_bt.interop.ros2_option import domain_from_env  # noqa: E402
from pirate_bt.interop.ros2_topics import TOPIC_TYPES, TREE  # noqa: E402

pytestmark = pytest.mark.xdist_group("real-time")


@pytest.mark.parametrize(
    ("text", "domain"),
    [("", 0), (" 7 ", 7), ("010", 8), ("0x1f", 31), ("+3", 3), ("0", 0), ("232", 232)],
)
def test_ros_domain_id_is_read_as_rcl_reads_it(
    monkeypatch: pytest.MonkeyPatch, text: str, domain: int
) -> None:
    # rcl: strtoul(text, &end, 0): "010" is octal, as every ROS node of that shell reads it
    monkeypatch.setenv("ROS_DOMAIN_ID", text)
    assert domain_from_env() == domain


@pytest.mark.parametrize("text", ["08", "3abc", "-1", "0x", "233", "٣", "1_0"])
def test_a_ros_domain_id_rcl_would_not_read_whole_is_refused(
    monkeypatch: pytest.MonkeyPatch, text: str
) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", text)
    with pytest.raises(InputError, match=r"^ROS_DOMAIN_ID=") as caught:
        domain_from_env()
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("namespace", "name", "why"),
    [
        ("/pirate/", "pirate_bt", "does not end with '/'"),
        ("//pirate", "pirate_bt", "no repeated '/'"),
        ("/a//b", "pirate_bt", "no repeated '/'"),
        ("/pi-rate", "pirate_bt", "'pi-rate' is no ROS name"),
        ("/größe", "pirate_bt", "'größe' is no ROS name"),
        ("/" + "a" * 246, "pirate_bt", "longer than ROS's 245"),
        ("/" + "a" * 230, "pirate_bt", "too long for the topic 'localisation/truth'"),
        ("/pirate", "", "node name ''"),
        ("/pirate", "9lives", "node name '9lives'"),
        ("/pirate", "x" * 256, "at most 255"),
    ],
)
def test_names_rmw_refuses_are_refused_in_one_line(namespace: str, name: str, why: str) -> None:
    # until 2026-11-30 the first two were quietly made "/pirate", an empty node name made
    # a token rmw_zenoh's graph cache drops, and over-long names made topics ROS refuses
    with pytest.raises(InputError, match=why) as caught:
        Ros2Node("tcp/127.0.0.1:1", namespace=namespace, name=name)
    assert "\n" not in str(caught.value)


def test_the_latched_tree_publisher_is_declared_as_rmw_zenoh_declares_one(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # rmw_zenoh's RELIABLE + TRANSIENT_LOCAL publisher: a cache of `depth`, publisher
    # detection and sample miss detection with a 500 ms sporadic heartbeat, which its
    # subscriptions' recovery (last_sample_miss_detection = Heartbeat) relies on
    import zenoh.ext

    calls: list[dict[str, Any]] = []

    class Fake:
        def __getattr__(self, name: str) -> Any:
            return lambda *args, **kwargs: Fake()

        def zid(self) -> str:
            return "0123456789abcdef"

    def advanced(session: Any, key: str, **options: Any) -> Fake:
        calls.append({"key": key, **options})
        return Fake()

    monkeypatch.setattr(zenoh.ext, "declare_advanced_publisher", advanced)
    config = {"domain_id": 0, "namespace": "/pirate", "name": "pirate_bt"}
    node = ros2_process.Node(
        zenoh, Fake(), {**config, "fq_estop": "/pirate/estop", "estop": False}, Fake()
    )
    node.declare()
    assert [c["key"].split("/")[1:3] for c in calls] == [["pirate", "tree"]]
    (call,) = calls
    assert call["cache"] is not None and call["publisher_detection"] is True
    miss = call.get("sample_miss_detection")
    assert miss is not None, "no sample miss detection: rmw_zenoh's recovery has nothing to use"
    assert ros2_process.MISS_HEARTBEAT_S == 0.5


# --- live, against a router -------------------------------------------------------------------


def _config(**settings: Any) -> Any:
    config = zenoh.Config()
    for key, value in {"scouting/multicast/enabled": False, **settings}.items():
        config.insert_json5(key, json.dumps(value))
    return config


def _parse(token: str) -> dict[str, str]:
    """A token as rmw_zenoh's ``Entity::make(keyexpr)`` reads it (None-free, demangled)."""
    parts = token.split("/")
    assert all(parts), f"an empty part: rmw_zenoh drops {token}"
    names = ["admin", "domain", "zid", "nid", "id", "kind", "enclave", "ns", "node"]
    names += ["topic", "type", "hash", "qos"]
    assert len(parts) == (9 if parts[5] == "NN" else 13), token
    fields = dict(zip(names, parts, strict=False))
    for name in ("enclave", "ns", "node", "topic"):
        if name in fields:
            fields[name] = fields[name].replace("%", "/")
    return fields


def test_a_live_node_as_an_rmw_zenoh_graph_cache_and_subscribers_see_it() -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    router = zenoh.open(_config(mode="router", **{"listen/endpoints": [f"tcp/127.0.0.1:{port}"]}))
    peer = _config(mode="peer", **{"connect/endpoints": [f"tcp/127.0.0.1:{port}"]})
    client = zenoh.open(peer)
    vanishing = zenoh.open(peer)
    events: list[tuple[str, str]] = []
    samples: list[tuple[str, bytes]] = []
    many: list[list[int]] = [[] for _ in range(20)]
    node: Ros2Node | None = None
    try:
        keep = [
            client.liveliness().declare_subscriber(
                "@ros2_lv/7/**", lambda s: events.append((str(s.kind), str(s.key_expr)))
            ),
            client.declare_subscriber(
                "7/**", lambda s: samples.append((str(s.key_expr), bytes(s.attachment.to_bytes())))
            ),
            *[
                client.declare_subscriber("7/ns/sub/joint_states/**", lambda s, g=g: g.append(1))
                for g in many
            ],
            vanishing.declare_subscriber("7/**", lambda s: None),
        ]
        node = Ros2Node(f"tcp/127.0.0.1:{port}", domain_id=7, namespace="ns/sub", rate_hz=200.0)
        assert node.wait_ready()
        deadline = time.monotonic() + 5.0
        while len({k for _, k in events}) < len(TOPIC_TYPES) + 2 and time.monotonic() < deadline:
            time.sleep(0.02)
        tokens = [_parse(k) for _, k in events]
        assert {t["kind"] for t in tokens} == {"NN", "MP", "MS"}
        for token in tokens:
            assert (token["domain"], token["zid"], token["nid"]) == ("7", node.session_id, "0")
            assert (token["enclave"], token["ns"], token["node"]) == ("/", "/ns/sub", "pirate_bt")
        ids = [t["id"] for t in tokens]
        assert len(set(ids)) == len(ids)  # one entity id each
        topics = {t["topic"] for t in tokens if t["kind"] == "MP"}
        assert topics == {rmw_zenoh.qualified_name("/ns/sub", t) for t in TOPIC_TYPES}
        assert pirate_bt.simulate_tree("straight", params={"distance": "0.2 m"}, ros2=node)
        assert node.flush()
        vanishing.close()  # a subscriber gone without a word
        assert pirate_bt.simulate_tree("straight", params={"distance": "0.2 m"}, ros2=node)
        assert node.flush()
        # a late joiner, as rmw_zenoh's transient-local subscription asks: the last tree
        # (zenoh-ext queries the history at declaration and again when it detects the
        # publisher, so the one cached sample may arrive twice: the same sequence number)
        late: list[tuple[int, int, bytes]] = []
        keep.append(
            zenoh.ext.declare_advanced_subscriber(
                client,
                f"7/ns/sub/{TREE}/**",
                lambda s: late.append(rmw_zenoh.parse_attachment(bytes(s.attachment.to_bytes()))),
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=1),
            )
        )
        # the last tree, by sequence number; a tree still on its way through the
        # router when the late joiner asked may come before it (the cache's then)

        def seqs(got: list[tuple[int, int, bytes]]) -> set[int]:
            return {seq for seq, _, _ in got}

        def trees() -> set[int]:
            return seqs([rmw_zenoh.parse_attachment(a) for k, a in samples if f"/{TREE}/" in k])

        deadline = time.monotonic() + 10.0
        while (
            not (late and max(seqs(late)) == max(trees(), default=-1))
            and time.monotonic() < deadline
        ):
            time.sleep(0.02)
        assert late and trees()
        assert max(seqs(late)) == max(trees()) and seqs(late) <= trees()
    finally:
        if node is not None:
            node.close()
    deadline = time.monotonic() + 3.0
    while sum(k == "SampleKind.DELETE" for k, _ in events) < len(tokens):
        assert time.monotonic() < deadline, "tokens not withdrawn at close"
        time.sleep(0.02)
    assert {k for k, _ in events if k.endswith("DELETE")} and not [
        r for r in client.liveliness().get("@ros2_lv/7/**") if r.ok is not None
    ]
    client.close()
    router.close()
    # every message: rmw_zenoh's attachment, sequence numbers 1, 2, ... per publisher
    by_key: dict[str, list[tuple[int, int, bytes]]] = {}
    for key, attachment in samples:
        assert len(attachment) == 33
        by_key.setdefault(key, []).append(rmw_zenoh.parse_attachment(attachment))
    assert len(by_key) >= 5
    for key, got in by_key.items():
        seqs = [seq for seq, _, _ in got]
        if f"/{TREE}/" in key:  # the latched topic's publisher is reliable: no gap
            assert seqs == list(range(1, len(got) + 1)), key
        else:  # the others drop under congestion (a loaded machine): never out of order
            assert seqs[0] >= 1 and all(b > a for a, b in itertools.pairwise(seqs)), key
        assert len({gid for _, _, gid in got}) == 1
        assert all(abs(stamp - time.time_ns()) < 60e9 for _, stamp, _ in got)
    assert len({got[0][2] for got in by_key.values()}) == len(by_key)  # a GID each
    # twenty subscribers of one topic each got its messages (how many depends on what
    # congestion dropped on a loaded machine)
    assert all(len(g) >= 1 for g in many)
