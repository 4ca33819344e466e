"""Querying a trace from Python: nodes by name, status changes, failures, why the run ended."""

from __future__ import annotations

from pathlib import Path

import pytest
from py_trees.common import Status

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.trace import (
    Failure,
    FeedbackChange,
    NodeLookupError,
    StatusChange,
    Trace,
    read_trace,
)

RUN = ["run", "trees/straight.yaml", "--param", "distance=0.2m", "--quiet", "--sim", "straight"]
HOLD = "straight/pass straight/hold or over an opening/hold"
CLAMP_REAR_HALF = f"{HOLD}/hold/clamp rear/clamp rear half"
OVER_AN_OPENING = "straight/pass straight/hold or over an opening/front over an opening"


@pytest.fixture(scope="module")
def ok(tmp_path_factory: pytest.TempPathFactory) -> Trace:
    """A straight PAB that succeeds: clamp rear, clamp front, drive 0.2 m."""
    path = tmp_path_factory.mktemp("ok") / "ok.jsonl"
    assert main([*RUN, "--trace", str(path)]) == 0
    return read_trace(path)


@pytest.fixture(scope="module")
def stalled(tmp_path_factory: pytest.TempPathFactory) -> Trace:
    """The same PAB with the rear clamp's joint stalled: clamping times out twice, then recover."""
    path = tmp_path_factory.mktemp("stalled") / "stalled.jsonl.gz"
    faults = ["--faults", "motor_stall:bend_3_joint@0.2s+30s"]
    assert main([*RUN, *faults, "--trace", str(path)]) == 1
    return read_trace(path)


def test_nodes_by_glob_and_substring(ok: Trace) -> None:
    every = ok.nodes()
    assert every[0] == "straight"
    assert len(every) == len(ok.structure) == 22
    assert ok.nodes("*/hold/clamp rear") == [f"{HOLD}/hold/clamp rear"]
    assert ok.nodes("*/clamp rear") == [f"{HOLD}/hold/clamp rear", f"{OVER_AN_OPENING}/clamp rear"]
    assert ok.nodes("*/clamp *half") == [
        CLAMP_REAR_HALF,
        every[11],
        f"{OVER_AN_OPENING}/clamp rear/clamp rear half",
    ]
    assert every[11].endswith("/clamp front half")
    assert ok.nodes("recover") == [
        "straight/recover",
        "straight/recover/safe state",
        "straight/recover/report failure",
    ]
    assert ok.nodes("no such node") == []


def test_node_by_id_path_tail_name_or_glob(ok: Trace) -> None:
    drive = ok.node("drive straight")
    assert (drive.id, drive.type, drive.kind) == ("0.0.2.0", "Drive", "leaf")
    assert ok.node("0.0.2.0") is drive
    assert ok.node("straight/pass straight/confirm drive/drive straight") is drive
    assert ok.node("confirm drive/drive straight") is drive
    assert ok.node("*/drive s*") is drive
    assert ok.node(drive) is drive
    assert ok.node_path(drive) == "straight/pass straight/confirm drive/drive straight"
    assert ok.node(HOLD).id == "0.0.1.0"  # a whole path wins over tails
    assert ok.node("hold/hold").id == "0.0.1.0.0"


def test_unknown_or_ambiguous_node_names_the_candidates(ok: Trace) -> None:
    with pytest.raises(NodeLookupError) as info:
        ok.node("hold")
    assert "'hold' matches 2 nodes" in str(info.value)
    assert info.value.matches == [HOLD, f"{HOLD}/hold"]
    with pytest.raises(NodeLookupError, match="'clamp rear half' matches 2 nodes"):
        ok.node("clamp rear half")
    with pytest.raises(KeyError, match="did you mean 'clamp rear'"):
        ok.node("clamp reer")
    with pytest.raises(InputError, match=r"its nodes are: clamp front, .*drive straight"):
        ok.statuses("xyzzy")


def test_statuses_and_first_tick(ok: Trace) -> None:
    changes = ok.statuses(CLAMP_REAR_HALF)
    assert [c.status for c in changes] == ["RUNNING", "SUCCESS"]
    assert changes[0] == StatusChange(1, 0.0, "RUNNING")
    tick, time_s, status = changes[1]
    assert status == "SUCCESS" and time_s == pytest.approx(tick * 0.05 - 0.05)
    assert ok.first_tick(CLAMP_REAR_HALF, "SUCCESS") == tick
    # The front half is clamped after the rear, and the drive starts once both are.
    front_done = ok.first_tick("clamp front half", "success")
    drive_start = ok.first_tick("drive straight", Status.RUNNING)
    assert front_done is not None and drive_start is not None
    assert tick < front_done <= drive_start  # the sequence goes on within the tick
    # the drive ends the tree; the trace goes on while the wheels ramp down (the run's
    # end waits for the robot to come to rest: a few ticks without the tree)
    assert ok.first_tick("drive straight", "S") == ok.first_tick("straight", "S")
    assert ok.first_tick("straight", "S") < ok.last_tick <= ok.first_tick("straight", "S") + 10
    assert ok.first_tick("report failure", "FAILURE") is None  # recovery never ran
    assert ok.first_tick("report failure", "invalid") == 0
    assert ok.statuses("report failure") == []
    with pytest.raises(ValueError, match="not a status"):
        ok.first_tick("drive straight", "DONE")


