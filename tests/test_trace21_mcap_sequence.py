"""MCAP traces rewritten by another tool: one channel's messages of one log time are
read in the order of their ``sequence`` (the publisher's counter, filled by pirate_bt's
writers), whatever order the tool wrote them in."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.interop.mcap_trace import export_mcap, read_mcap_records
from pirate_bt.trace import read_trace
from tests.trace_support import run_and_record


def _rewrite_ties_reversed(source: Path, out: Path, library: str | None) -> None:
    """``source`` written again by the ``mcap`` library's Writer, as a merge or a sort
    writes it: the same channels and sequences, the messages in log-time order, but
    each channel's messages of one log time in reverse. The header names ``library``
    (``None``: the source's)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with source.open("rb") as stream:
        reader = make_reader(stream)
        header = reader.get_header()
        read = list(reader.iter_messages(log_time_order=True))
    runs: dict[tuple[int, int], list[int]] = {}
    for i, (_, channel, message) in enumerate(read):
        runs.setdefault((channel.id, message.log_time), []).append(i)
    order = list(range(len(read)))
    for held in runs.values():  # each run's places, filled in reverse
        for place, source_i in zip(held, reversed(held), strict=True):
            order[place] = source_i
    with out.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library=header.library if library is None else library)
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for i in order:
            schema, channel, message = read[i]
            assert schema is not None
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id]
                )
            writer.add_message(
                channels[channel.id],
                message.log_time,
                message.data,
                message.publish_time,
                sequence=message.sequence,
            )
        writer.finish()


@pytest.mark.parametrize("library", ["another tool", None])
def test_one_channel_s_messages_of_one_time_written_in_reverse_are_read_in_sequence(
    tmp_path: Path, library: str | None
) -> None:
    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=6)  # tick 5: a drive passed, then a rotate refused
    ours = export_mcap(source, tmp_path / "run.mcap")
    rewritten = tmp_path / "rewritten.mcap"
    _rewrite_ties_reversed(ours, rewritten, library)
    # before: tick 5's commands read rotate first, then drive
    assert read_mcap_records(rewritten) == read_mcap_records(ours)
    tick = next(t for t in read_trace(rewritten).ticks if t.n == 5)
    assert [c["command"] for c in tick.commands] == ["drive(80 mm/s)", "rotate(1 rad)"]


def test_a_channel_without_sequences_keeps_its_file_order(tmp_path: Path) -> None:
    # sequence 0 is "not filled": nothing to order by, the file's order is kept
    from mcap.writer import Writer

    from pirate_bt.interop.mcap_trace import read_mcap_messages

    out = tmp_path / "unsequenced.mcap"
    with out.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="another tool")
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channel = writer.register_channel("/x", "json", schema)
        for i in (3, 1, 2):
            writer.add_message(channel, 10, f'{{"i": {i}}}'.encode(), 10)
        writer.finish()
    messages, _ = read_mcap_messages(out)
    assert [m["i"] for _, m in messages] == [3, 1, 2]
