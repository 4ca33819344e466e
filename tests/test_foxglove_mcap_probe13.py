"""Probe 13: the Foxglove WebSocket server and the MCAP files, checked against the protocols.

A second implementation of each side: a client that churns subscriptions, a strict JSON
parser and a JSON Schema check of every message against its channel's schema, the
``mcap`` library's readers in each mode, and hostile MCAP files given to ``read_trace``.
"""

from __future__ import annotations

import json
import struct
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from foxglove_ws import FoxgloveClient

from pirate_bt.errors import InputError

pytestmark = pytest.mark.xdist_group("real-time")

ROOT = Path(__file__).resolve().parent.parent


HEADER = {
    "type": "header",
    "format": "pirate_bt.trace",
    "version": 1,
    "created_utc": "2026-11-30T00:00:00Z",
    "tree": {"id": "0", "name": "root", "type": "Running"},
    "robot": {},
    "clock": "sim",
}
"""A trace's header for a tree of one node (the records the tests send after it)."""


def _strict_json(data: bytes) -> Any:
    """JSON as RFC 8259 (and Foxglove's ``JSON.parse``) has it: no NaN, no Infinity."""

    def refuse(token: str) -> Any:
        raise ValueError(f"not JSON: {token}")

    return json.loads(data, parse_constant=refuse)


def _violations(schema: Any, value: Any, where: str = "$") -> list[str]:
    """Where ``value`` breaks ``schema`` (the JSON Schema keywords the topics use)."""
    if schema is True or schema == {}:
        return []
    kinds = schema.get("type")
    if kinds is not None:
        names = kinds if isinstance(kinds, list) else [kinds]
        python = {
            "object": dict,
            "array": list,
            "string": str,
            "boolean": bool,
            "null": type(None),
        }
        fits = any(
            (name == "integer" and isinstance(value, int) and not isinstance(value, bool))
            or (name == "number" and isinstance(value, int | float) and not isinstance(value, bool))
            or (name in python and isinstance(value, python[name]))
            for name in names
        )
        if not fits:
            return [f"{where}: {value!r:.60} is not {kinds}"]
    if "enum" in schema and value not in schema["enum"]:
        return [f"{where}: {value!r} is none of {schema['enum']}"]
    found: list[str] = []
    if isinstance(value, dict):
        properties = schema.get("properties", {})
        others = schema.get("additionalProperties", True)
        for key, item in value.items():
            if key in properties:
                found += _violations(properties[key], item, f"{where}.{key}")
            elif others is False:
                found.append(f"{where}: {key} is not in the schema")
            elif isinstance(others, dict):
                found += _violations(others, item, f"{where}.{key}")
    if isinstance(value, list) and "items" in schema:
        for i, item in enumerate(value):
            found += _violations(schema["items"], item, f"{where}[{i}]")
    return found


# --- messages are JSON, as their channels say ------------------------------------------


def test_numbers_that_are_not_finite_are_strings_never_nan_tokens() -> None:
    """Python's json writes ``NaN`` and ``Infinity``, which are not JSON: Foxglove's parser
    refused such a message whole. A record given as data with a float NaN, and a mean wheel
    speed that overflows, were sent so."""
    from pirate_bt.interop.foxglove_schemas import encode_message, schema_of
    from pirate_bt.interop.foxglove_topics import TopicMapper

    mapper = TopicMapper()
    header = dict(HEADER)
    ticks = [
        {"type": "tick", "n": 1, "t_s": 0.1, "state": {"drive_velocity_mps.a": 1e308}},
        {"type": "tick", "n": 2, "t_s": 0.2, "state": {"drive_velocity_mps.b": 1e308}},
        {"type": "tick", "n": 3, "t_s": 0.3, "bb": {"x": float("nan"), "y": [float("-inf")]}},
    ]
    seen = set()
    for record in [header, *ticks]:
        for message in mapper.messages(record):
            value = _strict_json(encode_message(message.message))
            assert not _violations(schema_of(message.topic)[1], value), (message.topic, value)
            seen.add(message.topic)
    assert {"/pirate/state", "/pirate/blackboard"} <= seen
    assert value["values"] == {"x": "nan", "y": ["-inf"]}  # the blackboard's last message
    assert encode_message({"a": 1.5, "b": [float("inf")]}) == b'{"a":1.5,"b":["inf"]}'


