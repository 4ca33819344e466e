"""Another tool's MCAP trace without an index (a recorder killed before its summary, an
unchunked file) is read as it comes, as an indexed one is: reading it holds a message
or a few at a time, not the whole file, in log-time order whatever its order."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.interop.foxglove_topics import TopicMapper, encode_message
from pirate_bt.interop.mcap_trace import McapTraceReader, read_mcap_records
from tests.trace_support import run_and_record

pytest.importorskip("mcap")

TICKS = 2000


def _records(tmp_path: Path) -> list[dict[str, Any]]:
    """A recorded run's header, then ``TICKS`` ticks each moving the state, then its end."""
    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=2)
    header, *_, end = (json.loads(line) for line in source.read_text().splitlines())
    ticks = [
        {
            "type": "tick",
            "n": n,
            "t_s": n / 100,
            "state": {f"joint_angle_rad.bend_{j}": (n + j) / 1e4 for j in range(1, 13)},
            "log": [f"tick {n}"],
        }
        for n in range(1, TICKS + 1)
    ]
    return [header, *ticks, {**end, "n": TICKS, "t_s": TICKS / 100}]


def _write_unindexed(path: Path, records: list[dict[str, Any]], by_channel: bool) -> int:
    """``records`` as another tool writes them, unchunked, cut off before its summary
    (the tool was killed); ``by_channel``: one channel's messages after another's.
    Returns the bytes of the messages."""
    from mcap.writer import Writer

    mapper = TopicMapper()
    messages = [m for record in records for m in mapper.messages(record)]
    if by_channel:
        topics = list(dict.fromkeys(m.topic for m in messages))
        messages.sort(key=lambda m: topics.index(m.topic))  # stable: each in time order
    data_bytes = 0
    with path.open("wb") as out:
        writer = Writer(out, use_chunking=False)
        writer.start(profile="", library="another tool")
        channels: dict[str, int] = {}
        for message in messages:
            if message.topic not in channels:
                schema = writer.register_schema(message.topic, "jsonschema", b"{}")
                channels[message.topic] = writer.register_channel(message.topic, "json", schema)
            data = encode_message(message.message)
            data_bytes += len(data)
            writer.add_message(channels[message.topic], message.log_time_ns, data, 0)
        out.flush()  # no finish(): no summary, no footer
    return data_bytes


def _peak_reading(path: Path, expected: list[tuple[str, Any]]) -> tuple[int, int]:
    """How many records of ``path`` come as ``expected`` says (type and tick number, in
    order) before the first that does not, and the reading's peak of memory (bytes)."""
    tracemalloc.start()
    try:
        same = 0
        for (_, record), (kind, n) in zip(McapTraceReader(path), expected, strict=False):
            if (record.get("type"), record.get("n")) != (kind, n):
                break
            same += 1
        return same, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("by_channel", [False, True], ids=["in-time-order", "channel-by-channel"])
def test_another_tool_s_mcap_trace_without_an_index_is_not_held_whole(
    tmp_path: Path, by_channel: bool
) -> None:
    records = _records(tmp_path)
    other = tmp_path / "other.mcap"
    data_bytes = _write_unindexed(other, records, by_channel)
    expected = [(str(r["type"]), r.get("n")) for r in records]
    _peak_reading(other, expected)  # what the first reading imports is not the reading's
    same, peak = _peak_reading(other, expected)
    assert same == len(records)
    # before: the file was read whole first, every message decoded, and sorted: a peak
    # of many times its messages' bytes; now a message of each stretch at a time
    assert peak < data_bytes / 4, (peak, data_bytes)


def test_an_unindexed_mcap_trace_read_so_gives_what_it_gave_whole(tmp_path: Path) -> None:
    """The records of a file read as it comes are those of the same run written indexed
    (read through its index): each tick's values and log, not only their order."""
    from mcap.writer import Writer

    records = _records(tmp_path)[:40]
    records.append({**records[-1], "type": "end", "n": 38, "t_s": 0.38})
    records[-2:] = records[-1:]
    unindexed = tmp_path / "unindexed.mcap"
    _write_unindexed(unindexed, records, by_channel=True)
    indexed = tmp_path / "indexed.mcap"
    mapper = TopicMapper()
    with indexed.open("wb") as out:
        writer = Writer(out)
        writer.start(profile="", library="another tool")
        channels: dict[str, int] = {}
        for message in (m for record in records for m in mapper.messages(record)):
            if message.topic not in channels:
                schema = writer.register_schema(message.topic, "jsonschema", b"{}")
                channels[message.topic] = writer.register_channel(message.topic, "json", schema)
            writer.add_message(
                channels[message.topic], message.log_time_ns, encode_message(message.message), 0
            )
        writer.finish()
    assert read_mcap_records(unindexed) == read_mcap_records(indexed)
