"""rosbag2 bags written by another tool (``rosbags``' own Writer, in its sqlite3 and
mcap storages) read back by pirate_bt: the trace's records in the trace's order."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.trace_support import run_and_record

pytest.importorskip("rosbags")


def _written_again(bag: Path, out: Path, storage: str, reversed_order: bool) -> None:
    """``bag`` written again by rosbags' Writer: the same connections and messages, in
    the bag's order or in reverse (rosbags reads them in timestamp order; those of one
    timestamp then come in the order written)."""
    from rosbags.rosbag2 import Reader, StoragePlugin, Writer

    with Reader(bag) as reader:
        connections = list(reader.connections)
        messages = [(c.id, stamp, bytes(raw)) for c, stamp, raw in reader.messages()]
    with Writer(out, version=9, storage_plugin=StoragePlugin[storage]) as writer:
        ids = {
            c.id: writer.add_connection(
                c.topic,
                c.msgtype,
                msgdef=c.msgdef.data if c.msgdef else None,
                rihs01=c.digest,
                offered_qos_profiles=c.ext.offered_qos_profiles,
            )
            for c in connections
        }
        for connection, stamp, raw in messages[::-1] if reversed_order else messages:
            writer.write(ids[connection], stamp, raw)


@pytest.mark.parametrize("storage", ["SQLITE3", "MCAP"])
@pytest.mark.parametrize("reversed_order", [False, True])
def test_a_bag_another_tool_wrote_gives_the_trace_back_in_its_order(
    tmp_path: Path, storage: str, reversed_order: bool
) -> None:
    from pirate_bt.interop.rosbag2 import export_rosbag2, read_rosbag2_records

    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=6)
    records = [json.loads(line) for line in source.read_text().splitlines()]
    ours = export_rosbag2(source, tmp_path / "run_bag")
    other = tmp_path / "other_bag"
    _written_again(ours, other, storage, reversed_order)
    # before (reversed): the end, which shares its timestamp with tick 6, came first:
    # [..., ('tick', 5), ('end', 6), ('tick', 6)]
    got = read_rosbag2_records(other)
    assert [(r["type"], r.get("n")) for r in got] == [(r["type"], r.get("n")) for r in records]
    assert got == records
