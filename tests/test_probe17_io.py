"""Probe 17: files, traces, interop and the command line, as a hostile but
realistic user meets them. Every bad input is one line naming the file (and
line and column, or the node); nothing is left half-written."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
from pathlib import Path

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.trace import TraceRecorder, read_trace

ROOT = Path(__file__).resolve().parents[1]
PY_CLI = [sys.executable, "-m", "pirate_bt"]


@pytest.fixture(scope="module")
def straight_trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import pirate_bt

    path = tmp_path_factory.mktemp("run") / "straight.jsonl"
    pirate_bt.simulate_tree("straight", params={"distance": "0.3 m"}, trace=path)
    return path


def _on_a_full_disk(argv: list[str], limit: int = 20000) -> subprocess.CompletedProcess[str]:
    import resource

    def file_size_limit() -> None:  # a disk that fills as it writes, in the child only
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)

    # no .pyc written: a short write under the limit left a cut-off one in place
    # ("EOFError: marshal data too short" for every later import of the module)
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    return subprocess.run(
        [*PY_CLI, *argv],
        preexec_fn=file_size_limit,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )


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


@pytest.mark.skipif(not hasattr(signal, "SIGXFSZ"), reason="needs file size limits")
@pytest.mark.parametrize("made", [False, True])
def test_a_rosbag2_export_onto_a_full_disk_names_the_bag_and_leaves_nothing(
    straight_trace: Path, tmp_path: Path, made: bool
) -> None:
    # It said only "pirate-bt: File too large": no file named, nothing said was written.
    pytest.importorskip("rosbags")
    bag = tmp_path / "deep" / "run_bag"
    if made:  # an empty folder given is filled: it stays, empty
        bag.mkdir(parents=True)
    done = _on_a_full_disk(["trace", "export", str(straight_trace), "-o", f"{bag}/"])
    assert done.returncode == 2, done
    errors = done.stderr.strip().splitlines()
    assert len(errors) == 1 and "Traceback" not in done.stderr, done.stderr
    assert str(bag) in errors[0] and "cannot write" in errors[0], errors
    assert "File too large" in errors[0]
    if made:
        assert list(bag.iterdir()) == []
    assert [p.name for p in tmp_path.iterdir()] == (["deep"] if made else [])


@pytest.mark.parametrize(
    ("argv", "faults", "where", "words"),
    [
        (["run", "straight", "--param", "distance=0.1m"], "drop=2", "1:1", "drop='2'"),
        (["run", "straight", "--param", "distance=0.1m"], "drop=0.1  bogus=1", "1:11", "'bogus'"),
        (
            ["mission", "lab", "--plan"],
            "drop=0.1;motor_stall:nosuch@1s",
            "1:10",
            "unknown motor 'nosuch'",
        ),
        (["mission", "lab", "--plan"], "drop=0.1,drop=0.2", "1:10", "'drop' is given twice"),
        (["navigate", "goal", "--sim", "lab"], "x:y@1s", "1:1", "unknown fault kind 'x'"),
        (
            ["run", "straight", "--param", "distance=0.1m", "--port", "loop://"],
            "drop=0.1 link_loss@1s",
            "1:10",
            "need the simulator, not a port",
        ),
    ],
)
def test_a_bad_faults_option_is_placed_at_its_column_like_every_bad_input(
    argv: list[str],
    faults: str,
    where: str,
    words: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # It said "pirate-bt: faults: ...", the API's argument name, where a bad --param
    # says "--param:1:1: ...".
    assert main([*argv, "--faults", faults]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1, err
    assert err.startswith(f"pirate-bt: --faults:{where}: ") and words in err, err


def test_a_bad_sim_fault_option_is_named_as_typed(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "straight", "--fault", "motor_stall:nosuch@1s"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pirate-bt: --fault:1:1: fault motor_stall: unknown motor 'nosuch'")


def _ascii_stream(monkeypatch: pytest.MonkeyPatch, name: str) -> io.BytesIO:
    raw = io.BytesIO()
    monkeypatch.setattr(sys, name, io.TextIOWrapper(raw, encoding="ascii", errors="strict"))
    return raw


def test_output_an_ascii_terminal_cannot_show_is_escaped_not_an_internal_error(
    straight_trace: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # PYTHONIOENCODING=ascii (or a Latin-1 terminal): 'trace show' ended with
    # "internal error: UnicodeEncodeError: 'ascii' codec can't encode character
    # '\u25b6'", exit 1, after printing nothing
    out = _ascii_stream(monkeypatch, "stdout")
    assert main(["trace", "show", str(straight_trace), "--tick", "5"]) == 0
    sys.stdout.flush()
    assert b"\\u25b6 straight [Selector]  RUNNING" in out.getvalue()


def test_an_error_an_ascii_terminal_cannot_show_keeps_its_exit_code(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    err = _ascii_stream(monkeypatch, "stderr")
    assert main(["validate", str(tmp_path / "r\u00f6hre.yaml")]) == 2
    sys.stderr.flush()
    lines = err.getvalue().decode("ascii").splitlines()
    assert len(lines) == 1 and "r\\xf6hre.yaml" in lines[0], lines


_ALIASED_TREE = """\
name: aliased
root:
  type: sequence
  name: top
  children:
    - &grab
      type: clamp
      name: grab
      half: front
      torque: 50 N*m
    - {type: wait, name: pause, duration: &d 1 kg}
    - *grab
    - {type: wait, name: again, duration: *d}
