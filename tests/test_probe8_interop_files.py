"""Probe 8, interop (continued): traces and other tools' files a hand or a foreign tool made
(regressions of the bugs found; tests/test_probe8_interop.py holds the first ones)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pirate_bt.cli import main
from tests.trace_support import run_and_record


@pytest.mark.parametrize(
    "command",
    [
        ["trace", "summary", "{t}"],
        ["trace", "show", "{t}", "--tick", "1"],
        ["trace", "show", "{t}"],
        ["render", "trees/straight.yaml", "--trace", "{t}", "--tick", "1", "-o", "{o}"],
    ],
    ids=["summary", "show-tick", "show", "render"],
)
def test_a_tick_whose_status_is_no_status_code_is_a_located_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str]
) -> None:
    # the reader took any JSON as a status: `trace summary` said nothing, `trace show`
    # and `render --trace` ended with "internal error: TypeError: unhashable type"
    # or "KeyError: 5", exit 1
    source = tmp_path / "good.jsonl"
    run_and_record(source, ticks=3)
    lines = source.read_text().splitlines()
    tick = json.loads(lines[1])
    first = next(iter(tick["status"]))
    tick["status"][first] = ["R"]
    lines[1] = json.dumps(tick)
    trace = tmp_path / "bad.jsonl"
    trace.write_text("\n".join(lines) + "\n")
    root = Path(__file__).resolve().parent.parent
    argv = [a.format(t=trace, o=tmp_path / "out.svg") if "{" in a else a for a in command]
    argv = [str(root / a) if a.startswith("trees/") else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"bad.jsonl:2:1: bad tick record: ValueError: node '{first}': status ['R']" in err
    assert "internal error" not in err


def test_a_summary_of_a_header_whose_robot_is_no_object_says_what_it_can(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # "internal error: AttributeError: 'str' object has no attribute 'get'", exit 1
    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=3)
    lines = source.read_text().splitlines()
    header = json.loads(lines[0])
    header["robot"] = "abc"
    lines[0] = json.dumps(header)
    source.write_text("\n".join(lines) + "\n")
    assert main(["trace", "summary", str(source)]) == 0
    out = capsys.readouterr().out
    assert "outcome" in out and "robot " not in out


@pytest.mark.parametrize(
    ("record", "field", "value", "said"),
    [
        (-1, "n", None, "bad end record: n is a whole number"),
        (-1, "t_s", {}, "bad end record: n is a whole number"),
        (-1, "outcome", 3, "bad end record: n is a whole number"),
        (
            1,
            "commands",
            "abc",
            'bad tick record: ValueError: commands is a list of objects, not "abc"',
        ),
        (1, "commands", [1], "bad tick record: ValueError: commands is a list of objects, not [1]"),
    ],
    ids=["end-n-null", "end-t-object", "end-outcome-number", "commands-text", "commands-numbers"],
)
def test_a_record_member_of_the_wrong_kind_is_a_located_error(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    record: int,
    field: str,
    value: object,
    said: str,
) -> None:
    # "internal error: TypeError: int() argument must be ... not 'NoneType'" (trace
    # summary, trace show) and "AttributeError: 'str' object has no attribute 'get'"
    source = tmp_path / "run.jsonl"
    run_and_record(source, ticks=3)
    lines = source.read_text().splitlines()
    changed = json.loads(lines[record])
    changed[field] = value
    lines[record] = json.dumps(changed)
    source.write_text("\n".join(lines) + "\n")
    line = record % len(lines) + 1
    for command in (["trace", "summary", str(source)], ["trace", "show", str(source)]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert f"run.jsonl:{line}:1: {said}" in err, err


def test_a_tree_groot2_cannot_be_shown_is_found_so_once(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    # every request (Groot2 polls the statuses ten times a second) made the tree's XML
    # again and logged a traceback: a 70,000-node tree cost 0.4 s of the server's
    # thread a request, and filled the run's log
    zmq = pytest.importorskip("zmq")
    pytest.importorskip("msgpack")
    import py_trees

    from pirate_bt.interop import groot2_protocol as proto
    from pirate_bt.interop import groot2_run
    from pirate_bt.interop.groot2_server import Groot2Server

    made = []

    def too_large(*args: object) -> object:
        made.append(1)
        raise ValueError("the tree has 70001 nodes; BehaviorTree.CPP numbers at most 65535")

    monkeypatch.setattr(groot2_run, "served_tree", too_large)
    with Groot2Server(port=0) as server:
        server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
        context = zmq.Context()
        try:
            req = context.socket(zmq.REQ)
            req.setsockopt(zmq.RCVTIMEO, 20000)
            req.setsockopt(zmq.LINGER, 0)
            req.connect(f"tcp://127.0.0.1:{server.port}")
            replies = []
            for kind in "TSSSB":
                req.send_multipart([proto.pack_request(ord(kind)), *([b""] if kind == "B" else [])])
                replies.append(req.recv_multipart())
        finally:
            context.destroy(linger=0)
    assert made == [1]
    assert all(
        r
        == [
            b"error",
            b"cannot serve this tree: the tree has 70001 nodes;"
            b" BehaviorTree.CPP numbers at most 65535",
        ]
        for r in replies
    ), replies
    assert sum("cannot serve this tree" in r.getMessage() for r in caplog.records) == 1
