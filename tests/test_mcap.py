"""Traces as MCAP: export, direct writing, crash safety, read back with the mcap library."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import py_trees
import pytest
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.interop.foxglove_topics import TOPICS, records_from_messages
from pirate_bt.interop.mcap_trace import (
    compact_mcap,
    export_mcap,
    read_mcap_messages,
    read_mcap_records,
)
from pirate_bt.trace import CommandRecord, TickExtras, TraceEvent, TraceRecorder
from tests.trace_support import wait_for_writers

ROOT = Path(__file__).resolve().parent.parent
LAYOUT = ROOT / "docs" / "foxglove" / "pirate.json"


def _jsonl(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def _library_messages(path: Path) -> list[tuple[str, dict[str, Any]]]:
    """Every message as the mcap library's indexed reader gives it, in log-time order."""
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        return [
            (channel.topic, json.loads(message.data))
            for _, channel, message in reader.iter_messages(log_time_order=False)
        ]


@pytest.fixture(scope="module")
def run_trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated PAB run traced as JSON Lines by ``pirate-bt run``."""
    path = tmp_path_factory.mktemp("run") / "run.jsonl"
    code = main(
        ["run", "trees/straight.yaml", "--param", "distance=0.2m", "--quiet", "--trace", str(path)]
    )
    assert code == 0
    return path


def test_export_keeps_every_record_and_field(run_trace: Path, tmp_path: Path) -> None:
    out = export_mcap(run_trace, tmp_path / "run.mcap")
    assert out == tmp_path / "run.mcap"
    original = _jsonl(run_trace)
    # The mcap library's own (indexed, seeking) reader sees every topic on its own channel.
    with open(out, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.chunk_indexes  # chunked and indexed
        topics = {channel.topic for channel in summary.channels.values()}
        assert topics == set(TOPICS)
        for channel in summary.channels.values():
            assert channel.message_encoding == "json"
            schema = summary.schemas[channel.schema_id]
            assert schema.encoding == "jsonschema"
            assert json.loads(schema.data)["type"] == "object"
    rebuilt = list(records_from_messages(_library_messages(out)))
    assert rebuilt == original
    assert read_mcap_records(out) == original


def test_log_times_follow_the_run_clock(run_trace: Path, tmp_path: Path) -> None:
    from datetime import datetime

    out = export_mcap(run_trace, tmp_path / "run.mcap")
    header = _jsonl(run_trace)[0]
    start_ns = int(datetime.fromisoformat(header["created_utc"]).timestamp()) * 10**9
    with open(out, "rb") as stream:
        for _, _channel, message in make_reader(stream).iter_messages(topics=["/pirate/state"]):
            data = json.loads(message.data)
            assert message.log_time == start_ns + round(data["t_s"] * 1e9)
    # The state topic holds every value, nested, for plots: joints, clamps, speed, rotation.
    state = [m for t, m in read_mcap_messages(out)[0] if t == "/pirate/state"][-1]
    assert set(state["joint_angle_rad"]) >= {"bend_1", "bend_2", "bend_3", "bend_4"}
    assert "bend_1" in state["clamp_force_n"]
    assert isinstance(state["speed_mps"], float) and "rotation_rad" in state


def _rich_trace(path: Path) -> None:
    """A trace using every record member: refusals, events, blackboard unset, nan, full state."""
    from pirate_bt.robot.state import RobotState

    root = py_trees.composites.Sequence(
        "root",
        memory=True,
        children=[py_trees.behaviours.Success("a"), py_trees.behaviours.Running("b")],
    )
    tree = py_trees.trees.BehaviourTree(root)
    board = py_trees.blackboard.Client(name="test")
    board.register_key("goal", access=py_trees.common.Access.WRITE)
    with TraceRecorder(path, tree, every_tick=True, full_state=False) as recorder:
        for n in range(6):
            if n == 1:
                board.set("goal", {"x": 1.5})
            if n == 3:
                board.unset("goal")
            tree.tick()
            state = RobotState(
                stamp_s=n * 0.1,
                readings={},
                joint_angle_rad={"bend_1": 0.1 * (n // 2), "bend_2": float("nan")},
                clamp_force_n={"bend_1": 3.0},
                drive_velocity_mps={"bend_1_drive": 0.01 * (n // 2)},
                rotation_rad=0.0,
            )
            commands = (
                CommandRecord("clamp(front, 9 N·m)", "refuse", "torque_limit", "too much"),
                CommandRecord("drive(0.02)", "pass", sent=(("bend_1_drive", "velocity", 0.02),)),
            )
            recorder.record_tick(
                TickExtras(
                    state=state,
                    commands=commands if n in (1, 3) else (),
                    sim={"distance_m": (n // 2) * 0.01, "task.belief_m": 1.0 + n // 2},
                    events=(TraceEvent("fault", "motor stall", "0.1"),) if n == 4 else (),
                )
            )


def test_every_member_survives_the_round_trip(tmp_path: Path) -> None:
    trace = tmp_path / "rich.jsonl.gz"
    _rich_trace(trace)
    import gzip

    with gzip.open(trace, "rt") as stream:
        original = [json.loads(line) for line in stream]
    assert any("bb_unset" in r for r in original) and any("events" in r for r in original)
    assert any(r.get("type") == "tick" and set(r) == {"type", "n", "t_s"} for r in original)
    out = export_mcap(trace, tmp_path / "rich.mcap")
    assert list(records_from_messages(_library_messages(out))) == original
    topics = [t for t, _ in read_mcap_messages(out)[0]]
    assert {"/pirate/log", "/pirate/localisation", "/pirate/blackboard", "/pirate/tick"} <= set(
        topics
    )
    logs = [m for t, m in read_mcap_messages(out)[0] if t == "/pirate/log"]
    assert any(m["level"] == 3 and "refused" in m["message"] for m in logs)  # warning
    assert any(m["level"] == 4 and m["message"].startswith("fault: motor stall") for m in logs)


def test_direct_mcap_holds_what_jsonl_holds(tmp_path: Path) -> None:
    args = ["run", "trees/straight.yaml", "--param", "distance=0.2m", "--quiet", "--trace"]
    assert main([*args, str(tmp_path / "run.jsonl")]) == 0
    assert main([*args, str(tmp_path / "run.mcap")]) == 0
    jsonl = _jsonl(tmp_path / "run.jsonl")
    direct = list(records_from_messages(_library_messages(tmp_path / "run.mcap")))
    for record in (jsonl[0], direct[0]):
        record.pop("created_utc")
    assert direct == jsonl
    assert not list(tmp_path.glob(".*.part"))  # compacted in place, nothing left beside it


@pytest.fixture(scope="module")
def mission_mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first 40 s of the lab mission, written as MCAP by ``pirate-bt mission --trace``."""
    out = tmp_path_factory.mktemp("mission") / "m.mcap"
    code = main(["mission", "scenarios/lab.route", "--sim", "lab", "--quiet", "--max-time", "40 s",
                 "--trace", str(out)])  # fmt: skip
    assert code == 1  # stopped by the time limit, safely
    return out