"""


def test_an_error_in_an_aliased_tree_node_is_placed_where_the_alias_is_used(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Each problem of the second use was placed at the anchor: "aliased.yaml:6:7:
    # duplicate node name 'grab' among siblings (first at aliased.yaml:6:7)", and its
    # torque was said once, at line 10, for two nodes.
    path = tmp_path / "aliased.yaml"
    path.write_text(_ALIASED_TREE)
    assert main(["validate", str(path)]) == 2
    said = [line.removeprefix("pirate-bt: ") for line in capsys.readouterr().err.splitlines()]
    assert f"{path}:12:7: duplicate node name 'grab' among siblings (first at {path}:6:7)" in said
    torque = [s.split(": clamp")[0] for s in said if "torque: 50 N*m" in s]
    assert torque == [f"{path}:10:7", f"{path}:12:7"], said
    mass = [s.split(": wait")[0] for s in said if "is a mass" in s]
    assert mass == [f"{path}:11:33", f"{path}:13:33"], said


def test_a_merged_value_is_still_placed_in_the_anchor_that_writes_it() -> None:
    from pirate_bt.yamlfile import load_yaml_text

    doc = load_yaml_text("a: &x\n  k: 1\nb:\n  <<: *x\n  j: 2\nc: [*x]\n")
    assert str(doc.locator.locate(("b", "k"))) == "<string>:2:3"  # in the anchor
    assert str(doc.locator.locate(("c", 0, "k"))) == "<string>:6:5"  # where *x is used


@pytest.mark.parametrize("target", ["out.mcap", "out_bag/"])
def test_an_export_of_a_trace_cut_inside_its_header_says_so_as_summary_does(
    straight_trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], target: str
) -> None:
    # .mcap and rosbag2 exports called a 3000-byte file an "empty trace (no header)",
    # where trace summary and the .btlog export said the header was cut off.
    pytest.importorskip("mcap" if target.endswith(".mcap") else "rosbags")
    cut = tmp_path / "cut.jsonl"
    cut.write_bytes(straight_trace.read_bytes()[:3000])
    assert main(["trace", "export", str(cut), "-o", str(tmp_path / target)]) == 2
    err = capsys.readouterr().err
    said = f"{cut}:1:1: the header record is cut off (the run was cut off before it was"
    assert err.startswith(f"pirate-bt: {said} written") and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.jsonl"]


@pytest.mark.parametrize("gz", [False, True])
def test_a_json_lines_trace_renamed_mcap_is_named_as_one(
    straight_trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], gz: bool
) -> None:
    # It was "not a readable MCAP file: not a valid MCAP file, invalid magic: (123, 34,
    # 116, 121, 112, 101, 34, 58)"; a .mcap renamed .jsonl is named as MCAP.
    pytest.importorskip("mcap")
    import gzip

    data = straight_trace.read_bytes()
    path = tmp_path / "run.mcap"
    path.write_bytes(gzip.compress(data) if gz else data)
    assert main(["trace", "summary", str(path)]) == 2
    suffix = ".jsonl.gz" if gz else ".jsonl"
    assert capsys.readouterr().err.endswith(f"trace, not MCAP: name it run{suffix}\n")
