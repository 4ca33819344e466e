"""Trace files read back as real life leaves them: edited by hand or by other tools,
damaged, cut off. Every reader either reads what is there or refuses the file in
one line naming the file and the record's line; never a traceback or a wrong figure.
"""

from __future__ import annotations

import gzip
import json
import zlib
from pathlib import Path
from typing import Any

import py_trees
import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import LocatedError
from pirate_bt.trace import TraceRecorder, open_reader, read_trace

ROOT = Path(__file__).resolve().parents[1]

Records = list[dict[str, Any]]


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> Records:
    path = tmp_path_factory.mktemp("run") / "patrol.jsonl"
    pirate_bt.simulate_tree(ROOT / "trees" / "examples" / "patrol.yaml", trace=path)
    return [json.loads(line) for line in path.read_text().splitlines()]


def _write(path: Path, records: Records) -> Path:
    # Python's json writes NaN and Infinity, which JSON has not: as another tool would
    path.write_text("".join(json.dumps(r) + "\n" for r in records))
    return path


def _refused_everywhere(
    path: Path, line: int, problem: str, capsys: pytest.CaptureFixture[str], kind: str = ""
) -> None:
    with pytest.raises(LocatedError) as caught:
        read_trace(path)
    assert str(caught.value).startswith(f"{path}:{line}:1: {kind}"), caught.value
    assert problem in str(caught.value)
    out = path.with_name("out.png")
    for argv in (["summary", str(path)], ["plot", str(path), "-o", str(out)]):
        assert main(["trace", *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{path}:{line}:" in err[0] and problem in err[0], err
    assert not out.exists()


def _tick(records: Records, index: int, **changes: Any) -> Records:
    ticks = [i for i, r in enumerate(records) if r["type"] == "tick"]
    edited = [dict(r) for r in records]
    edited[ticks[index]].update(changes)
    return edited


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        # was read as tick 1 ("tick 1 does not follow tick 2", naming no real fault)
        ({"n": True}, "n is the tick's number, a whole number from 1, not true"),
        # was read as tick 2
        ({"n": 2.7}, "not 2.7"),
        ({"n": 0}, "a whole number from 1, not 0"),
        # read, and summed into the summary's times
        ({"t_s": float("nan")}, "t_s is the tick's time, a finite number of seconds, not NaN"),
        ({"t_s": float("inf")}, "not Infinity"),
        ({"t_s": "0.1"}, 'not "0.1"'),
        # ended trace summary with "internal error: AttributeError"
        ({"events": ["stalled", 5]}, 'events is a list of objects, not ["stalled", 5]'),
    ],
)
def test_a_tick_whose_number_time_or_events_are_no_such_thing_is_refused_on_its_line(
    records: Records,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: dict[str, Any],
    problem: str,
) -> None:
    path = _write(tmp_path / "run.jsonl", _tick(records, 1, **change))
    _refused_everywhere(path, 3, problem, capsys, "bad tick record: ")


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        # unset the keys "s", "t", "a", "r", "e" and "d" without a word
        ({"bb_unset": "started"}, 'bb_unset is a list of blackboard keys, not "started"'),
        ({"bb_unset": [1]}, "bb_unset is a list of blackboard keys, not [1]"),
        # read as the object {"connected": false}
        ({"link": [["connected", False]]}, 'link is an object, not [["connected", false]]'),
        ({"state": [1, 2]}, "state is an object, not [1, 2]"),
    ],
)
def test_a_tick_member_of_the_wrong_kind_is_refused_not_read_as_another(
    records: Records,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: dict[str, Any],
    problem: str,
) -> None:
    path = _write(tmp_path / "run.jsonl", _tick(records, 1, **change))
    _refused_everywhere(path, 3, problem, capsys, "bad tick record: ")