def test_status_at_agrees_with_the_replayed_frames(ok: Trace) -> None:
    drive = ok.node("drive straight")
    start = ok.first_tick(drive, "RUNNING")
    assert start is not None
    assert ok.status_at(drive, 0) == "INVALID"
    assert ok.status_at(drive, start - 1) == "INVALID"
    assert ok.status_at(drive, start) == "RUNNING"
    assert ok.status_at("drive straight", ok.last_tick) == "SUCCESS"
    for n in (0, 5, start, (start + ok.last_tick) // 2, ok.last_tick):
        expected = ok.statuses_at(n)
        for node in ok.structure:
            assert ok.status_at(node.id, n) == expected[node.id].name, (node.id, n)
    with pytest.raises(InputError, match="no tick 9999"):
        ok.status_at(drive, 9999)


def test_feedback_changes(ok: Trace) -> None:
    messages = ok.feedback(CLAMP_REAR_HALF)
    assert messages and all(isinstance(m, FeedbackChange) for m in messages)
    assert messages[0].tick == 1 and messages[0].message.startswith("clamping rear: bend_3 0.0°")
    assert [m.tick for m in messages] == sorted({m.tick for m in messages})
    assert ok.feedback("report failure") == []


def test_success_has_no_failures_and_says_why(ok: Trace) -> None:
    assert ok.failures() == []
    assert ok.outcome == "success"
    # the tree's own last tick (the trace goes on while the wheels ramp down)
    assert ok.why == f"tree succeeded after {ok.first_tick('straight', 'S')} ticks"


def test_failures_first_failure_first(stalled: Trace) -> None:
    failures = stalled.failures()
    assert all(isinstance(f, Failure) for f in failures)
    first = failures[0]
    assert first.path == CLAMP_REAR_HALF
    assert first.node.type == "Clamp"
    assert first.feedback.startswith("timeout: not done after 5 s")
    assert first.tick == stalled.first_tick(CLAMP_REAR_HALF, "FAILURE")
    assert first.time_s == pytest.approx(5.05)
    # The Retry around it tried again; the second timeout failed the whole PAB in one tick,
    # each child before its parent (the hold's fallback over an opening is only for a
    # leg that stops at features: it fails), then the recovery branch reported it.
    last_tick = stalled.last_tick
    final = [f.path for f in failures if f.tick == last_tick]
    assert final == [
        CLAMP_REAR_HALF,
        f"{HOLD}/hold/clamp rear",
        f"{HOLD}/hold",
        HOLD,
        f"{OVER_AN_OPENING}/may stop at it?",
        OVER_AN_OPENING,
        "straight/pass straight/hold or over an opening",
        "straight/pass straight",
        "straight/recover/report failure",
        "straight/recover",
        "straight",
    ]
    assert len(failures) == len(final) + 1
    retry = next(f for f in failures if f.path.endswith("/clamp rear"))
    assert retry.feedback == "final failure [status: 2 failure from 2]"
    assert [c.status for c in stalled.statuses(CLAMP_REAR_HALF)] == [
        "RUNNING",
        "FAILURE",
        "RUNNING",
        "FAILURE",
    ]
    assert stalled.status_at("safe state", last_tick) == "SUCCESS"
    assert stalled.outcome == "failure"
    # the end record carries the first cause, as the run's result does
    assert stalled.why is not None and stalled.why.startswith("timeout: not done after 5 s")
    assert stalled.why == failures[0].feedback


def test_why_names_the_node_that_raised(tmp_path: Path) -> None:
    path = tmp_path / "crash.jsonl"
    path.write_text(
        '{"type":"header","format":"pirate-bt-trace","version":1,"tree":{"name":"t","nodes":['
        '{"id":"0","name":"t","type":"Sequence","kind":"composite","parent":null,"children":["0.0"]},'
        '{"id":"0.0","name":"boom","type":"X","kind":"leaf","parent":"0","children":[]}]}}\n'
        '{"type":"tick","n":1,"t_s":0.1,"status":{"0":"R","0.0":"R"}}\n'
        '{"type":"end","n":1,"t_s":0.1,"outcome":"error","reason":"a behaviour raised",'
        '"error":{"node":"0.0","exception":"RuntimeError: boom"}}\n'
    )
    trace = read_trace(path)
    assert trace.outcome == "error"
    assert trace.why == "a behaviour raised; t/boom: RuntimeError: boom"
    path.write_text(path.read_text().rsplit("\n", 2)[0] + "\n")  # no end record
    cut = read_trace(path)
    assert (cut.outcome, cut.why) == ("incomplete", None)


def test_why_says_an_exception_the_reason_already_says_once(tmp_path: Path) -> None:
    # a planner's node that raised: the end's reason names it and its exception, and
    # why said it twice ("ValueError in plain: plain broke; plain: ValueError: plain broke")
    path = tmp_path / "raised.jsonl"
    path.write_text(
        '{"type":"header","format":"pirate-bt-trace","version":1,"tree":{"name":"t","nodes":['
        '{"id":"0","name":"plain","type":"Plain","kind":"leaf","parent":null,"children":[]}]}}\n'
        '{"type":"tick","n":1,"t_s":0.05,"status":{"0":"R"}}\n'
        '{"type":"end","n":1,"t_s":0.05,"outcome":"error",'
        '"reason":"ValueError in plain: plain broke",'
        '"error":{"node":"0","exception":"ValueError: plain broke"}}\n'
    )
    assert read_trace(path).why == "ValueError in plain: plain broke"