def test_mission_writes_mcap_with_belief_and_truth(mission_mcap: Path) -> None:
    out = mission_mcap
    belief = [m for t, m in _library_messages(out) if t == "/pirate/localisation"]
    assert belief and {"belief_m", "truth_m", "error_m"} <= set(belief[-1])
    assert [t for t, _ in _library_messages(out)].count("/pirate/run") == 1


_KILLED = textwrap.dedent(
    """
    import sys, py_trees
    from pirate_bt.robot.state import RobotState
    from pirate_bt.trace import TickExtras, TraceRecorder
    root = py_trees.behaviours.Running("spin")
    rec = TraceRecorder(sys.argv[1], root)
    n = 0
    while True:
        n += 1
        root.tick_once()
        rec.record_tick(TickExtras(state=RobotState(stamp_s=n * 0.01, readings={},
                                                    joint_angle_rad={"bend_1": n * 0.001})))
        print(n, flush=True)
    """
)


def test_sigkill_keeps_every_complete_tick(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILLED, str(path)], stdout=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    last = 0
    while last < 300:
        last = int(proc.stdout.readline())
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    # The writer process outlives the run and writes every tick handed over (as for .jsonl).
    wait_for_writers(path)
    # The mcap library's stream reader reads the file without a summary record by record.
    with open(path, "rb") as stream, pytest.raises(Exception):  # noqa: B017 - the cut end
        for _ in StreamReader(stream).records:
            pass
    messages, cut = read_mcap_messages(path)
    assert cut
    records = list(records_from_messages(messages))
    ticks = [r["n"] for r in records if r["type"] == "tick"]
    assert ticks[:last] == list(range(1, last + 1))  # every tick reported done is on disk
    assert records[-1]["state"] == {"joint_angle_rad.bend_1": round(ticks[-1] * 0.001, 6)}
    # Recovered into an indexed file the mcap library's seeking reader opens.
    fixed = compact_mcap(path, tmp_path / "fixed.mcap")
    assert list(records_from_messages(_library_messages(fixed))) == records