def test_an_end_record_with_a_time_of_nan_is_refused_not_a_duration_of_nan(
    records: Records, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Was: summary "duration  nan s"; plot "plot window from 0 s to nan s: give
    # finite numbers of seconds", blaming a window nobody gave.
    edited = [*records[:-1], {**records[-1], "t_s": float("nan")}]
    path = _write(tmp_path / "run.jsonl", edited)
    _refused_everywhere(path, len(edited), "bad end record: t_s is the run's time", capsys)


def test_an_end_record_before_the_last_tick_is_refused_not_a_run_cut_short(
    records: Records, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Was: summary "ticks 2" for a run of 15, and trace show refused ticks it holds.
    last = [r for r in records if r["type"] == "tick"][-1]["n"]
    edited = [*records[:-1], {**records[-1], "n": 2}]
    path = _write(tmp_path / "run.jsonl", edited)
    problem = f"bad end record: n 2, the run's last tick, is before tick {last}"
    _refused_everywhere(path, len(edited), problem, capsys)


def test_a_clock_set_back_and_a_tick_with_no_change_still_read(
    records: Records, tmp_path: Path
) -> None:
    # t_s is the caller's clock minus the start: a wall clock may go back.
    edited = _tick(records, 2, t_s=-0.5)
    trace = read_trace(_write(tmp_path / "run.jsonl", edited))
    assert trace.outcome == "success" and trace.ticks[2].t_s == -0.5


@pytest.mark.parametrize("suffix", [".btlog", ".mcap"])
def test_trace_export_refuses_such_an_end_record_as_read_trace_does(
    records: Records, tmp_path: Path, capsys: pytest.CaptureFixture[str], suffix: str
) -> None:
    # .mcap export converted it record by record and wrote the file (or, for a NaN
    # time, "cannot convert this record: cannot convert float NaN to integer").
    pytest.importorskip("mcap")
    edited = [*records[:-1], {**records[-1], "n": 2}]
    path = _write(tmp_path / "run.jsonl", edited)
    out = tmp_path / f"out{suffix}"
    assert main(["trace", "export", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}:{len(edited)}:1: bad end record: n 2" in err[0], err
    assert not out.exists()


class _Says(py_trees.behaviour.Behaviour):
    def update(self) -> py_trees.common.Status:
        self.feedback_message = "loaded \ud800.yaml"  # half a UTF-16 pair: no character
        return py_trees.common.Status.SUCCESS


def test_half_a_utf16_pair_that_the_writer_escaped_reads_as_a_replacement_character(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The writer writes it as the JSON escape "\ud800"; trace summary and show then
    # ended with "internal error: UnicodeEncodeError" printing it.
    root = py_trees.composites.Sequence("r\udc00oot", memory=True, children=[_Says("says")])
    tree = py_trees.trees.BehaviourTree(root)
    path = tmp_path / "run.jsonl"
    with TraceRecorder(path, tree, background=False) as recorder:
        tree.add_post_tick_handler(recorder.post_tick_handler())
        tree.tick()
    assert b"\\ud800" in path.read_bytes()
    trace = read_trace(path)
    assert trace.feedback("says")[-1].message == "loaded \ufffd.yaml"
    assert trace.nodes() == ["r\ufffdoot", "r\ufffdoot/says"]
    # the exports read the file as written, and convert the name as it is
    assert next(iter(open_reader(path)))[1]["tree"]["name"] == "r\udc00oot"
    for argv in (["summary", str(path)], ["show", str(path), "--tick", "1"]):
        assert main(["trace", *argv]) == 0
        out = capsys.readouterr().out
        assert "r\ufffdoot" in out
        out.encode()  # what a terminal is sent: raised UnicodeEncodeError


def test_bytes_that_are_no_utf8_are_refused_at_their_column(
    records: Records, tmp_path: Path
) -> None:
    path = tmp_path / "run.jsonl"
    header = json.dumps(records[0]).encode()
    at = header.index(b'"name"') + 9
    path.write_bytes(header[:at] + b"\xff" + header[at:] + b"\n")
    with pytest.raises(LocatedError) as caught:
        read_trace(path)
    assert str(caught.value).startswith(f"{path}:1:{at + 1}: not a trace record: ")  # was :1:1


@pytest.mark.parametrize(
    ("ticks", "said"),
    [
        (1, "nothing to plot: the run took no time (it ended at tick 1, at 0 s)"),
        (0, "nothing to plot: it holds no tick"),  # killed before its first tick
    ],
)
def test_plotting_a_run_that_took_no_time_says_so_not_a_window_nobody_gave(
    records: Records, tmp_path: Path, capsys: pytest.CaptureFixture[str], ticks: int, said: str
) -> None:
    # A tree that fails at its first tick (a condition) ends at 0 s: "plot window
    # from 0 s to 0 s is outside the trace (0 s to 0 s)", with no --from or --to.
    pytest.importorskip("matplotlib")
    first = {**records[1], "n": 1, "t_s": 0.0}
    end = {**records[-1], "n": 1, "t_s": 0.0}
    path = _write(tmp_path / "run.jsonl", [records[0], first, end] if ticks else records[:1])
    out = tmp_path / "run.png"
    out.write_bytes(b"the picture that was there")
    assert main(["trace", "plot", str(path), "-o", str(out)]) == 2
    assert capsys.readouterr().err.strip() == f"pirate-bt: {path}: {said}"
    assert out.read_bytes() == b"the picture that was there"


@pytest.mark.parametrize(
    ("version", "problem"),
    [
        (2, "trace format version 2 is newer than this reader (1); update pirate_bt"),
        # each was said to be "newer than this reader", or (0, true) read as version 1
        ("1", 'trace format version "1" is no version (a whole number from 1)'),
        (1.0, "trace format version 1.0 is no version"),
        (None, "trace format version null is no version"),
        (0, "trace format version 0 is no version"),
        (True, "trace format version true is no version"),
    ],
)
@pytest.mark.parametrize("suffix", [".mcap", "_bag"])
def test_a_header_of_a_version_this_reader_cannot_read_is_refused_by_every_export(
    records: Records,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    version: Any,
    problem: str,
    suffix: str,
) -> None:
    # trace export to .mcap and to a rosbag2 folder converted a version-2 trace as if
    # it were version 1, where summary, show, plot and .btlog export refused it.
    pytest.importorskip("mcap")
    if suffix == "_bag":
        pytest.importorskip("rosbags")
    path = _write(tmp_path / "run.jsonl", [{**records[0], "version": version}, *records[1:]])
    with pytest.raises(LocatedError, match="version"):
        read_trace(path)
    out = tmp_path / f"out{suffix}"
    assert main(["trace", "export", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"pirate-bt: {path}:1:1: {problem}") and "\n" not in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        # ended trace summary with "internal error: TypeError: 'str' object is not a mapping"
        ({"outcome": "error", "error": "boom"}, 'error is an object (node, exception), not "boom"'),
        # were dropped from the summary's "after the last tick" without a word
        ({"commands": "clamp(front)"}, 'commands is a list of objects, not "clamp(front)"'),
        ({"commands": ["clamp(front)"]}, 'commands is a list of objects, not ["clamp(front)"]'),
    ],
)
def test_an_end_record_whose_error_or_commands_are_no_such_thing_is_refused_on_its_line(
    records: Records,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    change: dict[str, Any],
    problem: str,
) -> None:
    edited = [*records[:-1], {**records[-1], **change}]
    path = _write(tmp_path / "run.jsonl", edited)
    _refused_everywhere(path, len(edited), problem, capsys, "bad end record: ")


@pytest.mark.parametrize("joined", ["two runs", "two ends"])
@pytest.mark.parametrize("out", ["", "out.btlog", "out.mcap"])
def test_two_traces_joined_into_one_file_are_refused_where_they_join(
    records: Records, tmp_path: Path, capsys: pytest.CaptureFixture[str], joined: str, out: str
) -> None:
    # `cat a.jsonl b.jsonl`: the second header was an "unknown record type 'header'";
    # a second end record (a failure after a success) replaced the first without a word
    # (summary: outcome failure), and .mcap export wrote both.
    if out.endswith(".mcap"):
        pytest.importorskip("mcap")
    second = records if joined == "two runs" else [{**records[-1], "outcome": "failure"}]
    path = _write(tmp_path / "run.jsonl", records + second)
    problem = (
        "a second header record: a trace holds one run (two files joined?)"
        if joined == "two runs"
        else f"a second end record (the first is on line {len(records)}): two files joined?"
    )
    argv = ["trace", "export", str(path), "-o", str(tmp_path / out)] if out else []
    assert main(argv or ["trace", "summary", str(path)]) == 2
    assert capsys.readouterr().err.strip() == f"pirate-bt: {path}:{len(records) + 1}:1: {problem}"
    assert not (tmp_path / out).is_file()


@pytest.mark.parametrize(
    ("start", "said"),
    [
        # was "run.jsonl:1:2: not a trace record: 'utf-8' codec can't decode byte 0x8b ..."
        (b"\x1f\x8b\x08\x00", "a gzip-compressed trace, not JSON Lines: name it run.jsonl.gz"),
        (b"\x89MCAP0\r\n", "an MCAP trace, not JSON Lines: name it run.mcap"),
    ],
)
def test_a_compressed_or_mcap_trace_named_jsonl_is_named_as_such(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], start: bytes, said: str
) -> None:
    path = tmp_path / "run.jsonl"
    path.write_bytes(start + bytes(range(256)))
    assert main(["trace", "summary", str(path)]) == 2
    assert capsys.readouterr().err.strip() == f"pirate-bt: {path}: {said}"


@pytest.mark.parametrize("out", ["out.mcap", "out_bag"])
@pytest.mark.parametrize("order", ["repeated", "backwards", "after the end"])
def test_export_refuses_ticks_out_of_order_as_read_trace_does(
    records: Records, tmp_path: Path, capsys: pytest.CaptureFixture[str], out: str, order: str
) -> None:
    # .mcap and rosbag2 exports wrote such a trace, which read_trace of their own
    # output (or of the .jsonl) then refused.
    pytest.importorskip("mcap")
    if out.endswith("_bag"):
        pytest.importorskip("rosbags")
    ticks = [r for r in records if r["type"] == "tick"]
    if order == "after the end":
        edited, line, problem = [*records, ticks[1]], len(records) + 1, "a tick after the end"
    else:
        stray = ticks[2] if order == "repeated" else ticks[0]
        edited = [*records[:4], stray, *records[4:]]
        line, problem = 5, f"tick {stray['n']} does not follow tick {ticks[2]['n']}"
    path = _write(tmp_path / "run.jsonl", edited)
    with pytest.raises(LocatedError, match=problem):
        read_trace(path)
    assert main(["trace", "export", str(path), "-o", str(tmp_path / out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"pirate-bt: {path}:{line}:1: {problem}") and "\n" not in err, err
    assert not (tmp_path / out).exists()


def test_a_header_over_16_mib_reads_as_the_tree_it_holds(records: Records, tmp_path: Path) -> None:
    # The header holds the tree: a tree file of 91,000 nodes 90 deep (within the
    # limits of 100,000 nodes, 100 deep) ran and wrote a 38 MB header, which every
    # reader refused as "a line longer than 16777216 bytes: not a trace".
    header = json.loads(json.dumps(records[0]))
    header["tree"]["nodes"][0]["name"] = "n" * (17 * 1024 * 1024)
    path = _write(tmp_path / "run.jsonl", [header, *records[1:]])
    trace = read_trace(path)
    assert trace.outcome == "success" and len(trace.node("0").name) > 16 * 1024 * 1024
    # a tick is no longer than that
    tick = {**records[1], "feedback": {"0": "x" * (17 * 1024 * 1024)}}
    _write(path, [records[0], tick, *records[2:]])
    with pytest.raises(LocatedError, match=r"run\.jsonl:2:1: a line longer than 16777216 bytes"):
        read_trace(path)


def _long_run(records: Records) -> list[bytes]:
    """The lines of a long run: the ticks of ``records`` forty times over, renumbered."""
    ticks = [r for r in records if r["type"] == "tick"] * 40
    ticks = [{**t, "n": n, "t_s": n * 0.05} for n, t in enumerate(ticks, start=1)]
    return [json.dumps(r).encode() + b"\n" for r in [records[0], *ticks, records[-1]]]


def test_a_jsonl_gz_whose_end_a_crash_filled_with_nuls_reads_as_cut_off_there(
    records: Records, tmp_path: Path
) -> None:
    # A machine that crashes saves the file's size but not its last blocks, which read
    # as NUL bytes. The trace cut off there read as cut off, every whole line; with the
    # NULs after it, it was "not readable as gzip after N lines" (N lines short too).
    whole = gzip.compress(b"".join(_long_run(records)))
    cut = whole[: len(whole) * 2 // 3]
    (tmp_path / "cut.jsonl.gz").write_bytes(cut)
    (tmp_path / "crashed.jsonl.gz").write_bytes(cut + b"\0" * 4096)
    expected = [t.n for t in read_trace(tmp_path / "cut.jsonl.gz").ticks]
    crashed = read_trace(tmp_path / "crashed.jsonl.gz")
    assert crashed.outcome == "incomplete" and crashed.truncated and len(expected) > 100
    # a line whose last compressed bytes were NULs is not told from the fill
    assert [t.n for t in crashed.ticks] in (expected, expected[:-1])


def test_a_damaged_jsonl_gz_is_refused_at_the_line_where_the_damage_is(
    records: Records, tmp_path: Path
) -> None:
    # gzip.open decompresses many kB at a time: damage in a piece lost every line
    # before it in the piece, and the error named an earlier line.
    compressor, data, flushed = zlib.compressobj(wbits=31), b"", []
    for line in _long_run(records):  # sync-flushed after every record, as written
        data += compressor.compress(line) + compressor.flush(zlib.Z_SYNC_FLUSH)
        flushed.append(len(data))
    data += compressor.flush()
    damaged = 300  # the first line it costs: the bytes after line 300 are no block
    at = flushed[damaged - 1]
    path = tmp_path / "run.jsonl.gz"
    path.write_bytes(data[:at] + b"\xff" + data[at + 1 :])
    with pytest.raises(LocatedError) as caught:
        read_trace(path)
    assert str(caught.value).startswith(
        f"{path}:{damaged + 1}:1: not readable as gzip after {damaged} lines: "
    )


class _FullDisk:
    """A standard error on a full disk: every write refused."""

    def __init__(self) -> None:
        self.tries = 0

    def isatty(self) -> bool:
        return False

    def write(self, text: str) -> int:
        import errno

        self.tries += 1
        raise OSError(errno.ENOSPC, "No space left on device")

    def flush(self) -> None:
        return None


def test_a_live_view_that_cannot_write_does_not_end_the_run(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # simulate_tree(live=True) with standard error on a full disk ended a run that
    # would succeed, with the view's OSError (the CLI guarded its own runs only: the
    # CLI probe); the view now switches itself off, as logging drops a record
    import sys

    full = _FullDisk()
    monkeypatch.setattr(sys, "stderr", full)
    result = pirate_bt.simulate_tree("straight", params={"distance": "0.1 m"}, live=True)
    assert result.status == "success", result.why
    assert full.tries == 1  # tried once, then left alone
