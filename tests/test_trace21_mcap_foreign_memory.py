"""An MCAP trace written by another tool (foxglove-sdk, the ``mcap`` library's Writer) is
read chunk by chunk through its index, as pirate_bt's own files are read as they come:
reading it holds the chunks whose times overlap, not the whole file."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path
from typing import Any

from pirate_bt.interop.foxglove_topics import TopicMapper, encode_message
from pirate_bt.interop.mcap_trace import McapTraceReader
from tests.trace_support import run_and_record

TICKS = 2000


def _peak_reading(path: Path) -> tuple[int, int]:
    """The records of ``path`` and the reading's peak of memory (bytes)."""
    tracemalloc.start()
    try:
        count = sum(1 for _ in McapTraceReader(path))
        return count, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


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
        }
        for n in range(1, TICKS + 1)
    ]
    return [header, *ticks, {**end, "n": TICKS, "t_s": TICKS / 100}]


def test_another_tool_s_indexed_mcap_trace_is_not_held_whole(tmp_path: Path) -> None:
    from mcap.writer import Writer

    records = _records(tmp_path)
    other = tmp_path / "other.mcap"
    data_bytes = 0
    with other.open("wb") as out:
        writer = Writer(out, chunk_size=32 * 1024)  # chunked and indexed, as tools write
        writer.start(profile="", library="another tool")
        channels: dict[str, int] = {}
        mapper = TopicMapper()
        for message in (m for record in records for m in mapper.messages(record)):
            if message.topic not in channels:
                schema = writer.register_schema(message.topic, "jsonschema", b"{}")
                channels[message.topic] = writer.register_channel(message.topic, "json", schema)
            data = encode_message(message.message)
            data_bytes += len(data)
            writer.add_message(channels[message.topic], message.log_time_ns, data, 0)
        writer.finish()
    _peak_reading(other)  # what the first reading imports is not the reading's
    count, peak = _peak_reading(other)
    assert count == len(records)
    # before: the file was read whole first, every message decoded: a peak of about 10
    # times its messages' bytes (3.8 MB for 0.5 MB); now one of its 32 KiB chunks at a
    # time (0.13 MB)
    assert peak < data_bytes, (peak, data_bytes)
