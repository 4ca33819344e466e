"""An MCAP trace is read as it is read: chunk by chunk, never held whole.

Reading a 100,000-tick ``.mcap`` trace (``read_trace``, ``pirate-bt trace show``)
built a list of every message before the first record was given: 686 MB peak
against 280 MB for the same trace as ``.jsonl`` (``benchmarks/bench_trace_read.py``,
docs/performance.md, "Reading large traces"). These tests count the bytes the
reader has taken from the file when it gives its first record, and check that a
file damaged after its first chunks is still refused whole, not read in part.
"""

from __future__ import annotations

import math
import os
import zlib
from pathlib import Path
from typing import IO, Any

import py_trees
import pytest

import pirate_bt
from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError
from pirate_bt.robot.state import RobotState
from pirate_bt.trace import TickExtras, TraceRecorder, open_reader

mcap_trace = pytest.importorskip("pirate_bt.interop.mcap_trace")
pytest.importorskip("mcap")

TICKS = 6000


@pytest.fixture(scope="module")
def long_mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A trace of 6000 ticks, every state value moving each tick, exported to MCAP:
    several chunks of 1 MiB (uncompressed)."""
    folder = tmp_path_factory.mktemp("stream")
    jsonl = folder / "long.jsonl"
    root = py_trees.composites.Sequence(
        "pab", memory=False, children=[py_trees.behaviours.Running("drive")]
    )
    tree = py_trees.trees.BehaviourTree(root)
    clock = SimClock()
    with TraceRecorder(jsonl, tree, clock=clock) as recorder:
        for n in range(1, TICKS + 1):
            clock.advance(0.01)
            tree.tick()
            wave = math.sin(n / 7.0)
            state = RobotState(
                stamp_s=clock.now(),
                readings={},
                joint_angle_rad={f"bend_{k}": wave * k for k in range(1, 5)},
                clamp_force_n={f"bend_{k}": 8.0 + wave / k for k in range(1, 5)},
                drive_velocity_mps={f"bend_{k}_drive": 0.08 + wave * 1e-3 * k for k in range(1, 5)},
                motor_current_a={f"bend_{k}_drive": 0.4 + wave * 1e-2 * k for k in range(1, 5)},
            )
            recorder.record_tick(TickExtras(state=state))
    return mcap_trace.export_mcap(jsonl, folder / "long.mcap")


class _Counted:
    """A file open for reading that counts the bytes taken from it."""

    def __init__(self, stream: IO[bytes], counter: list[int]) -> None:
        self._stream = stream
        self._counter = counter

    def read(self, size: int = -1) -> bytes:
        data = self._stream.read(size)
        self._counter[0] += len(data)
        return data

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)

    def __enter__(self) -> _Counted:
        return self

    def __exit__(self, *exc: object) -> None:
        self._stream.close()


def _counting_open(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    counter = [0]

    def counted(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        return _Counted(open(file, mode, *args, **kwargs), counter)

    monkeypatch.setattr(mcap_trace, "open", counted, raising=False)
    return counter


def test_the_first_record_comes_before_the_file_is_read_through(
    long_mcap: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    size = long_mcap.stat().st_size
    counter = _counting_open(monkeypatch)
    reader = open_reader(long_mcap)
    records = iter(reader)
    line, header = next(records)
    assert (line, header["type"]) == (1, "header")
    assert counter[0] < size / 2, f"read {counter[0]} of {size} bytes for the header"
    line, tick = next(records)
    assert (line, tick["type"], tick["n"]) == (2, "tick", 1)
    assert counter[0] < size / 2
    rest = list(records)
    assert counter[0] >= size * 0.9  # read through in the end
    assert [r["type"] for _, r in rest[-1:]] == ["end"]
    assert len(rest) == TICKS  # every tick, then the end record
    assert reader.truncated is False


def test_a_streamed_read_gives_what_the_file_holds(long_mcap: Path) -> None:
    trace = pirate_bt.read_trace(long_mcap)
    assert len(trace.ticks) == TICKS
    assert not trace.truncated
    assert [t.n for t in trace.ticks[:3]] == [1, 2, 3]
    assert trace.end is not None
    records = mcap_trace.read_mcap_records(long_mcap)
    assert records[0]["type"] == "header" and records[-1]["type"] == "end"
    assert sum(r["type"] == "tick" for r in records) == TICKS
    messages, cut = mcap_trace.read_mcap_messages(long_mcap)
    assert not cut and messages[0][0] == "/pirate/run"


def _damage_last_chunk(source: Path, target: Path) -> None:
    """``source`` with one byte of its last chunk's compressed data changed."""
    data = bytearray(source.read_bytes())
    with open(source, "rb") as stream:
        from mcap.reader import make_reader

        chunks = make_reader(stream).get_summary().chunk_indexes  # type: ignore[union-attr]
    assert len(chunks) >= 3, "the trace should span several chunks"
    last = chunks[-1]
    at = last.chunk_start_offset + last.chunk_length - 40  # inside its records
    data[at] ^= 0xFF
    target.write_bytes(bytes(data))
    assert zlib.crc32(data) != zlib.crc32(source.read_bytes())