def test_export_of_a_bad_trace_writes_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.jsonl"
    good = ROOT / "tests" / "data"
    lines = [
        json.dumps({"type": "header", "format": "pirate-bt-trace", "version": 1, "tree": {}}),
        '{"type":"tick","n":1,"t_s":0.0}',
        "this is no record",
        '{"type":"tick","n":2,"t_s":0.1}',
    ]
    bad.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.mcap"
    with pytest.raises(InputError, match=r"bad\.jsonl:3"):
        export_mcap(bad, out)
    assert not out.exists() and not list(tmp_path.glob(".*.part"))
    del good
    (tmp_path / "notrace.jsonl").write_text('{"type":"tick","n":1,"t_s":0}\n')
    with pytest.raises(InputError, match="no header"):
        export_mcap(tmp_path / "notrace.jsonl", out)
    assert not out.exists()


def test_missing_mcap_package_is_one_clear_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("mcap", "mcap.writer", "mcap.exceptions", "mcap.records", "mcap.stream_reader"):
        monkeypatch.setitem(sys.modules, name, None)  # import fails as if not installed
    out = tmp_path / "run.mcap"
    code = main(["run", "trees/straight.yaml", "--param", "distance=0.1m", "--quiet",
                 "--trace", str(out)])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == ["pirate-bt: MCAP needs the 'mcap' package: pip install 'pirate-bt[foxglove]'"]


# --- the Foxglove layout -----------------------------------------------------------


def _paths_in_layout(layout: dict[str, Any]) -> set[str]:
    """Every message path a panel of the layout reads (``/topic.field.sub``)."""
    found: set[str] = set()

    def walk(value: Any) -> None:
        if isinstance(value, dict):
            for key, inner in value.items():
                keyed = key in ("value", "topicPath", "topicToRender")
                if keyed and isinstance(inner, str) and inner.startswith("/"):
                    found.add(inner)
                walk(inner)
        elif isinstance(value, list):
            for inner in value:
                walk(inner)

    walk(layout["configById"])
    return found


def _resolve(messages: list[dict[str, Any]], path: str) -> bool:
    """Whether some message has the field path (``a.b``; ``[:]`` and ``{...}`` filters)."""
    import re

    parts = [p for p in re.sub(r"\{[^}]*\}", "", path).replace("[:]", "").split(".") if p]
    for message in messages:
        value: Any = message
        for part in parts:
            if isinstance(value, list):
                value = value[0] if value else None
            if not isinstance(value, dict) or part not in value:
                break
            value = value[part]
        else:
            return True
    return False


def test_layout_reads_only_what_a_run_publishes(mission_mcap: Path) -> None:
    layout = json.loads(LAYOUT.read_text())
    out = mission_mcap
    by_topic: dict[str, list[dict[str, Any]]] = {}
    for topic, message in _library_messages(out):
        by_topic.setdefault(topic, []).append(message)
    paths = _paths_in_layout(layout)
    assert len(paths) >= 10
    for path in paths:
        topic = next((t for t in TOPICS if path == t or path.startswith(t + ".")), None)
        assert topic is not None, f"{path}: no such topic"
        field = path[len(topic) :].lstrip(".")
        if field:
            assert _resolve(by_topic.get(topic, []), field), f"{path}: not in any message"


def test_trace_commands_read_an_mcap_file_as_they_read_jsonl(
    run_trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``trace summary``, ``show`` and ``plot`` take a ``.mcap`` file too, with the same text."""
    out = export_mcap(run_trace, tmp_path / "run.mcap")
    texts = []
    for path in (run_trace, out):
        assert main(["trace", "summary", str(path)]) == 0
        assert main(["trace", "show", str(path), "--tick", "5", "--ascii"]) == 0
        texts.append(capsys.readouterr().out.replace(str(path), "TRACE"))
    assert texts[0] == texts[1]
    assert main(["trace", "plot", str(out), "-o", str(tmp_path / "run.png")]) == 0
    assert (tmp_path / "run.png").stat().st_size > 0


def _data_end(data: bytes) -> int:
    """Where an MCAP file's data section ends: just after its DataEnd record (0x0F)."""
    pos = 8  # the magic
    while pos + 9 <= len(data):
        opcode, length = data[pos], int.from_bytes(data[pos + 1 : pos + 9], "little")
        pos += 9 + length
        if opcode == 0x0F:
            return pos
    raise AssertionError("no DataEnd record")


def test_an_mcap_cut_after_its_end_record_is_not_called_cut_before_it(
    run_trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A file cut after its data (the summary section and footer lost) still holds the
    # run's end record: the summary said "no end record: the run was cut off".
    whole = export_mcap(run_trace, tmp_path / "run.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: _data_end(whole)])
    assert main(["trace", "summary", str(cut)]) == 0
    outcome = next(line for line in capsys.readouterr().out.splitlines() if "outcome" in line)
    assert "no end record" not in outcome
    assert outcome.endswith("(the file is cut off after the run's end record)")
