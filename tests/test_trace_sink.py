"""The trace's writer process: same bytes as in-process, failures reported, odd values."""

from __future__ import annotations

import json
import marshal
import os
import signal
import struct
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState
from pirate_bt.trace import TickExtras, TraceRecorder, read_trace
from pirate_bt.trace.sink import (
    END,
    LINE,
    SETUP,
    TICK,
    SinkError,
    TickEncoder,
    _messages,
    serve,
)
from pirate_bt.trace.writer import JsonLinesWriter, SinkProcess
from tests.trace_support import make_tree, run_and_record


def _lines_without_time(path: Path) -> list[str]:
    lines = path.read_text("utf-8").splitlines()
    header = json.loads(lines[0])
    header.pop("created_utc")
    # py_trees' Timeout writes the wall time left into its feedback: mask it.
    ticks = [json.loads(line) for line in lines[1:]]
    for tick in ticks:
        for key, text in tick.get("feedback", {}).items():
            if text.startswith("time still ticking"):
                tick["feedback"][key] = "time still ticking"
    return [json.dumps(header)] + [json.dumps(t) for t in ticks]


def test_writer_process_and_in_process_write_the_same_records(tmp_path: Path) -> None:
    run_and_record(tmp_path / "process.jsonl", background=None)
    run_and_record(tmp_path / "inline.jsonl", background=False)
    process = _lines_without_time(tmp_path / "process.jsonl")
    inline = _lines_without_time(tmp_path / "inline.jsonl")
    assert process == inline
    assert len(process) == 16  # header, 14 ticks, end


def test_recorder_uses_a_writer_process_by_default(tmp_path: Path) -> None:
    with TraceRecorder(tmp_path / "t.jsonl", make_tree(), clock=SimClock()) as rec:
        assert rec.background
    with TraceRecorder(tmp_path / "u.jsonl", make_tree(), background=False) as rec:
        assert not rec.background


def test_a_dead_writer_process_is_reported_on_the_next_tick(tmp_path: Path) -> None:
    path = tmp_path / "t.jsonl"
    rec = TraceRecorder(path, make_tree(), clock=SimClock(), every_tick=True)
    assert rec._sink is not None
    rec.record_tick()
    os.kill(rec._sink.pid, signal.SIGKILL)
    rec._sink._proc.wait(10)
    with pytest.raises(SinkError, match=rf"{path.name}: the trace writer failed \(exit -9\)"):
        rec.record_tick()
    with pytest.raises(SinkError, match="exit -9"):
        rec.close()
    rec.close()  # closed once and for all: no second error


def test_values_marshal_cannot_carry_are_recorded_as_numbers(tmp_path: Path) -> None:
    """A float subclass (numpy's float64 is one) goes through the fallback, same text."""

    class Float(float):
        pass

    def state(value: float) -> RobotState:
        return RobotState(stamp_s=0.0, readings={}, joint_angle_rad={"bend_1": value})

    for background in (None, False):
        path = tmp_path / f"odd-{background}.jsonl"
        with TraceRecorder(path, make_tree(), clock=SimClock(), background=background) as rec:
            rec.record_tick(TickExtras(state=state(Float(0.1234567)), sim={"x": Float(2.0)}))
            rec.record_tick(TickExtras(state=state(0.1234567)))  # equal value: no change
        ticks = [json.loads(x) for x in path.read_text().splitlines()[1:-1]]
        assert ticks[0]["state"] == {"joint_angle_rad.bend_1": 0.123457}
        assert ticks[0]["sim"] == {"x": 2.0}
        assert len(ticks) == 1


def test_unwritable_destination_fails_at_once(tmp_path: Path) -> None:
    (tmp_path / "dir.jsonl").mkdir()
    with pytest.raises(IsADirectoryError):
        TraceRecorder(tmp_path / "dir.jsonl", make_tree())


def test_open_writer_is_written_in_process(tmp_path: Path) -> None:
    out = JsonLinesWriter(tmp_path / "t.jsonl")
    with pytest.raises(ValueError, match="in-process"):
        TraceRecorder(out, make_tree(), background=True)
    with TraceRecorder(out, make_tree(), clock=SimClock()) as rec:
        assert not rec.background
        rec.record_tick(TickExtras(link=LinkHealth(connected=True)))
    assert read_trace(tmp_path / "t.jsonl").frame_at(1).link["connected"] is True


def test_writer_process_reads_split_messages_and_drops_a_cut_last_one() -> None:
    read_fd, write_fd = os.pipe()
    payloads = [marshal.dumps((LINE, f"line {n}\n")) for n in range(3)]
    data = b"".join(struct.pack("<I", len(p)) + p for p in payloads)
    os.write(write_fd, data[:-3])  # the last message is cut short, as by a kill mid-write
    os.close(write_fd)
    try:
        got = list(_messages(read_fd))
    finally:
        os.close(read_fd)
    assert got == [(LINE, "line 0\n"), (LINE, "line 1\n")]