def test_damage_after_the_first_chunks_is_refused_not_read_in_part(
    long_mcap: Path, tmp_path: Path
) -> None:
    damaged = tmp_path / "damaged.mcap"
    _damage_last_chunk(long_mcap, damaged)
    with pytest.raises(InputError) as caught:
        pirate_bt.read_trace(damaged)
    message = str(caught.value)
    assert message.startswith(f"{damaged}: damaged after ")
    assert "\n" not in message
    with pytest.raises(InputError, match="damaged after"):
        mcap_trace.read_mcap_records(damaged)


def test_exporting_a_damaged_mcap_leaves_nothing(long_mcap: Path, tmp_path: Path) -> None:
    damaged = tmp_path / "damaged.mcap"
    _damage_last_chunk(long_mcap, damaged)
    out = tmp_path / "out.mcap"
    with pytest.raises(InputError, match="damaged after"):
        mcap_trace.export_mcap(damaged, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["damaged.mcap"]


@pytest.mark.parametrize("read", ["read_mcap_records", "read_mcap_messages"])
def test_a_file_descriptor_number_is_no_file_name_and_is_left_open(
    long_mcap: Path, read: str
) -> None:
    # a number was opened as a file descriptor, read, and closed (0: standard input)
    fd = os.open(long_mcap, os.O_RDONLY)
    try:
        with pytest.raises(InputError, match=r"^path: give a file name .*not an int$"):
            getattr(mcap_trace, read)(fd)
        assert os.fstat(fd).st_size == long_mcap.stat().st_size  # still open
    finally:
        os.close(fd)


@pytest.mark.parametrize(
    ("path", "said"),
    [
        (None, "path: give a file name (text or a Path), not None"),
        ("run\0.mcap", "path: a file name may not hold a NUL character"),
    ],
)
def test_no_file_name_is_one_line_not_a_traceback(path: Any, said: str) -> None:
    # None was a TypeError, a NUL a ValueError, from open()
    with pytest.raises(InputError) as caught:
        mcap_trace.read_mcap_records(path)
    assert str(caught.value) == said


def test_a_named_pipe_is_refused_not_waited_on(tmp_path: Path) -> None:
    fifo = tmp_path / "run.mcap"
    os.mkfifo(fifo)
    # held open here with bytes in it, so that a reader that opens it anyway fails
    # (invalid magic) instead of waiting for ever for a writer
    held = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)
    try:
        os.write(held, b"not an MCAP file, nor a trace\n")
        with pytest.raises(InputError) as caught:
            mcap_trace.read_mcap_records(fifo)
        assert str(caught.value) == f"{fifo}: cannot read: it is a named pipe, not a file"
    finally:
        os.close(held)


def test_another_tools_json_recording_is_no_trace_not_an_empty_one(tmp_path: Path) -> None:
    # JSON messages on other topics were read as no records at all: read_mcap_records
    # gave [] and read_trace (pirate-bt trace summary) said "empty trace (no header)"
    from mcap.writer import Writer

    foreign = tmp_path / "diagnostics.mcap"
    with open(foreign, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema(name="d", encoding="jsonschema", data=b"{}")
        channel = writer.register_channel("/diagnostics", "json", schema)
        for n in range(3):
            writer.add_message(channel, n, b'{"level": 0}', n)
        writer.finish()
    said = (
        f"{foreign}: not a pirate_bt trace: no JSON /pirate/run channel"
        " (its channels: /diagnostics (json))"
    )
    with pytest.raises(InputError) as caught:
        mcap_trace.read_mcap_records(foreign)
    assert str(caught.value) == said
    with pytest.raises(InputError) as caught:
        pirate_bt.read_trace(foreign)
    assert str(caught.value) == said


def test_compact_mcap_checks_its_arguments_as_the_readers_do(tmp_path: Path) -> None:
    # compact_mcap(None) was a TypeError traceback and a named pipe hung until killed
    from pirate_bt.errors import ArgumentTypeError
    from pirate_bt.interop.mcap_writer import compact_mcap

    with pytest.raises(ArgumentTypeError, match=r"^path: give a file name"):
        compact_mcap(None)  # type: ignore[arg-type]
    with pytest.raises(ArgumentTypeError, match=r"^path: give a file name"):
        compact_mcap(0)  # type: ignore[arg-type]
    fifo = tmp_path / "run.mcap"
    os.mkfifo(fifo)
    held = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)
    try:
        os.write(held, b"not an MCAP file\n")
        with pytest.raises(InputError) as caught:
            compact_mcap(fifo)
        assert str(caught.value) == f"{fifo}: cannot read: it is a named pipe, not a file"
    finally:
        os.close(held)
    assert not list(tmp_path.glob("*.mcap.*"))  # nothing half-written beside it
