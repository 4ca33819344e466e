"""Trace writing and reading: round trip against the live tree, crashes, cut-off files."""

from __future__ import annotations

import gzip
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.behaviours import StatusQueue
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError, LocatedError
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState
from pirate_bt.trace import (
    CommandRecord,
    TickExtras,
    TraceRecorder,
    attach_trace,
    read_trace,
    summarise,
    trace_schema,
    tree_structure,
)
from pirate_bt.trace.records import state_from_flat
from tests.trace_support import (
    make_tree,
    run_and_record,
    state,
    wait_for_writers,
)

DATA = Path(__file__).parent / "data" / "traces"
TREES = Path(__file__).parents[1] / "trees"
FORMATS = [".jsonl", ".jsonl.gz"]


@pytest.mark.parametrize("background", [None, False], ids=["process", "inprocess"])
@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_matches_live_tree_on_every_tick(
    tmp_path: Path, suffix: str, background: bool | None
) -> None:
    path = tmp_path / f"run{suffix}"
    live = run_and_record(path, background=background)
    trace = read_trace(path)
    assert trace.outcome == "success"
    assert trace.last_tick == len(live) - 1
    assert not trace.truncated
    for n, expected in enumerate(live):
        assert trace.statuses_at(n) == expected, f"tick {n}"
    frame = trace.frame_at(12)
    assert frame.state["joint_angle_rad.bend_1"] == pytest.approx(1.0)
    assert frame.link["retries"] == 3
    assert frame.sim["frames"] == 24
    assert frame.blackboard["/progress"] == 4
    robot_state = trace.robot_state_at(3)
    assert robot_state is not None
    assert robot_state.joint_angle_rad["bend_1"] == pytest.approx(0.3)
    assert robot_state.mean_drive_velocity_mps() == pytest.approx(0.08)


