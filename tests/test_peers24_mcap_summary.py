"""An MCAP trace written by another writer whose summary does not repeat its channels or
schemas (the spec leaves that to the writer: the ``mcap`` library's
``Writer(repeat_channels=False)``, ``repeat_schemas=False``, foxglove-sdk's
``MCAPWriteOptions`` of the same names) is read as the trace it holds. It was refused
as *damaged after 0 messages: KeyError: 1*: the indexed reading took every channel from
the summary."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.interop.foxglove_topics import TopicMapper, encode_message
from pirate_bt.interop.mcap_trace import read_mcap_messages, read_mcap_records
from pirate_bt.trace import read_trace
from tests.trace_support import run_and_record

pytest.importorskip("mcap")


def _rewrite(records: list[dict[str, Any]], path: Path, **options: Any) -> Path:
    """``records`` as another tool writes them with the ``mcap`` library, chunked and
    indexed, with ``options`` for its ``Writer``."""
    from mcap.writer import Writer

    mapper = TopicMapper()
    with path.open("wb") as out:
        writer = Writer(out, chunk_size=512, **options)
        writer.start(profile="", library="another tool")
        channels: dict[str, int] = {}
        sequence = 0
        for record in records:
            for message in mapper.messages(record):
                if message.topic not in channels:
                    schema = writer.register_schema(message.topic, "jsonschema", b"{}")
                    channels[message.topic] = writer.register_channel(message.topic, "json", schema)
                sequence += 1
                writer.add_message(
                    channels[message.topic],
                    message.log_time_ns,
                    encode_message(message.message),
                    message.log_time_ns,
                    sequence=sequence,
                )
        writer.finish()
    return path


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    source = tmp_path_factory.mktemp("run") / "run.jsonl"
    run_and_record(source, ticks=6)
    return [json.loads(line) for line in source.read_text().splitlines()]


@pytest.mark.parametrize(
    "options",
    [
        {"repeat_channels": False},
        {"repeat_schemas": False},
        {"repeat_channels": False, "repeat_schemas": False},
    ],
    ids=["channels", "schemas", "both"],
)
def test_a_summary_without_its_channels_or_schemas_reads_as_the_trace(
    records: list[dict[str, Any]], tmp_path: Path, options: dict[str, bool]
) -> None:
    path = _rewrite(records, tmp_path / "other.mcap", **options)
    assert read_mcap_records(path) == records
    trace = read_trace(path)  # as `pirate-bt trace show` reads it
    assert [tick.n for tick in trace.ticks] == [r["n"] for r in records if r["type"] == "tick"]
    messages, cut = read_mcap_messages(path)
    assert not cut and messages[0][0] == "/pirate/run"


def test_a_summary_with_its_channels_is_still_read_by_its_index(
    records: list[dict[str, Any]], tmp_path: Path
) -> None:
    """The neighbour: the usual file (channels and schemas repeated) reads the same."""
    assert read_mcap_records(_rewrite(records, tmp_path / "usual.mcap")) == records


@pytest.mark.parametrize(
    "options",
    [
        {"repeat_channels": False},
        {"repeat_schemas": False},
        {"repeat_channels": False, "emit_message_indexes": False, "emit_statistics": False},
    ],
    ids=["channels", "schemas", "bare"],
)
def test_foxglove_sdk_s_file_without_its_channels_in_the_summary_reads_as_the_trace(
    records: list[dict[str, Any]], tmp_path: Path, options: dict[str, bool]
) -> None:
    """The same written by foxglove-sdk, the other writer Foxglove's users record with."""
    foxglove = pytest.importorskip("foxglove")
    from foxglove.mcap import MCAPWriteOptions

    path = tmp_path / "sdk.mcap"
    context = foxglove.Context()
    mapper = TopicMapper()
    channels: dict[str, Any] = {}
    write_options = MCAPWriteOptions(chunk_size=512, **options)
    with foxglove.open_mcap(path, context=context, writer_options=write_options):
        for record in records:
            for message in mapper.messages(record):
                if message.topic not in channels:
                    schema = foxglove.Schema(name=message.topic, encoding="jsonschema", data=b"{}")
                    channels[message.topic] = foxglove.Channel(
                        message.topic, message_encoding="json", schema=schema, context=context
                    )
                channels[message.topic].log(
                    encode_message(message.message), log_time=message.log_time_ns
                )
    assert read_mcap_records(path) == records
