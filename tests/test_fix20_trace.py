"""Trace leftovers of the twentieth session: a forked child and the trace's lock, and
MCAP files written by another tool (the ``mcap`` library's Writer)."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.trace import read_trace
from pirate_bt.trace.sink_formats import held
from tests.trace_support import run_and_record

ROOT = Path(__file__).resolve().parent.parent

# A run that forks a child (os.fork without exec, as multiprocessing's fork start
# method does) while its trace is open. The run says "forked PID" once the child runs; the child
# then waits for a byte on its standard input; with "close" it first closes its copy of the
# recorder (a `with` block it falls out of). The run then ends ("ended") or is killed.
_FORKING = """
import os, sys
import py_trees
from py_trees.behaviours import StatusQueue
from py_trees.common import Status
from pirate_bt.clock import SimClock
from pirate_bt.trace import TraceRecorder

path = sys.argv[1]
background, child_closes, killed = (flag == "1" for flag in sys.argv[2:5])
s, r = Status.SUCCESS, Status.RUNNING
root = py_trees.composites.Sequence("run", memory=True, children=[StatusQueue("a", [r, r, s], s)])
tree = py_trees.trees.BehaviourTree(root)
clock = SimClock()
recorder = TraceRecorder(path, tree, clock=clock, background=background)
clock.advance(0.1)
tree.tick()
recorder.record_tick()
ready, told = os.pipe()
pid = os.fork()
if pid == 0:
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)  # the test reads the run's output to its end: not held open here
    if child_closes:
        recorder.close()
    os.write(told, b"x")
    os.read(0, 1)  # until the test says so
    os._exit(0)
os.read(ready, 1)  # the child runs
print("forked", pid, flush=True)
for _ in range(2):
    clock.advance(0.1)
    tree.tick()
    recorder.record_tick()
if killed:
    os.kill(os.getpid(), 9)
recorder.close()
print("ended", flush=True)
"""


def _fork_run(path: Path, background: bool, child_closes: bool, killed: bool) -> tuple[Any, int]:
    run = subprocess.Popen(
        [
            sys.executable,
            "-c",
            textwrap.dedent(_FORKING),
            str(path),
            "1" if background else "0",
            "1" if child_closes else "0",
            "1" if killed else "0",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert run.stdout is not None
    said, child = run.stdout.readline().split()
    assert said == "forked"
    return run, int(child)


def _let_child_go(run: Any) -> None:
    with contextlib.suppress(OSError):  # (a child gone already)
        run.stdin.write("x")
        run.stdin.close()


def _free_within(path: Path, limit_s: float) -> bool:
    """Whether the trace is free (no writer holds it) within ``limit_s``, polled."""
    deadline = time.monotonic() + limit_s
    while held(path):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


@pytest.mark.parametrize(
    ("suffix", "background", "child_closes"),
    [
        (".jsonl", False, False),
        (".jsonl.gz", False, True),
        (".mcap", False, True),
        (".jsonl", True, True),
        (".mcap", True, False),
    ],
)
def test_a_forked_child_does_not_keep_the_trace_of_a_run_that_ended(
    tmp_path: Path, suffix: str, background: bool, child_closes: bool
) -> None:
    path = tmp_path / f"run{suffix}"
    run, _ = _fork_run(path, background, child_closes, killed=False)
    try:
        assert run.stdout is not None
        assert run.stdout.readline() == "ended\n"
        assert run.wait(30) == 0
        # the child lives on; the run's trace is whole and free for another run
        assert not held(path)
        trace = read_trace(path)
        assert trace.end is not None and trace.last_tick == 3
    finally:
        _let_child_go(run)
        run.wait(30)
    assert not list(tmp_path.glob(".*")), "a twin left beside the trace"


def test_a_run_killed_with_a_forked_child_alive_leaves_its_trace_written_and_free(
    tmp_path: Path,
) -> None:
    path = tmp_path / "run.jsonl"
    run, child = _fork_run(path, background=True, child_closes=False, killed=True)
    try:
        assert run.wait(30) == -signal.SIGKILL
        # the writer process wrote what it was handed and let the file go; before, it
        # waited for the end of a pipe the child still held, the file locked meanwhile
        assert _free_within(path, 60.0)
        trace = read_trace(path)
        assert (trace.last_tick, trace.outcome) == (3, "incomplete")
        os.kill(child, 0)  # (the child is still alive)
    finally:
        _let_child_go(run)


def _other_tool_mcap(
    records: list[dict[str, Any]], out: Path, ties_reversed: bool, other: bytes = b'{"x": 1}'
) -> None:
    """``records`` as another tool writes them with the ``mcap`` library's Writer: the
    messages in log-time order (those of one time in pirate_bt's order, or channel by
    channel in reverse order of topic names; one channel's in order), channels of its own
    beside pirate_bt's (JSON and Protobuf) whose messages a trace reader must ignore."""
    from mcap.writer import Writer

    from pirate_bt.interop.foxglove_topics import TopicMapper

    mapper = TopicMapper()
    messages = [m for record in records for m in mapper.messages(record)]
    order = list(range(len(messages)))
    if ties_reversed:  # one time's messages channel by channel, the header's last
        order.sort(key=lambda i: messages[i].topic, reverse=True)
        order.sort(key=lambda i: messages[i].log_time_ns)
    with out.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="another tool")
        json_schema = writer.register_schema(name="x.Other", encoding="jsonschema", data=b"{}")
        proto = writer.register_schema(name="x.Proto", encoding="protobuf", data=b"\0")
        extra = [
            writer.register_channel("/other/json", "json", json_schema),
            writer.register_channel("/other/proto", "protobuf", proto),
        ]
        channels: dict[str, int] = {}
        for i in order:
            message = messages[i]
            if message.topic not in channels:
                schema = writer.register_schema(message.topic, "jsonschema", b"{}")
                channels[message.topic] = writer.register_channel(message.topic, "json", schema)
            when = message.log_time_ns
            data = json.dumps(message.message).encode()
            writer.add_message(channels[message.topic], when, data, when)
            for channel in extra:
                writer.add_message(channel, when, other, when)
        writer.finish()


