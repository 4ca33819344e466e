"""Traces as BT.CPP FileLogger2 logs, compared with the log BT.CPP itself writes.

A pure-logic tree runs under pirate_bt with a trace; the same tree is then
built in BehaviorTree.CPP (Python bindings) from the log's XML, its leaves
return, tick by tick, the statuses the trace recorded, and BT.CPP's own
``FileLogger`` writes a ``.btlog``. Ours must have the same header, the same
tree with the same node UIDs, and the same status transitions (BT.CPP also
logs the resets to IDLE that py_trees does not have; timestamps differ).
"""

from __future__ import annotations

import subprocess
import sys
import types
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.interop.btcpp import node_models
from pirate_bt.interop.btlog import MAGIC, read_btlog
from pirate_bt.trace.reader import read_trace

ROOT = Path(__file__).resolve().parent.parent
REPLAY = ROOT / "tests" / "data" / "btcpp" / "replay.yaml"
CODES = {"I": 0, "R": 1, "S": 2, "F": 3}


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp("btlog")
    trace, log = folder / "run.jsonl", folder / "run.btlog"
    assert main(["run", str(REPLAY), "--trace", str(trace), "--quiet"]) == 0
    assert main(["trace", "export", str(trace), "-o", str(log)]) == 0
    return trace, log


def _btcpp_log(trace_path: Path, xml: str, out: Path) -> Any:
    """BT.CPP's own log of the same tree, its leaves replaying the trace's statuses.

    In a Python of its own (``tests/btlog_oracle.py``), which waits for BT.CPP's
    FileLogger2 thread to write what it queued: its destructor stops the thread
    without emptying the queue, and fresh-clone CI runs read logs holding the header
    only when the replay was over before the thread first ran.
    """
    pytest.importorskip("behaviortreepy")
    xml_path = out.with_suffix(".xml")
    xml_path.write_text(xml, encoding="utf-8")
    done = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tests" / "btlog_oracle.py"),
            str(trace_path),
            str(xml_path),
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return read_btlog(out)


def _changes(transitions: Any) -> list[tuple[int, int]]:
    """(uid, status) of each change of a node's status, resets to IDLE left out.

    BT.CPP sets nodes back to IDLE when their parent finishes or re-ticks them (a
    reactive fallback resets a failed child and ticks it again: FAILURE, IDLE,
    FAILURE); py_trees keeps the last status, and a trace records changes only.
    What must match is every change a node's status goes through.
    """
    last: dict[int, int] = {}
    out: list[tuple[int, int]] = []
    for t in transitions:
        if t.status == 0 or last.get(t.uid) == t.status:
            continue
        last[t.uid] = t.status
        out.append((t.uid, t.status))
    return out


def _tree_shape(xml: str) -> list[tuple[str, str | None, str | None]]:
    tree = ET.fromstring(xml).find("BehaviorTree")
    assert tree is not None
    return [(e.tag, e.get("name"), e.get("_uid")) for e in tree.iter() if e is not tree]


def test_btlog_matches_the_log_bt_cpp_writes_for_the_same_run(
    run: tuple[Path, Path], tmp_path: Path
) -> None:
    trace_path, log_path = run
    ours = read_btlog(log_path)
    theirs = _btcpp_log(trace_path, ours.xml, tmp_path / "bt.btlog")
    assert (
        log_path.read_bytes()[: len(MAGIC) + 1]
        == (tmp_path / "bt.btlog").read_bytes()[: len(MAGIC) + 1]
    )
    # the same nodes, the same names, the UIDs BT.CPP assigns to the same XML
    assert _tree_shape(ours.xml) == _tree_shape(theirs.xml)
    # the same status changes in the same order
    assert _changes(ours.transitions) == _changes(theirs.transitions)
    assert len(ours.transitions) >= len(_changes(ours.transitions))
    assert not ours.truncated and not theirs.truncated


def test_btlog_holds_every_status_change_of_the_trace_at_its_time(run: tuple[Path, Path]) -> None:
    trace_path, log_path = run
    trace = read_trace(trace_path)
    log = read_btlog(log_path)
    uid = {n.id: i for i, n in enumerate(trace.structure, start=1)}
    final: dict[int, int] = {}
    for t in log.transitions:
        final[t.uid] = t.status
    last = trace.frame_at(trace.last_tick).status
    assert final == {uid[k]: CODES[v] for k, v in last.items() if v != "I"}
    times = [t.time_us for t in log.transitions]
    assert times == sorted(times)
    assert times[-1] == round(trace.ticks[-1].t_s * 1e6)
    assert log.start_us > 1_600_000_000 * 10**6  # the trace's creation time, in µs


def test_btlog_tree_is_parsed_by_bt_cpp(run: tuple[Path, Path]) -> None:
    bt = pytest.importorskip("behaviortreepy")
    factory = bt.BehaviorTreeFactory()
    for model in node_models().values():
        if model.category == "Action":
            factory.register_simple_action(model.id, lambda node: bt.NodeStatus.SUCCESS)
    factory.register_behavior_tree_from_text(read_btlog(run[1]).xml)
    assert factory.registered_behavior_trees() == [read_trace(run[0]).structure.name]


def test_export_picks_the_format_by_suffix(
    run: tuple[Path, Path], tmp_path: Path, capsys: Any, monkeypatch: Any
) -> None:
    trace_path, _ = run
    assert main(["trace", "export", str(trace_path), "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"pirate-bt: {tmp_path / 'x.csv'}: unknown export format '.csv'; known: .btlog, .mcap,"
        " or a rosbag2 folder (a name ending in / or _bag)"
    )
    calls: list[tuple[Path, Path]] = []
    fake = types.ModuleType("pirate_bt.interop.mcap_trace")

    def export_mcap(trace: Path, out: Path) -> Path:
        calls.append((trace, out))
        return out

    fake.export_mcap = export_mcap  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "pirate_bt.interop.mcap_trace", fake)
    assert main(["trace", "export", str(trace_path), "-o", str(tmp_path / "run.MCAP")]) == 0
    assert calls == [(trace_path, tmp_path / "run.MCAP")]


def test_export_of_a_missing_or_broken_trace_is_one_line(tmp_path: Path, capsys: Any) -> None:
    out = tmp_path / "x.btlog"
    assert main(["trace", "export", str(tmp_path / "none.jsonl"), "-o", str(out)]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"type": "tick", "n": 1}\n{}\n')
    assert main(["trace", "export", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"pirate-bt: {bad}:1:") and "\n" not in err
    assert not out.exists()


def test_read_btlog_refuses_other_files(tmp_path: Path) -> None:
    from pirate_bt.errors import InputError

    other = tmp_path / "x.btlog"
    other.write_bytes(b"not a log at all, really")
    with pytest.raises(InputError, match=r"not a BehaviorTree\.CPP FileLogger2 log"):
        read_btlog(other)
    other.write_bytes(MAGIC + b"\x01" + (10_000).to_bytes(4, "little") + b"<root/>")
    with pytest.raises(InputError, match="does not fit the file"):
        read_btlog(other)
