"""Probe 18b: traces read back, queried and exported, as a user of traces meets them."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.errors import InputError
from pirate_bt.trace import read_trace
from pirate_bt.trace.reader import Trace

HEADER = {
    "type": "header",
    "format": "pirate-bt-trace",
    "version": 1,
    "tree": {
        "name": "pab",
        "nodes": [
            {
                "id": "0",
                "name": "pab",
                "type": "Sequence",
                "kind": "composite",
                "parent": None,
                "children": ["0.0"],
            },
            {
                "id": "0.0",
                "name": "clamp rear",
                "type": "Clamp",
                "kind": "leaf",
                "parent": "0",
                "children": [],
            },
        ],
    },
}


def write_trace(path: Path, records: list[dict[str, Any]]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in [HEADER, *records]), encoding="utf-8")
    return path


def flapping(tmp_path: Path, ticks: int) -> Trace:
    """A run whose leaf turns RUNNING and SUCCESS by turns, one change a tick."""
    records = [
        {
            "type": "tick",
            "n": n,
            "t_s": n * 0.01,
            "status": {"0": "R", "0.0": "R" if n % 2 else "S"},
            "state": {"rotation_rad": n * 1e-3},
        }
        for n in range(1, ticks + 1)
    ]
    records.append({"type": "end", "n": ticks, "t_s": ticks * 0.01, "outcome": "success"})
    return read_trace(write_trace(tmp_path / "flap.jsonl", records))


class Counted(list[Any]):
    """A list that counts the items read from it."""

    reads = 0

    def __iter__(self) -> Iterator[Any]:
        for item in super().__iter__():
            Counted.reads += 1
            yield item

    def __getitem__(self, index: Any) -> Any:
        Counted.reads += 1
        return super().__getitem__(index)


# -- queries over a long run are not quadratic


def test_status_at_over_every_tick_does_not_walk_the_history_each_time(tmp_path: Path) -> None:
    # status_at copied the node's whole list of changes and walked it at each call: a
    # loop over a 100,000-tick run's ticks took minutes
    trace = flapping(tmp_path, 1000)
    expected = ["INVALID"] + ["RUNNING" if n % 2 else "SUCCESS" for n in range(1, 1001)]
    index = trace._index()
    index.status["0.0"] = Counted(index.status["0.0"])
    Counted.reads = 0
    got = [trace.status_at("clamp rear", n) for n in range(1001)]
    assert got == expected
    assert Counted.reads < 30 * 1001  # a search per call (it read 500,000 changes)


def test_first_tick_does_not_walk_the_history(tmp_path: Path) -> None:
    trace = flapping(tmp_path, 1000)
    index = trace._index()
    index.status["0.0"] = Counted(index.status["0.0"])
    Counted.reads = 0
    for _ in range(100):
        assert trace.first_tick("clamp rear", "FAILURE") is None
        assert trace.first_tick("clamp rear", "success") == 2
        assert trace.first_tick("pab", "RUNNING") == 1
        assert trace.first_tick("clamp rear", "INVALID") == 0
    assert Counted.reads < 1000  # it read every change for each call


def test_frame_at_over_every_tick_replays_the_run_once(tmp_path: Path) -> None:
    # frame_at replayed the run from its start (a copy of every value at every tick on
    # the way) at each call: `trace show`/`render --tick` per tick was quadratic
    trace = flapping(tmp_path, 1000)
    whole = {frame.n: frame for frame in trace.frames()}
    trace.ticks = Counted(trace.ticks)
    Counted.reads = 0
    for n in range(1001):
        assert trace.frame_at(n) == whole[n]
    assert Counted.reads < 10 * 1001  # was half a million
    assert trace.frame_at(3) == whole[3]  # and back again
    assert trace.frame_at(0) == whole[0]


def test_frame_at_of_a_tick_that_wrote_no_record_is_the_last_one_renumbered(
    tmp_path: Path,
) -> None:
    records = [
        {"type": "tick", "n": 1, "t_s": 0.01, "status": {"0": "R", "0.0": "R"}},
        {"type": "tick", "n": 4, "t_s": 0.04, "status": {"0.0": "S"}, "events": [{"kind": "note"}]},
        {"type": "end", "n": 6, "t_s": 0.06, "outcome": "success"},
    ]
    trace = read_trace(write_trace(tmp_path / "gaps.jsonl", records))
    for n, t_s, leaf in [(5, 0.04, "S"), (2, 0.01, "R"), (0, 0.0, "I"), (6, 0.04, "S")]:
        frame = trace.frame_at(n)
        assert (frame.n, frame.t_s, frame.status["0.0"], frame.events) == (n, t_s, leaf, ())
    assert trace.frame_at(4).events == ({"kind": "note"},)
    with pytest.raises(ValueError, match="no tick 7"):
        trace.frame_at(7)


# -- a record of a type no trace holds


def annotated(tmp_path: Path) -> Path:
    records = [
        {"type": "tick", "n": 1, "t_s": 0.01, "status": {"0": "R", "0.0": "R"}},
        {"type": "annotation", "n": 1, "text": "from a newer writer"},
        {"type": "end", "n": 1, "t_s": 0.01, "outcome": "success"},
    ]
    return write_trace(tmp_path / "run.jsonl", records)


def test_an_unknown_record_type_is_named_once_quoted(tmp_path: Path) -> None:
    # it said: unknown record type "'annotation'"
    trace = annotated(tmp_path)
    with pytest.raises(InputError) as caught:
        read_trace(trace)
    assert str(caught.value).startswith(f"{trace}:3:1: unknown record type 'annotation':")


@pytest.mark.parametrize("target", ["out.mcap", "out_bag"])
def test_every_export_refuses_an_unknown_record_as_read_trace_does(
    tmp_path: Path, target: str, capsys: pytest.CaptureFixture[str], monkeypatch: Any
) -> None:
    # the rosbag2 export wrote a bag of it (exit 0); the .mcap export said "cannot
    # convert this record: not a trace record type" without the column
    from pirate_bt.cli import main

    trace = annotated(tmp_path)
    monkeypatch.chdir(tmp_path)
    assert main(["trace", "export", str(trace), "-o", target]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"pirate-bt: {trace}:3:1: unknown record type 'annotation':"
        " a trace holds a header, ticks and an end"
    )
    assert not (tmp_path / target).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.jsonl"]


# -- names and messages with control characters


def test_summary_and_show_keep_a_name_with_control_characters_on_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a node named with a line break, an escape sequence, a NUL or a right-to-left
    # override (a tree built in Python, a hand-made trace) broke the summary's row in
    # two and recoloured the terminal; a feedback message in `show` the same
    from pirate_bt.cli import main

    header = json.loads(json.dumps(HEADER))
    header["tree"]["nodes"][1]["name"] = "clamp\x1b[31m rear\nhalf\t\x00\u202e"
    records = [
        {
            "type": "tick",
            "n": 1,
            "t_s": 0.01,
            "status": {"0": "R", "0.0": "F"},
            "feedback": {"0.0": "stalled\r\x1b[2Jgone"},
            "bb": {"key\nx": "v\x07"},
        },
        {"type": "end", "n": 1, "t_s": 0.01, "outcome": "failure", "reason": "why\nnot"},
    ]
    path = tmp_path / "ctl.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in [header, *records]), encoding="utf-8")
    assert main(["trace", "summary", str(path)]) == 0
    summary = capsys.readouterr().out
    assert main(["trace", "show", str(path), "--state"]) == 0
    show = capsys.readouterr().out
    for text in (summary, show):
        assert not any(c in text for c in "\x1b\x00\r\t\x07\u202e")
    rows = summary.splitlines()
    assert any(r.startswith("    clamp\\x1b[31m rear\\nhalf\\t\\x00\\u202e  ") for r in rows)
    assert "why       why\\nnot" in rows
    assert any(r.endswith("[Clamp]  FAILURE  -- stalled\\r\\x1b[2Jgone") for r in show.splitlines())
    assert '  key\\nx = "v\\u0007"' in show.splitlines()


# -- .btlog export


def test_btlog_export_of_a_tree_too_wide_names_the_trace(tmp_path: Path) -> None:
    # it said only "the tree has 65536 nodes; ...", naming no file
    from pirate_bt.interop.btlog import export_btlog

    leaves = [
        {"id": f"0.{i}", "name": f"w{i}", "type": "Wait", "kind": "leaf", "parent": "0"}
        for i in range(65535)
    ]
    root = {
        "id": "0",
        "name": "wide",
        "type": "Sequence",
        "kind": "composite",
        "parent": None,
        "children": [leaf["id"] for leaf in leaves],
    }
    header = {**HEADER, "tree": {"name": "wide", "nodes": [root, *leaves]}}
    for leaf in leaves:
        leaf["children"] = []
    path = tmp_path / "wide.jsonl"
    path.write_text(json.dumps(header) + "\n", encoding="utf-8")
    with pytest.raises(InputError) as caught:
        export_btlog(path, tmp_path / "wide.btlog")
    assert str(caught.value) == (
        f"{path}: the tree has 65536 nodes; BehaviorTree.CPP (a .btlog, Groot2)"
        " numbers at most 65535"
    )
    assert not (tmp_path / "wide.btlog").exists()


def test_btlog_export_of_a_tick_before_the_start_says_so(tmp_path: Path) -> None:
    # a wall clock set back: t_s may go back, below 0; it said "beyond a .btlog"
    from pirate_bt.interop.btlog import export_btlog

    records = [
        {"type": "tick", "n": 1, "t_s": 0.5, "status": {"0": "R", "0.0": "R"}},
        {"type": "tick", "n": 2, "t_s": -0.25, "status": {"0.0": "S"}},
    ]
    path = write_trace(tmp_path / "back.jsonl", records)
    with pytest.raises(InputError) as caught:
        export_btlog(path, tmp_path / "back.btlog")
    assert str(caught.value) == (
        f"{path}: tick 2 at -0.25 s is before the run's start; a .btlog holds no time before it"
    )


# -- why: the run's first cause, as the run's result said it


@pytest.mark.parametrize("message", ["plain broke\nsecond line", "  tabs\tand\r\nbreaks  "])
def test_why_of_a_crash_whose_message_has_line_breaks_is_the_results(
    tmp_path: Path, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # the result folds the message's whitespace; the trace's why then said the
    # exception a second time: 'RuntimeError in boom: plain broke second line; boom:
    # RuntimeError: plain broke\nsecond line', and so did `trace summary`
    import py_trees

    import pirate_bt
    from pirate_bt.cli import main

    class Boom(py_trees.behaviour.Behaviour):
        def update(self) -> py_trees.common.Status:
            raise RuntimeError(message)

    path = tmp_path / "boom.jsonl"
    result = pirate_bt.simulate_tree(Boom("boom"), trace=path)
    assert result.why is not None and result.why.startswith("RuntimeError in boom: ")
    assert read_trace(path).why == result.why
    capsys.readouterr()
    assert main(["trace", "summary", str(path)]) == 0
    assert f"why       {result.why}" in capsys.readouterr().out.splitlines()


def test_summary_why_of_a_long_message_is_the_results_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the result leaves the middle of a why over 1000 characters out; the summary
    # printed the trace's whole 20,000 characters (the trace keeps them: Trace.why)
    import py_trees

    import pirate_bt
    from pirate_bt.cli import main

    class Boom(py_trees.behaviour.Behaviour):
        def update(self) -> py_trees.common.Status:
            raise RuntimeError("x" * 20000 + " the end")

    path = tmp_path / "long.jsonl"
    result = pirate_bt.simulate_tree(Boom("boom"), trace=path)
    assert result.why is not None and "characters)..." in result.why
    assert read_trace(path).why == "RuntimeError in boom: " + "x" * 20000 + " the end"
    capsys.readouterr()
    assert main(["trace", "summary", str(path)]) == 0
    assert f"why       {result.why}" in capsys.readouterr().out.splitlines()


# -- a named pipe given as a trace


def _writer_once(fifo: Path) -> Any:
    """A thread that opens ``fifo`` for writing (when a reader opens it) and closes it:
    a reader that opens the pipe then reads an empty file, where it would wait."""
    import threading

    thread = threading.Thread(target=lambda: open(fifo, "wb").close(), daemon=True)
    thread.start()
    return thread


def _release(fifo: Path, thread: Any) -> None:
    import os

    if thread.is_alive():  # nobody opened it (as it should be): let the writer go
        descriptor = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        thread.join(5)
        os.close(descriptor)


@pytest.mark.parametrize("name", ["run.mcap", "run.jsonl"])
def test_a_named_pipe_is_refused_in_every_trace_format(tmp_path: Path, name: str) -> None:
    # an .mcap reader (its own __iter__) opened the pipe and waited on it for ever
    import os

    fifo = tmp_path / name
    os.mkfifo(fifo)
    thread = _writer_once(fifo)
    try:
        with pytest.raises(InputError) as caught:
            read_trace(fifo)
    finally:
        _release(fifo, thread)
    assert str(caught.value) == f"{fifo}: cannot read trace: it is a named pipe, not a file"


def test_read_btlog_refuses_a_named_pipe(tmp_path: Path) -> None:
    import os

    from pirate_bt.interop.btlog import read_btlog

    fifo = tmp_path / "run.btlog"
    os.mkfifo(fifo)
    thread = _writer_once(fifo)
    try:
        with pytest.raises(InputError) as caught:
            read_btlog(fifo)
    finally:
        _release(fifo, thread)
    assert str(caught.value) == f"{fifo}: cannot read: it is a named pipe, not a file"


def test_frame_at_reads_the_ticks_the_trace_holds_now(tmp_path: Path) -> None:
    # frame_at goes on from its last call; ticks cut or replaced start it again
    trace = flapping(tmp_path, 20)
    assert trace.frame_at(15).state["rotation_rad"] == 0.015
    trace.ticks = trace.ticks[:10]
    assert trace.frame_at(12).state["rotation_rad"] == 0.01
    trace.ticks = [*trace.ticks, *flapping(tmp_path, 20).ticks[10:]]
    assert trace.frame_at(16).state["rotation_rad"] == 0.016


# -- TraceRecorder's options


@pytest.mark.parametrize(
    ("options", "said"),
    [
        ({"full_state": "no"}, "full_state: give True or False, not 'no'"),
        ({"sync": 1}, "sync: give True or False, not 1"),
        ({"background": "yes"}, "background: give True or False or None, not 'yes'"),
        ({"meta": [1]}, "meta: give a mapping of names to values or None, not a list"),
        ({"seed": "7"}, "seed: give a whole number or None, not a str"),
        ({"scenario": 5}, "scenario: give text or None, not an int"),
    ],
)
def test_trace_recorder_refuses_an_option_of_the_wrong_type_before_the_file(
    tmp_path: Path, options: dict[str, Any], said: str
) -> None:
    # full_state="no" recorded every value and wrote "no" into the header; meta=[1]
    # raised a bare TypeError and left an empty file (an "empty trace" when read)
    import py_trees

    from pirate_bt.errors import ArgumentTypeError
    from pirate_bt.trace import TraceRecorder

    path = tmp_path / "run.jsonl"
    with pytest.raises(ArgumentTypeError) as caught:
        TraceRecorder(path, py_trees.behaviours.Success("ok"), **options)
    assert str(caught.value) == said
    assert not path.exists()


def test_trace_recorder_takes_its_options_as_documented(tmp_path: Path) -> None:
    import py_trees

    from pirate_bt.trace import TraceRecorder

    path = tmp_path / "run.jsonl"
    options: dict[str, Any] = {"full_state": True, "sync": False, "background": None}
    with TraceRecorder(
        path, py_trees.behaviours.Success("ok"), seed=7, scenario="s", meta={"a": 1}, **options
    ) as recorder:
        recorder.record_tick()
    header = read_trace(path).header
    assert (header["full_state"], header["seed"], header["scenario"], header["meta"]) == (
        True,
        7,
        "s",
        {"a": 1},
    )


# -- a trace renamed .jsonl.gz


@pytest.mark.parametrize(
    ("start", "said"),
    [
        (b"", "a JSON Lines trace, not gzip-compressed: name it run.jsonl"),
        (b"\x89MCAP0\r\n", "an MCAP trace, not gzip-compressed: name it run.mcap"),
    ],
)
def test_a_trace_renamed_jsonl_gz_is_told_its_name(
    tmp_path: Path, start: bytes, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # it was "not readable as gzip after 0 lines: Not a gzipped file (b'{\"')", where a
    # gzip trace renamed .jsonl is told "name it run.jsonl.gz"
    from pirate_bt.cli import main

    text = write_trace(tmp_path / "x.jsonl", []).read_bytes()
    path = tmp_path / "run.jsonl.gz"
    path.write_bytes(start + text if start else text)
    assert main(["trace", "summary", str(path)]) == 2
    assert capsys.readouterr().err.strip() == f"pirate-bt: {path}: {said}"
