"""Probe 17: files, traces, interop and the command line, as a hostile but
realistic user meets them. Every bad input is one line naming the file (and
line and column, or the node); nothing is left half-written."""

from __future__ import annotations

from pathlib import Path

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.trace import TraceRecorder, read_trace

ROOT = Path(__file__).resolve().parents[1]


class _Says(py_trees.behaviour.Behaviour):
    def update(self) -> py_trees.common.Status:
        self.feedback_message = "loaded \ud800.yaml"  # half a UTF-16 pair: no character
        return py_trees.common.Status.SUCCESS


def test_half_a_utf16_pair_in_an_mcap_trace_reads_as_a_replacement_character(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The .jsonl reader mended it; an .mcap trace ended trace summary and show with
    # "internal error: UnicodeEncodeError: ... surrogates not allowed".
    pytest.importorskip("mcap")
    root = py_trees.composites.Sequence("r\udc00oot", memory=True, children=[_Says("says")])
    tree = py_trees.trees.BehaviourTree(root)
    path = tmp_path / "run.mcap"
    with TraceRecorder(path, tree, background=False) as recorder:
        tree.add_post_tick_handler(recorder.post_tick_handler())
        tree.tick()
    trace = read_trace(path)
    assert trace.nodes() == ["r\ufffdoot", "r\ufffdoot/says"]
    assert trace.feedback("says")[-1].message == "loaded \ufffd.yaml"
    for argv in (["summary", str(path)], ["show", str(path), "--tick", "1"]):
        assert main(["trace", *argv]) == 0
        out = capsys.readouterr().out
        assert "r\ufffdoot" in out
        out.encode()  # what a terminal is sent: raised UnicodeEncodeError
