"""The ring of shared memory that carries ticks to the trace's writer process."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import py_trees
import pytest
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import RobotState
from pirate_bt.trace import CommandRecord, TickExtras, TraceRecorder, read_trace, sink, sink_ring
from pirate_bt.trace.sink import SinkError, SinkProcess
from pirate_bt.trace.sink_ring import Ring, RingReader
from tests.trace_support import wait_for_writers


def _has_ring() -> bool:
    created = Ring.create(4096)
    if created is None:
        return False
    created[0].close()
    os.close(created[1])
    return True


pytestmark = pytest.mark.skipif(not _has_ring(), reason="no shared memory for a ring (not Linux)")


def _spinning_tree() -> py_trees.trees.BehaviourTree:
    """A sequence that restarts a running leaf every few ticks: statuses keep moving."""
    steps = [
        py_trees.behaviours.StatusQueue(f"step {i}", [Status.RUNNING] * (i + 2), Status.SUCCESS)
        for i in range(4)
    ]
    return py_trees.trees.BehaviourTree(py_trees.composites.Sequence("run", True, steps))


def _record(path: Path, ticks: int, **options: object) -> TraceRecorder:
    tree = _spinning_tree()
    clock = SimClock()
    with TraceRecorder(path, tree, clock=clock, **options) as rec:  # type: ignore[arg-type]
        for n in range(1, ticks + 1):
            clock.advance(0.01)
            tree.tick()
            if tree.root.status != Status.RUNNING:
                tree.root.stop(Status.INVALID)
            state = RobotState(
                stamp_s=clock.now(),
                readings={},
                joint_angle_rad={"bend_1": math.sin(n / 10), "bend_2": 0.5},
                drive_velocity_mps={"drive": 0.08 + (n % 7) * 1e-3},
            )
            rec.record_tick(
                TickExtras(
                    state=state,
                    commands=(CommandRecord(f"drive({n % 3} mm/s)", "pass"),),
                    link=LinkHealth(connected=True, retries=n // 100),
                )
            )
    return rec


def test_a_recorder_hands_ticks_over_through_a_ring(tmp_path: Path) -> None:
    rec = _record(tmp_path / "t.jsonl", 10)
    assert rec.background
    assert read_trace(tmp_path / "t.jsonl").last_tick == 10


def test_a_small_ring_wraps_and_fills_and_the_records_are_the_same(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """4 kB of ring for 3000 ticks: frames wrap around its end, and the recorder waits for
    the writer process to read (it gives space back only after a rest) many times over.

    (CI on 2026-12-01 saw this fail with the ticks' pacing left to the machine: under
    load some ticks went through the pipe and the ring went round 26 times, not 50.)"""
    monkeypatch.setattr(sink_ring, "CAPACITY", 4096)
    # Every tick into the ring, however loaded the machine: a tick more than PAUSE_S
    # after the one before goes through the pipe instead (and moves the ring on less).
    monkeypatch.setattr(sink, "PAUSE_S", 10.0)
    waits: list[int] = []
    make_room = SinkProcess._make_room

    def counted(self: SinkProcess, end: int) -> None:
        waits.append(end)
        make_room(self, end)

    monkeypatch.setattr(SinkProcess, "_make_room", counted)
    _record(tmp_path / "ring.jsonl", 3000)
    assert len(waits) > 10 and waits[-1] > 50 * 4096
    _record(tmp_path / "inline.jsonl", 3000, background=False)
    ring = (tmp_path / "ring.jsonl").read_text().splitlines()
    inline = (tmp_path / "inline.jsonl").read_text().splitlines()
    assert len(ring) == 3002
    assert ring[1:] == inline[1:]  # the header differs by its time of creation only


def test_ring_positions_wrap_around_the_end() -> None:
    created = Ring.create(64)
    assert created is not None
    ring, fd = created
    os.close(fd)
    try:
        reader = RingReader(ring)
        head = 0
        frames = [bytes([i]) * 4 + os.urandom(13) for i in range(10)]
        for frame in frames:
            head = ring.put(head, frame)
            assert ring.head() == head
            assert ring.get(head - len(frame), head) == frame
        assert head == 170 > 2 * ring.capacity
        reader.read_to = head - len(frames[-1])
        reader.rested()
        assert ring.tail() == head - len(frames[-1])
    finally:
        ring.close()


_QUIET = textwrap.dedent(
    """
    import sys, time, py_trees
    from pirate_bt.trace import TraceRecorder, sink
    sink.BELL_S = sink.PAUSE_S = 3600.0  # one bell, at the first tick: the rest unrung
    root = py_trees.behaviours.Running("spin")
    rec = TraceRecorder(sys.argv[1], py_trees.trees.BehaviourTree(root), every_tick=True)
    assert rec._sink._ring is not None
    for n in range(1, 2001):
        root.tick_once()
        rec.record_tick()
    print(n, rec._sink._head - rec._sink._belled, flush=True)
    time.sleep(60)
    """
)


def test_ticks_put_in_the_ring_after_the_last_bell_survive_a_sigkill(tmp_path: Path) -> None:
    """Killed while the ticks it put in the ring have not been rung: the writer process
    reads the ring to its end when the pipe closes, so none is lost."""
    path = tmp_path / "killed.jsonl"
    proc = subprocess.Popen(
        [sys.executable, "-c", _QUIET, str(path)],
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1])},
    )
    assert proc.stdout is not None
    done, unrung = map(int, proc.stdout.readline().split())
    assert done == 2000 and unrung > 0
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    wait_for_writers(path)
    trace = read_trace(path)
    assert [t.n for t in trace.ticks] == list(range(1, done + 1))
    assert trace.outcome == "incomplete"


def test_without_a_ring_every_tick_goes_through_the_pipe(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Where there is no shared memory (not Linux, or refused), the pipe carries all."""
    monkeypatch.setattr(Ring, "create", classmethod(lambda cls, capacity=None: None))
    rec = _record(tmp_path / "pipe.jsonl", 500)
    assert rec.background
    _record(tmp_path / "inline.jsonl", 500, background=False)
    pipe = (tmp_path / "pipe.jsonl").read_text().splitlines()
    assert pipe[1:] == (tmp_path / "inline.jsonl").read_text().splitlines()[1:]


def test_a_dead_writer_is_noticed_when_the_ring_is_full(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ticks that ring no bell go into the ring until it is full; then the recorder
    rings, and the failed write says the writer process died."""
    monkeypatch.setattr(sink_ring, "CAPACITY", 4096)
    monkeypatch.setattr(sink, "BELL_S", 3600.0)
    monkeypatch.setattr(sink, "PAUSE_S", 3600.0)
    tree = _spinning_tree()
    rec = TraceRecorder(tmp_path / "t.jsonl", tree, clock=SimClock(), every_tick=True)
    assert rec._sink is not None
    for _ in range(2):  # the first through the pipe, the second into the ring, rung
        tree.tick()
        rec.record_tick()
    os.kill(rec._sink.pid, signal.SIGKILL)
    rec._sink._proc.wait(10)
    ticks = 0
    with pytest.raises(SinkError, match=r"the trace writer failed \(exit -9\)"):
        while ticks < 10_000:
            tree.tick()
            rec.record_tick()
            ticks += 1
    assert 10 < ticks < 4096  # silently into the ring, until it had no room left
    with pytest.raises(SinkError):
        rec.close()