def test_only_changes_are_written(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    run_and_record(path)
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    ticks = [r for r in lines if r["type"] == "tick"]
    # bend_2 never changes: written once, on the first tick only
    assert sum("joint_angle_rad.bend_2" in t.get("state", {}) for t in ticks) == 1
    assert sum("0.0" in t.get("status", {}) for t in ticks) == 2  # RUNNING, then SUCCESS


def test_full_state_option_records_every_value(tmp_path: Path) -> None:
    path = tmp_path / "full.jsonl"
    run_and_record(path, full_state=True, readings=True)
    ticks = [json.loads(x) for x in path.read_text().splitlines()[1:-1]]
    assert all(t["full"] and "joint_angle_rad.bend_2" in t["state"] for t in ticks)
    assert "readings.bend_1_angle" in ticks[0]["state"]
    assert read_trace(path).frame_at(14).state["joint_angle_rad.bend_1"] == pytest.approx(1.0)


def test_header_structure_and_schema(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    run_and_record(path)
    records = [json.loads(x) for x in path.read_text().splitlines()]
    header = records[0]
    assert header["format"] == "pirate-bt-trace" and header["version"] == 1
    assert header["scenario"] == "straight" and header["seed"] == 7
    assert {"pirate_bt", "py_trees", "python"} <= set(header["software"])
    kinds = {n["name"]: n["kind"] for n in header["tree"]["nodes"]}
    assert kinds == {
        "pab": "composite",
        "clamp rear": "leaf",
        "within 5 s": "guard",
        "drive": "leaf",
        "bend or retry": "composite",
        "bend": "leaf",
        "fallback": "leaf",
        "unclamp": "leaf",
    }
    schema = trace_schema()
    defs = schema["$defs"]
    for record in records:
        part = defs[record["type"]]
        assert set(part["required"]) <= set(record)
        if part.get("additionalProperties") is False:
            assert set(record) <= set(part["properties"]), record


def test_ids_are_stable_across_builds() -> None:
    first = tree_structure(make_tree())
    second = tree_structure(make_tree())
    assert [n.to_json() for n in first] == [n.to_json() for n in second]
    assert [n.id for n in first][:3] == ["0", "0.0", "0.1"]


def test_summary_counts_refusals_and_faults(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    run_and_record(path)
    trace = read_trace(path)
    summary = summarise(trace)
    by_name = {trace.structure.node(i).name: s for i, s in summary.nodes.items()}
    assert by_name["clamp rear"].runs == 1 and by_name["clamp rear"].successes == 1
    assert by_name["clamp rear"].running_s == pytest.approx(0.02)
    assert by_name["bend"].failures == 1
    assert [r["reason"] for r in summary.refusals] == ["rotate_needs_one_clamped"]
    assert [f["message"] for f in summary.faults] == ["crc burst"]
    assert summary.commands == 15


def test_cut_off_last_line_is_tolerated(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    run_and_record(path)
    data = path.read_bytes()
    lines = data.splitlines(keepends=True)
    cut = b"".join(lines[:-2]) + lines[-2][: len(lines[-2]) // 2]  # no end, half a tick
    path.write_bytes(cut)
    trace = read_trace(path)
    assert trace.truncated
    assert trace.outcome == "incomplete"
    assert trace.ticks[-1].n == json.loads(lines[-3])["n"]


def test_bad_line_in_the_middle_names_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    run_and_record(path)
    lines = path.read_text().splitlines(keepends=True)
    lines[3] = "{not json\n"
    path.write_text("".join(lines))
    with pytest.raises(LocatedError) as info:
        read_trace(path)
    assert f"{path}:4:" in str(info.value)


def test_not_a_trace_and_unknown_suffix(tmp_path: Path) -> None:
    path = tmp_path / "x.jsonl"
    path.write_text('{"type": "tick", "n": 1, "t_s": 0}\n')
    with pytest.raises(LocatedError, match="first record is no header"):
        read_trace(path)
    with pytest.raises(InputError, match="unknown trace format"):
        read_trace(tmp_path / "x.csv")
    with pytest.raises(InputError, match="cannot read"):
        read_trace(tmp_path / "missing.jsonl")
    with pytest.raises(InputError, match="no tick 99"):
        run_and_record(tmp_path / "ok.jsonl")
        read_trace(tmp_path / "ok.jsonl").frame_at(99)


def test_reference_trace_reads() -> None:
    trace = read_trace(DATA / "pab_v1.jsonl")
    assert trace.outcome == "success"
    assert trace.frame_at(trace.last_tick).status["0"] == "S"


WRITER_SCRIPT = textwrap.dedent(
    """
    import sys, time, py_trees
    from py_trees.behaviours import StatusQueue
    from py_trees.common import Status
    from pirate_bt.clock import SimClock
    from pirate_bt.trace import TraceRecorder
    root = py_trees.composites.Sequence("root", memory=True, children=[
        StatusQueue("a", [Status.RUNNING] * 1000000, Status.SUCCESS)])
    tree = py_trees.trees.BehaviourTree(root)
    clock = SimClock()
    background = {"none": None, "false": False}[sys.argv[2]]
    rec = TraceRecorder(sys.argv[1], tree, clock=clock, every_tick=True, background=background)
    n = 0
    while True:
        clock.advance(0.01)
        tree.tick()
        rec.record_tick()
        n += 1
        if n == 50:
            print("ready", rec.background, flush=True)
    """
)


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc")
@pytest.mark.parametrize("background", ["none", "false"])
@pytest.mark.parametrize("suffix", FORMATS)
@pytest.mark.parametrize("group", [False, True], ids=["pid", "group"])
def test_sigkill_leaves_every_complete_tick(
    tmp_path: Path, suffix: str, background: str, group: bool
) -> None:
    """SIGKILL to the run (or to its whole process group) loses no tick handed over."""
    path = tmp_path / f"killed{suffix}"
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER_SCRIPT, str(path), background],
        stdout=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[1])},
        start_new_session=True,
    )
    try:
        assert proc.stdout is not None
        ready = proc.stdout.readline().split()
        assert ready == [b"ready", b"True" if background == "none" else b"False"]
        time.sleep(0.05)
        if group:
            os.killpg(proc.pid, signal.SIGKILL)
        else:
            proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    # The writer process outlives the run (its own session), writes what it was handed
    # and exits; in-process writing leaves nothing behind.
    wait_for_writers(path)
    trace = read_trace(path)
    assert trace.end is None and trace.outcome == "incomplete"
    assert len(trace.ticks) >= 50
    assert [t.n for t in trace.ticks] == list(range(1, len(trace.ticks) + 1))
    assert trace.frame_at(trace.last_tick).status == {"0": "R", "0.0": "R"}
    if suffix == ".jsonl.gz" and background == "false":
        with pytest.raises(EOFError):
            gzip.decompress(path.read_bytes())  # no trailer: the stream really was cut
    elif suffix == ".jsonl.gz":
        gzip.decompress(path.read_bytes())  # the writer process closed the stream properly


def test_attach_trace_to_runner(tmp_path: Path) -> None:
    from pirate_bt.runner import Runner

    class Boom(py_trees.behaviour.Behaviour):
        def update(self) -> Status:
            raise RuntimeError("boom")

    root = py_trees.composites.Sequence(
        "root",
        memory=True,
        children=[StatusQueue("a", [Status.RUNNING], Status.SUCCESS), Boom("b")],
    )
    clock = SimClock()
    runner = Runner(root, clock=clock, period_s=0.01)
    seen: list[int] = []
    attach_trace(runner, tmp_path / "r.jsonl", extras=lambda info: seen.append(info.tick) or None)
    result = runner.run()
    trace = read_trace(tmp_path / "r.jsonl")
    assert trace.last_tick == result.ticks == 2
    assert seen == [1]
    assert trace.outcome == "error"
    assert trace.end is not None and trace.end["error"]["node"] == "0.1"
    assert trace.header["tick_period_s"] == 0.01
    assert summarise(trace).faults[0]["node"] == "0.1"


def test_state_from_flat_round_trip() -> None:
    from pirate_bt.trace.records import flatten_state

    original = state(1.0, 0.5)
    rebuilt = state_from_flat(flatten_state(original, readings=True), 1.0)
    assert rebuilt.joint_angle_rad == dict(original.joint_angle_rad)
    assert rebuilt.clamp_force_n == dict(original.clamp_force_n)
    assert rebuilt.value("bend_1_angle") == 0.5


def test_state_changes_match_flatten_state_diff() -> None:
    """The fast state diff gives what comparing flatten_state() values would."""
    import math
    import random

    from pirate_bt.trace.records import StateChanges, flatten_state

    rng = random.Random(7)
    for readings in (False, True):
        fast = StateChanges(readings=readings)
        slow: dict[str, object] = {}
        for n in range(300):
            pick = [0.1, 0.1000000001, -0.0, 0.0, math.nan, math.inf, 2.5, 1]
            joints = {f"bend_{k}": rng.choice(pick) for k in range(1, 3 + n % 2)}
            state = RobotState(
                stamp_s=n * 0.01,
                readings={"a": Reading(rng.choice(pick), 0.0)},
                joint_angle_rad=joints,
                clamp_force_n={"bend_1": rng.choice(pick)},
                rotation_rad=rng.choice([None, 0.5, 0.25]),
                imu_rad={"roll": 0.0},
            )
            flat = flatten_state(state, readings=readings)
            expected = {k: v for k, v in flat.items() if slow.get(k, slow) != v}
            slow.update(expected)
            got = fast.changes(state)
            assert list(got) == list(expected)
            assert all(
                got[k] == expected[k] or (got[k] != got[k] and expected[k] != expected[k])
                for k in got
            )


def test_jsonl_writer_writes_each_record_to_the_kernel(tmp_path: Path) -> None:
    """Each record is on disk (readable by another reader) as soon as write() returns."""
    from pirate_bt.trace.writer import JsonLinesWriter

    out = JsonLinesWriter(tmp_path / "t.jsonl")
    out.write({"type": "tick", "n": 1, "t_s": 0.01, "feedback": {"0": "é"}})
    assert (tmp_path / "t.jsonl").read_text("utf-8") == (
        '{"type":"tick","n":1,"t_s":0.01,"feedback":{"0":"é"}}\n'
    )
    with pytest.raises(ValueError):
        out.write({"type": "tick", "x": float("nan")})
    out.close()


def test_state_changes_name_moving_between_views_is_a_new_layout() -> None:
    """The same names in another view are new values, not an unchanged snapshot."""
    from pirate_bt.trace.records import StateChanges

    fast = StateChanges()
    first = RobotState(stamp_s=0.0, readings={}, joint_angle_rad={"bend_1": 0.5})
    moved = RobotState(stamp_s=0.01, readings={}, clamp_force_n={"bend_1": 0.5})
    assert fast.changes(first) == {"joint_angle_rad.bend_1": 0.5}
    assert fast.changes(moved) == {"clamp_force_n.bend_1": 0.5}


def test_link_and_counters_written_only_when_they_change(tmp_path: Path) -> None:
    """A fresh LinkHealth (nan rtt) each tick and sub-µ noise are no change; real ones are."""
    import math

    tree = make_tree()
    clock = SimClock()
    counters = {"frames": 0.0, "distance_m": 0.1}
    with TraceRecorder(tmp_path / "t.jsonl", tree, clock=clock, blackboard=False) as rec:
        for n in range(1, 9):
            clock.advance(0.01)
            counters["distance_m"] = 0.1 + (1e-9 * n if n < 5 else 0.5)  # mutated in place
            if n == 6:
                counters["new"] = 1
            health = LinkHealth(
                connected=True,
                rtt_s=math.nan if n < 3 else 0.05,
                last_heard_s=-math.inf,
                retries=n // 4,
            )
            rec.record_tick(TickExtras(link=health, sim=counters))
    lines = (tmp_path / "t.jsonl").read_text("utf-8").splitlines()
    ticks = {r["n"]: r for r in map(json.loads, lines) if r["type"] == "tick"}
    links = {n: r["link"] for n, r in ticks.items() if "link" in r}
    sims = {n: r["sim"] for n, r in ticks.items() if "sim" in r}
    assert read_trace(tmp_path / "t.jsonl").frame_at(8).link["retries"] == 2
    assert links[1] == {
        "connected": True,
        "last_heard_s": "-inf",
        "rtt_s": "nan",
        "loss_ratio": 0.0,
        "crc_errors": 0,
        "retries": 0,
        "failed": 0,
        "duplicates": 0,
        "estopped": False,
        "estop_input": False,
    }
    assert {n: v for n, v in links.items() if n > 1} == {
        3: {"rtt_s": 0.05},
        4: {"retries": 1},
        8: {"retries": 2},
    }
    assert sims == {1: {"frames": 0.0, "distance_m": 0.1}, 5: {"distance_m": 0.6}, 6: {"new": 1}}


def test_supervised_extras_reads_verdicts_and_counters_once() -> None:
    """Each verdict is recorded once; counters are re-read every tick, missing ones tolerated."""
    from types import SimpleNamespace

    from pirate_bt.trace import supervised_extras

    class Verdict:
        def to_record(self) -> dict[str, object]:
            return {
                "command": "drive(80 mm/s)",
                "outcome": "clip",
                "reason": "speed_limit",
                "detail": "",
                "source": "tree",
                "sent": [["d", "velocity", 1]],
            }

    listeners: list[Any] = []
    supervisor = SimpleNamespace(
        add_listener=listeners.append,
        state=lambda: None,
        health=lambda: LinkHealth(connected=True),
    )
    full = SimpleNamespace(
        distance_m=0.0,
        stuck_events=0,
        slip_events=0,
        violation_count=0,
        damage_count=0,
        frames_dropped=0,
        frames_rejected=0,
        watchdog_trips=0,
    )
    box = [full]
    extras = supervised_extras(supervisor, counters=lambda: box[0], more=lambda: {"belief_m": 1.0})
    listeners[0](Verdict())
    first = extras(None)
    assert first.commands == (
        CommandRecord(
            "drive(80 mm/s)", "clip", "speed_limit", None, (("d", "velocity", 1.0),), "tree"
        ),
    )
    assert first.sim is not None and first.sim["distance_m"] == 0.0
    assert first.sim["belief_m"] == 1.0
    assert extras(None).commands == ()
    full.distance_m = 0.25  # the same counters object, changed
    assert extras(None).sim == {**first.sim, "distance_m": 0.25}
    box[0] = SimpleNamespace(distance_m=0.5, stuck_events=None)  # an older simulator
    assert extras(None).sim == {"distance_m": 0.5, "belief_m": 1.0}


def test_counter_cache_skips_only_unchanged_frozen_snapshots() -> None:
    from types import SimpleNamespace

    from pirate_bt.sim.counters import SimCounters
    from pirate_bt.trace.attach import _CounterCache

    cache = _CounterCache()
    frozen = SimCounters(distance_m=1.0)
    values = cache(frozen)
    assert cache(frozen) is values and values["distance_m"] == 1.0
    assert cache(SimCounters(distance_m=2.0))["distance_m"] == 2.0
    # A mutable object handed out again is read again: a change is never hidden.
    mutable = SimpleNamespace(**{f: 0 for f in ("stuck_events", "slip_events")})
    for name in ("frames_dropped", "frames_rejected", "watchdog_trips"):
        setattr(mutable, name, 0)
    mutable.distance_m, mutable.violation_count, mutable.damage_count = 3.0, 0, 0
    assert cache(mutable)["distance_m"] == 3.0
    mutable.distance_m = 4.0
    assert cache(mutable)["distance_m"] == 4.0


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda c: c["counts"]["0"].__setitem__(0, float("nan")), "counts: 0: [nan,"),
        (lambda c: c["counts"]["0"].__setitem__(1, float("inf")), "counts: 0: [70, inf,"),
        (lambda c: c["counts"]["0"].__setitem__(2, "x"), "is not 6 whole numbers"),
        (lambda c: c["counts"]["0"].__setitem__(3, None), "is not 6 whole numbers"),
        (lambda c: c["counts"].__setitem__("0.0", 7), "counts: 0.0: 7 is not 6 whole"),
        (lambda c: c["counts"].__setitem__("0", [1, 2]), "counts: 0: [1, 2] is not 6"),
        (lambda c: c.__setitem__("conditions", 5), "conditions is 5, not a list"),
        (lambda c: c["counts"].__setitem__("9.9", [0] * 6), "'9.9' is no node of the tree"),
    ],
    ids=["nan", "infinity", "text", "null", "not-a-list", "too-short", "conditions", "no-node"],
)
def test_bad_coverage_in_the_end_record_names_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: Any, expected: str
) -> None:
    import pirate_bt
    from pirate_bt.cli import main

    path = tmp_path / "run.jsonl"
    pirate_bt.simulate_tree("straight", params={"distance": "0.05 m"}, trace=path)
    assert read_trace(path).coverage is not None
    lines = path.read_text().splitlines()
    end = json.loads(lines[-1])
    end["coverage"]["counts"]["0"][0] = 70  # the same on every run, for the messages
    change(end["coverage"])
    path.write_text("\n".join([*lines[:-1], json.dumps(end)]) + "\n")
    with pytest.raises(LocatedError) as info:
        read_trace(path)
    assert str(info.value).startswith(f"{path}:{len(lines)}:1: bad end record: coverage: ")
    assert expected in str(info.value)
    # Was exit 1, "internal error: ValueError: cannot convert float NaN to integer".
    svg = tmp_path / "x.svg"
    for argv in (
        ["trace", "summary", str(path)],
        [
            "render",
            str(TREES / "straight.yaml"),
            "--trace",
            str(path),
            "--coverage",
            "-o",
            str(svg),
        ],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"{path}:{len(lines)}:1: bad end record" in err
    assert not svg.exists()