def test_every_message_of_an_mcap_run_fits_its_schema_in_every_reader_mode(
    tmp_path: Path,
) -> None:
    """The ``mcap`` library reads the run's file seeking (with its index and summary) and
    streaming, with chunk CRCs checked; every message is strict JSON that fits its
    channel's JSON Schema, with the encodings Foxglove expects and log times in ns."""
    from mcap.reader import NonSeekingReader, SeekingReader

    import pirate_bt

    path = tmp_path / "run.mcap"
    result = pirate_bt.simulate_tree(
        ROOT / "trees" / "straight.yaml",
        params={"distance": "0.1m"},
        faults="motor_stall:bend_3_joint@0s",
        max_time="60 s",
        trace=path,
    )
    assert result.ticks > 10
    counts: list[int] = []
    for reader_class in (SeekingReader, NonSeekingReader):
        with path.open("rb") as f:
            reader = reader_class(f, validate_crcs=True)
            times: list[int] = []
            topics: set[str] = set()
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                assert schema is not None
                assert (schema.encoding, channel.message_encoding) == ("jsonschema", "json")
                assert channel.topic.startswith("/pirate/") and channel.schema_id == schema.id
                value = _strict_json(message.data)
                assert not _violations(json.loads(schema.data), value), (channel.topic, value)
                assert message.log_time > 10**18 and message.publish_time == message.log_time
                times.append(message.log_time)
                topics.add(channel.topic)
            assert times == sorted(times)
            assert {"/pirate/run", "/pirate/tree", "/pirate/state", "/pirate/end"} <= topics
            counts.append(len(times))
            if reader_class is SeekingReader:
                summary = reader.get_summary()
                assert summary is not None and summary.statistics is not None
                assert summary.statistics.message_count == len(times)
                assert summary.chunk_indexes
    assert counts[0] == counts[1]


# --- subscription churn --------------------------------------------------------------


def test_subscription_churn_is_bounded_for_the_run_and_for_other_clients() -> None:
    """A client subscribing and unsubscribing as fast as it can: the run's process hears
    of it at most once per LATE_S, and another client is sent the run's header again at
    most as often (until 2026-11-30: once per subscription, and over a hundred headers a
    second to every other subscriber)."""
    from pirate_bt.interop.foxglove_live import FoxgloveServer
    from pirate_bt.interop.foxglove_process import LATE_S

    with FoxgloveServer(port=0) as server:
        heard: list[int] = []
        hear = server._heard

        def counting(message: tuple[Any, ...]) -> None:
            heard.append(message[0])
            hear(message)

        server._heard = counting  # type: ignore[method-assign]
        server.publish_record(dict(HEADER))
        watcher = FoxgloveClient("127.0.0.1", server.port)
        assert watcher.wait_for(lambda c: "/pirate/run" in c.channels, 10)
        watcher.subscribe("/pirate/run")
        assert watcher.wait_for(lambda c: c.of("/pirate/run"), 10)
        churner = FoxgloveClient("127.0.0.1", server.port)
        assert churner.wait_for(lambda c: "/pirate/run" in c.channels, 10)
        channel = churner.channels["/pirate/run"]["id"]
        stop = threading.Event()

        def drain() -> None:
            while not stop.is_set():
                try:
                    churner.pump(0.05)
                except OSError:
                    return

        reader = threading.Thread(target=drain, daemon=True)
        reader.start()
        before = len(heard)
        started = time.monotonic()
        sent = 0
        while time.monotonic() - started < 1.0:
            sent += 1
            churner.send_json(
                {"op": "subscribe", "subscriptions": [{"id": sent, "channelId": channel}]}
            )
            churner.send_json({"op": "unsubscribe", "subscriptionIds": [sent]})
        churned_s = time.monotonic() - started
        watcher.pump(0.5)
        stop.set()
        reader.join(2)
        churner.close()
        told = heard[before:].count(32)  # foxglove_process.SUBSCRIBED
        headers = len(watcher.of("/pirate/run"))
        watcher.close()
    rounds = (churned_s + 0.5) / LATE_S + 3
    assert sent > 3 * rounds, sent  # the churn outran the bound
    assert told <= rounds, (told, sent)
    assert headers <= 1 + rounds, (headers, sent)