def test_serve_writes_ticks_and_lines(tmp_path: Path) -> None:
    read_fd, write_fd = os.pipe()
    messages = [
        (SETUP, ["0", "0.0"], False, False, False, ["connected"]),
        (LINE, '{"type":"header"}\n'),
        (2, 1, 0.01, [(0, "R"), (1, "R")], None, None, None, None, None, None, None, None),
        (2, 2, 0.02, None, None, None, None, None, None, None, None, None),  # nothing: no line
        (2, 3, 0.03, None, [(1, "50 %")], None, None, None, None, [True], None, None),
        (END, '{"type":"end"}\n'),
        (LINE, "after the end: never written\n"),
    ]
    for message in messages:
        payload = marshal.dumps(message)
        os.write(write_fd, struct.pack("<I", len(payload)) + payload)
    os.close(write_fd)
    out = JsonLinesWriter(tmp_path / "s.jsonl")
    try:
        serve(read_fd, out)
    finally:
        out.close()
        os.close(read_fd)
    assert (tmp_path / "s.jsonl").read_text().splitlines() == [
        '{"type":"header"}',
        '{"type":"tick","n":1,"t_s":0.01,"status":{"0":"R","0.0":"R"}}',
        '{"type":"tick","n":3,"t_s":0.03,"feedback":{"0.0":"50 %"},"link":{"connected":true}}',
        '{"type":"end"}',
    ]


def test_encoder_state_noise_below_a_micro_unit_is_no_change() -> None:
    encoder = TickEncoder(["0"], link_fields=["connected"])
    keys = ("bend_1", None, None, None, None, None)
    base = (None,) * 4

    def tick(n: int, value: float, layout: bool = False) -> str | None:
        raw = (value, *base)
        message = (2, n, n * 0.01, None, None, None, keys if layout else None, raw)
        return encoder.encode((*message, None, None, None, None))

    assert tick(1, 0.5, layout=True) == (
        '{"type":"tick","n":1,"t_s":0.01,"state":{"joint_angle_rad.bend_1":0.5}}\n'
    )
    assert tick(2, 0.5000000001) is None
    assert (
        tick(3, 0.25)
        == '{"type":"tick","n":3,"t_s":0.03,"state":{"joint_angle_rad.bend_1":0.25}}\n'
    )


def test_sink_process_refuses_an_unknown_writer(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no writer class"):
        SinkProcess(tmp_path / "x.jsonl", "CsvWriter")


def test_readings_layout_change_mid_run(tmp_path: Path) -> None:
    """A channel that appears mid-run is a new layout: its value is recorded."""
    path = tmp_path / "r.jsonl"
    with TraceRecorder(path, make_tree(), clock=SimClock(), readings=True) as rec:
        rec.record_tick(TickExtras(state=RobotState(stamp_s=0.0, readings={})))
        late = RobotState(stamp_s=0.01, readings={"imu.roll": Reading(0.2, 0.01)})
        rec.record_tick(TickExtras(state=late))
    assert read_trace(path).frame_at(2).state == {"readings.imu.roll": 0.2}


def test_falls_back_to_in_process_when_no_process_can_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    import pirate_bt.trace.sink as sink

    monkeypatch.setattr(sink.sys, "executable", "")
    with pytest.raises(SinkError, match="no interpreter"):
        TraceRecorder(tmp_path / "strict.jsonl", make_tree(), background=True)
    with TraceRecorder(tmp_path / "t.jsonl", make_tree(), clock=SimClock()) as rec:
        assert not rec.background
        rec.record_tick(TickExtras(link=LinkHealth(connected=True)))
    assert "writing the trace in-process" in caplog.text
    trace = read_trace(tmp_path / "t.jsonl")
    assert trace.end is not None and trace.frame_at(1).link["connected"] is True


class _Collecting:
    """A stand-in sink that keeps what it is handed."""

    def __init__(self) -> None:
        self.messages: list[tuple[object, ...]] = []
        self.closed = False

    def send(self, message: tuple[object, ...]) -> None:
        self.messages.append(message)

    def close(self, timeout_s: float = 60.0) -> None:
        self.closed = True


def test_hand_over_sends_every_later_tick_and_the_end_to_the_new_sink(tmp_path: Path) -> None:
    """What a live view does (Foxglove): capture here, encode in another process."""
    tree = make_tree()
    rec = TraceRecorder(tmp_path / "t.jsonl", tree, clock=SimClock(), background=False)
    assert rec.node_ids[0] == "0" and len(rec.node_ids) == sum(1 for _ in tree.root.iterate())
    sink = _Collecting()
    rec.hand_over(sink)  # type: ignore[arg-type]
    tree.tick()
    rec.record_tick()
    rec.close()
    kinds = [m[0] for m in sink.messages]
    assert kinds[0] == TICK and kinds[-1] == END and sink.closed
    # the file keeps what was written before the hand-over (the header), nothing after
    assert [
        json.loads(line)["type"] for line in (tmp_path / "t.jsonl").read_text().splitlines()
    ] == ["header"]


def test_hand_over_refuses_a_recorder_that_has_a_writer_process(tmp_path: Path) -> None:
    with (
        TraceRecorder(tmp_path / "t.jsonl", make_tree(), clock=SimClock()) as rec,
        pytest.raises(ValueError, match="already"),
    ):
        rec.hand_over(_Collecting())  # type: ignore[arg-type]