def test_an_mcap_of_another_tool_is_read_whatever_the_order_of_messages_of_one_time(
    tmp_path: Path,
) -> None:
    from pirate_bt.interop.mcap_trace import read_mcap_records

    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=6)
    records = [json.loads(line) for line in source.read_text().splitlines()]
    first = next(r for r in records if r["type"] == "tick")
    first["t_s"] = 0.0  # the first tick at the run's start: the header's log time
    assert records[-1]["type"] == "end"
    assert records[-1]["t_s"] == records[-2]["t_s"]  # the end at the last tick's
    as_written = tmp_path / "in-order.mcap"
    _other_tool_mcap(records, as_written, ties_reversed=False)
    reversed_ties = tmp_path / "ties-reversed.mcap"
    _other_tool_mcap(records, reversed_ties, ties_reversed=True)
    # before: "the first record is no header"
    assert read_mcap_records(reversed_ties) == read_mcap_records(as_written)
    trace = read_trace(reversed_ties)
    outcome = read_trace(source).outcome
    assert (trace.outcome, trace.last_tick, len(trace.ticks)) == (outcome, 6, 6)
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "trace", "summary", str(reversed_ties)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert f"outcome   {outcome}" in done.stdout


def test_a_json_channel_of_another_tool_beside_the_trace_is_skipped(tmp_path: Path) -> None:
    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=3)
    records = [json.loads(line) for line in source.read_text().splitlines()]
    out = tmp_path / "with-other.mcap"
    _other_tool_mcap(records, out, ties_reversed=False, other=b"[1, 2]")
    # before: "with-other.mcap: message 2 (on /other/json) is JSON list, not an object"
    trace = read_trace(out)
    assert (trace.last_tick, trace.outcome) == (3, read_trace(source).outcome)


def test_an_mcap_of_another_tool_written_channel_by_channel_is_read_in_time_order(
    tmp_path: Path,
) -> None:
    # MCAP does not require log-time order; one channel written after another was read
    # in file order and refused: "the first record is no header"
    from mcap.writer import Writer

    from pirate_bt.interop.foxglove_topics import TopicMapper
    from pirate_bt.interop.mcap_trace import read_mcap_records

    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=6)
    records = [json.loads(line) for line in source.read_text().splitlines()]
    mapper = TopicMapper()
    messages = [m for record in records for m in mapper.messages(record)]
    in_order = tmp_path / "in-order.mcap"
    _other_tool_mcap(records, in_order, ties_reversed=False)
    by_channel = tmp_path / "by-channel.mcap"
    with by_channel.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="another tool")
        channels: dict[str, int] = {}
        for topic in sorted({m.topic for m in messages}, reverse=True):  # the header's last
            schema = writer.register_schema(topic, "jsonschema", b"{}")
            channels[topic] = writer.register_channel(topic, "json", schema)
            for m in (m for m in messages if m.topic == topic):
                data = json.dumps(m.message).encode()
                writer.add_message(channels[topic], m.log_time_ns, data, m.log_time_ns)
        writer.finish()
    assert read_mcap_records(by_channel) == read_mcap_records(in_order)
    trace = read_trace(by_channel)
    assert (trace.last_tick, len(trace.ticks)) == (6, 6)