def test_a_record_with_a_float_nan_reaches_a_live_client_as_json() -> None:
    from pirate_bt.interop.foxglove_live import FoxgloveServer

    with FoxgloveServer(port=0) as server:
        client = FoxgloveClient("127.0.0.1", server.port)
        assert client.wait_for(lambda c: "/pirate/blackboard" in c.channels, 10)
        client.subscribe("/pirate/blackboard")
        assert client.wait_for(lambda _: server.subscriptions >= 1, 10)
        raw: list[bytes] = []
        handle = client._handle

        def keep(opcode: int, data: bytes) -> None:
            if opcode == 2:
                raw.append(data)
            handle(opcode, data)

        client._handle = keep  # type: ignore[method-assign]
        server.publish_record({"type": "tick", "n": 1, "t_s": 0.1, "bb": {"x": float("nan")}})
        assert client.wait_for(lambda _: raw, 10)
        client.close()
    opcode, subscription = struct.unpack_from("<BI", raw[0])
    assert (opcode, subscription) == (1, 1)
    assert _strict_json(raw[0][13:])["set"] == {"x": "nan"}


# --- hostile MCAP files ------------------------------------------------------------------


def _hostile(src: bytes) -> dict[str, bytes]:
    magic = src[:8]
    (header_length,) = struct.unpack_from("<Q", src, 9)
    after_header = 8 + 9 + header_length
    unknown = b"\x80" + struct.pack("<Q", 3) + b"abc"
    return {
        "wrong magic": b"\x89MCAP1\r\n" + src[8:],
        "magic only": magic,
        "huge header length": src[:9] + struct.pack("<Q", 2**63) + src[17:],
        "huge unknown record": src[:after_header]
        + b"\x80"
        + struct.pack("<Q", 2**62)
        + src[after_header:],
        "unknown records": src[:after_header] + unknown * 1000 + src[after_header:],
        "empty records": src[:after_header] + (b"\x80" + bytes(8)) * 100_000 + src[after_header:],
        "footer pointing far": src[:-28] + struct.pack("<QQI", 2**62, 2**62, 0) + src[-8:],
        "bad summary crc": src[:-12] + struct.pack("<I", 12345) + src[-8:],
        "a chunk bit flipped": src[: len(src) // 3]
        + bytes([src[len(src) // 3] ^ 0x10])
        + src[len(src) // 3 + 1 :],
    }


def test_hostile_mcap_files_are_one_line_or_read_never_a_traceback_or_a_hang(
    tmp_path: Path,
) -> None:
    import pirate_bt
    from pirate_bt.trace import read_trace

    good = tmp_path / "good.mcap"
    pirate_bt.simulate_tree(
        ROOT / "trees" / "straight.yaml", params={"distance": "0.05m"}, trace=good
    )
    for name, data in _hostile(good.read_bytes()).items():
        path = tmp_path / (name.replace(" ", "_") + ".mcap")
        path.write_bytes(data)
        started = time.monotonic()
        try:
            trace = read_trace(path)
            assert trace.frames() is not None
        except InputError as exc:
            assert "\n" not in str(exc) and str(path) in str(exc), (name, exc)
        assert time.monotonic() - started < 30.0, name  # a hang guard, not a speed figure
