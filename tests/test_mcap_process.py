"""``--trace RUN.mcap`` from the trace's writer process: a killed run, a killed writer."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.interop.mcap_trace import compact_mcap, read_mcap_messages, read_mcap_records
from pirate_bt.trace import TraceRecorder, read_trace
from tests.trace_support import make_tree, wait_for_writers, writer_processes

ROOT = Path(__file__).resolve().parent.parent
PIRATE_BT = str(Path(sys.executable).with_name("pirate-bt"))
MISSION = [PIRATE_BT, "mission", "scenarios/lab.route", "--sim", "lab", "--quiet", "--trace"]

pytestmark = pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc")


def _start_mission(path: Path) -> subprocess.Popen[str]:
    """The lab mission traced to ``path``, once its file holds a few hundred ticks."""
    proc = subprocess.Popen(
        [*MISSION, str(path)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    deadline = time.monotonic() + 120
    while not path.exists() or path.stat().st_size < 300_000:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the mission wrote nothing"
        time.sleep(0.02)
    return proc


def test_a_recorder_writes_mcap_from_its_writer_process(tmp_path: Path) -> None:
    with TraceRecorder(tmp_path / "t.mcap", make_tree(), clock=SimClock()) as rec:
        assert rec.background
        rec.record_tick()
    assert read_trace(tmp_path / "t.mcap").end is not None
    assert not list(tmp_path.glob(".*.part"))


@pytest.mark.parametrize("group", [False, True], ids=["pid", "group"])
def test_sigkill_mid_mission_leaves_every_tick_handed_over(tmp_path: Path, group: bool) -> None:
    """SIGKILL to the mission's process (or its process group) mid-run: the writer process
    writes every tick it was handed, leaves the file unchunked with no footer, and exits."""
    path = tmp_path / "killed.mcap"
    proc = _start_mission(path)
    if group:
        os.killpg(proc.pid, signal.SIGKILL)
    else:
        proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    wait_for_writers(path)
    _, cut = read_mcap_messages(path)
    assert cut  # no footer: the file says it was cut off
    records = read_mcap_records(path)
    assert records[0]["type"] == "header" and records[-1]["type"] == "tick"
    ticks = [r["n"] for r in records if r["type"] == "tick"]
    # the file held 300 kB at the kill: a few dozen ticks or more, as the pace allows
    assert len(ticks) >= 20 and ticks == sorted(set(ticks)) and ticks[0] == 1, len(ticks)
    trace = read_trace(path)
    assert trace.end is None and trace.outcome == "incomplete"
    assert not list(tmp_path.glob(".*.part"))  # the chunked copy is gone, the file stays
    fixed = compact_mcap(path, tmp_path / "fixed.mcap")
    assert read_mcap_records(fixed) == records


def test_a_killed_writer_process_stops_the_run_safely_and_says_why(tmp_path: Path) -> None:
    """As with ``.jsonl``: the next tick raises SinkError, the runner stops the robot in its
    safe state and the mission fails with the writer's exit status as its reason."""
    path = tmp_path / "writer-killed.mcap"
    proc = _start_mission(path)
    pids = writer_processes(path)
    assert len(pids) == 1
    os.kill(pids[0], signal.SIGKILL)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, err
    assert "safe state" in err
    assert f"{path}: the trace writer failed (exit -9)" in err.splitlines()[-1]
    assert "FAILED" in err.splitlines()[-1], out
    records = read_mcap_records(path)  # what was written before stays readable
    assert records[0]["type"] == "header"
    # the file held 300 kB when the writer was killed: a few dozen ticks or more (the
    # lab mission's header is large; how many more depends on the machine's pace)
    assert sum(r["type"] == "tick" for r in records) >= 20, len(records)


def test_the_finished_file_is_what_the_mcap_writer_writes(tmp_path: Path) -> None:
    """The chunked copy written as the run goes: CRCs, indexes, summary and statistics as the
    ``mcap`` library's reader checks them, the same messages as ``compact_mcap`` gives."""
    from mcap.reader import SeekingReader
    from mcap.stream_reader import StreamReader

    from pirate_bt.cli import main

    path = tmp_path / "run.mcap"
    args = ["run", "trees/straight.yaml", "--param", "distance=0.3m", "--quiet", "--trace"]
    assert main([*args, str(path)]) == 0
    with open(path, "rb") as stream:
        reader = SeekingReader(stream, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        seen = [(c.topic, m.sequence, m.log_time, m.data) for _, c, m in reader.iter_messages()]
        assert summary.statistics.message_count == len(seen) > 100
        assert summary.statistics.chunk_count == len(summary.chunk_indexes) >= 1
        counts = summary.statistics.channel_message_counts
        assert sum(counts.values()) == len(seen)
    with open(path, "rb") as stream:
        assert sum(1 for _ in StreamReader(stream, validate_crcs=True).records) > len(seen)
    # The library's own writer, from the same messages: the same messages come back.
    again = compact_mcap(path, tmp_path / "again.mcap")
    with open(again, "rb") as stream:
        rewritten = [
            (c.topic, m.sequence, m.log_time, m.data)
            for _, c, m in SeekingReader(stream, validate_crcs=True).iter_messages()
        ]
    assert rewritten == seen
