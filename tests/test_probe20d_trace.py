"""Probe of the twentieth session: hand-written traces read back, drawn and plotted
(``pirate-bt trace summary|show|plot``, ``render --trace``), from docs/formats/trace.md."""

from __future__ import annotations

import copy
import json
import os
import shutil
import subprocess
import sys
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ArgumentTypeError, InputError
from pirate_bt.render.files import write_diagram
from pirate_bt.render.plot import plot_series, plot_trace
from pirate_bt.render.tree import render_tree
from pirate_bt.trace import read_trace

_NODES = [
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
]


def _records() -> list[dict[str, Any]]:
    """The example of docs/formats/trace.md."""
    return [
        {
            "type": "header",
            "format": "pirate-bt-trace",
            "version": 1,
            "tree": {"name": "pab", "nodes": copy.deepcopy(_NODES)},
            "robot": {"name": "PIRATE 2018", "digest": "5f2c..."},
            "clock": "simulated",
            "tick_period_s": 0.01,
            "full_state": False,
            "readings": False,
            "meta": {},
        },
        {"type": "tick", "n": 1, "t_s": 0.01, "status": {"0": "R", "0.0": "R"}},
        {"type": "tick", "n": 2, "t_s": 0.02, "state": {"joint_angle_rad.bend_3": 0.2}},
        {"type": "tick", "n": 3, "t_s": 0.03, "status": {"0": "S", "0.0": "S"}},
        {"type": "end", "n": 3, "t_s": 0.03, "outcome": "success"},
    ]


def _write(path: Path, records: list[dict[str, Any]]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")
    return path


def _commands(path: Path, out: Path) -> list[list[str]]:
    return [
        ["trace", "summary", str(path)],
        ["trace", "show", str(path), "--state"],
        ["trace", "plot", str(path), "-o", str(out / "plot.png")],
        ["render", str(path), "--trace", str(path), "--tick", "2", "-o", str(out / "d.dot")],
    ]


@pytest.mark.parametrize(
    ("value", "said"),
    [
        ("9" * 5000, "a whole number longer than 4300 digits"),
        ("[" * 5000 + "]" * 5000, "values nested deeper than a trace's reader goes"),
    ],
    ids=["a number of 5000 digits", "lists 5000 deep"],
)
def test_valid_json_that_python_cannot_hold_is_refused_at_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, said: str
) -> None:
    """JSON allows a number of any length and any depth; Python's json refuses both.
    Such a line was 'cannot read this trace: ValueError: Exceeds the limit (4300 digits)
    ... use sys.set_int_max_str_digits()', naming no line (and RecursionError alike)."""
    records = _records()
    records[2]["bb"] = {"k": "HERE"}
    text = "".join(json.dumps(r) + "\n" for r in records).replace('"HERE"', value)
    path = tmp_path / "run.jsonl"
    path.write_text(text, encoding="utf-8")
    for argv in _commands(path, tmp_path):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err == f"pirate-bt: {path}:3:1: not a trace record: {said}", argv
    assert not (tmp_path / "plot.png").exists()
    assert not (tmp_path / "d.dot").exists()


def _nameless() -> list[dict[str, Any]]:
    records = _records()
    for node in records[0]["tree"]["nodes"]:
        node["name"] = ""
    return records


@pytest.mark.skipif(shutil.which("dot") is None, reason="needs Graphviz's dot")
def test_a_node_with_an_empty_name_is_drawn(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A node named '' (a py_trees behaviour made with name='', a trace's header) gave
    Graphviz the label <b></b>, which it refuses: 'internal error: CalledProcessError',
    exit 1, with Graphviz's own lines on standard error and no picture."""
    path = _write(tmp_path / "run.jsonl", _nameless())
    for suffix in (".svg", ".png"):
        out = tmp_path / f"tick{suffix}"
        assert main(["render", str(path), "--trace", str(path), "--tick", "2", "-o", str(out)]) == 0
        assert capsys.readouterr().err == ""
        assert out.stat().st_size > 0
    root = py_trees.composites.Sequence("", memory=True, children=[py_trees.behaviours.Success("")])
    drawn = render_tree(root, tmp_path / "py.svg")
    assert ET.parse(drawn).getroot().tag.endswith("svg")


@pytest.mark.skipif(shutil.which("dot") is None, reason="needs Graphviz's dot")
def test_a_source_graphviz_refuses_is_one_line_naming_the_picture(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Whatever Graphviz refuses is one line naming the picture, with the .dot kept,
    not an internal error with Graphviz's lines printed above it."""
    out = tmp_path / "bad.svg"
    with pytest.raises(InputError) as caught:
        write_diagram("digraph { a [label=<<b></b>>] }", out)
    said = str(caught.value)
    assert "\n" not in said
    assert said.startswith(f"{out}: Graphviz could not draw it (dot exit 1: Error: syntax error")
    assert said.endswith(f"; {tmp_path / 'bad.dot'} was written")
    assert not out.exists()
    assert (tmp_path / "bad.dot").read_text(encoding="utf-8").startswith("digraph")
    assert capsys.readouterr().err == ""


def test_a_plot_is_drawn_whatever_backend_mplbackend_names(tmp_path: Path) -> None:
    """A plot is drawn with Agg; MPLBACKEND naming a backend matplotlib does not know
    (a typo in a shell's profile) made 'pirate-bt trace plot' an internal error
    (ValueError: Key backend: 'bogus' is not a valid value ...), exit 1. Run in a
    process of its own, where matplotlib is first imported by the plot."""
    path = _write(tmp_path / "run.jsonl", _records())
    out = tmp_path / "run.png"
    env = {**os.environ, "MPLBACKEND": "bogus", "PYTHONDONTWRITEBYTECODE": "1"}
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", "trace", "plot", str(path), "-o", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert (done.returncode, done.stderr) == (0, "")
    assert out.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("given", ["1", True, [1]], ids=["text", "True", "a list"])
def test_plot_trace_refuses_a_window_that_is_no_number(tmp_path: Path, given: object) -> None:
    """plot_trace(start_s="1") ended with Python's 'ValueError: Unknown
    format code 'g' for object of type 'str'', and start_s=True drew from 1 s."""
    path = _write(tmp_path / "run.jsonl", _records())
    for option in ("start_s", "end_s"):
        with pytest.raises(ArgumentTypeError, match=f"plot_trace: {option}: give a number"):
            plot_trace(path, tmp_path / "run.png", **{option: given})  # type: ignore[arg-type]
    assert not (tmp_path / "run.png").exists()


def _many_pabs(name_chars: int, pabs: int = 40) -> list[dict[str, Any]]:
    """A root sequence of ``pabs`` steps, one after another, 0.1 s each."""
    children = [f"0.{i}" for i in range(pabs)]
    nodes: list[dict[str, Any]] = [
        {"id": "0", "name": "mission", "type": "Sequence", "kind": "composite", "parent": None}
    ]
    nodes[0]["children"] = children
    for i, child in enumerate(children):
        name = f"{i + 1:02d} " + "pass the long straight " * (name_chars // 23 + 1)
        nodes.append(
            {"id": child, "name": name[:name_chars], "type": "Wait", "kind": "leaf", "parent": "0"}
        )
        nodes[-1]["children"] = []
    records = _records()[:1]
    records[0]["tree"] = {"name": "mission", "nodes": nodes}
    for i, child in enumerate(children):
        status = {child: "R", "0": "R"} if i == 0 else {children[i - 1]: "S", child: "R"}
        state = {"rotation_rad": i / 100}
        records.append(
            {"type": "tick", "n": i + 1, "t_s": i / 10, "status": status, "state": state}
        )
    last = len(children) + 1
    records.append({"type": "tick", "n": last, "t_s": last / 10, "status": {children[-1]: "S"}})
    records.append({"type": "end", "n": last, "t_s": last / 10, "outcome": "success"})
    return records


def test_a_plot_of_many_pabs_with_long_names_is_drawn(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The PABs too short to name in their band are listed under the plot; 40 PABs of
    300-character names took more lines than the figure is high, and 'trace plot'
    ended with 'internal error: ValueError: bottom cannot be >= top', no picture."""
    path = _write(tmp_path / "run.jsonl", _many_pabs(300))
    out = tmp_path / "run.png"
    assert main(["trace", "plot", str(path), "-o", str(out)]) == 0
    assert capsys.readouterr().err == ""
    assert out.read_bytes().startswith(b"\x89PNG")


def test_a_plot_shows_control_characters_in_names_as_escapes(tmp_path: Path) -> None:
    """A PAB or tree named with a control character (a NUL, a line break: a tree built in
    Python, a hand-made trace) was drawn as written: matplotlib warned 'Glyph 0 missing
    from font(s)' on standard error, and a line break split a strip's label in two.
    They are shown as escapes, as trace summary and show print them."""
    records = _many_pabs(20, pabs=3)
    records[0]["tree"]["name"] = "mission\x00"
    records[0]["tree"]["nodes"][1]["name"] = "01 clamp\x00rear\nnow"
    path = _write(tmp_path / "run.jsonl", records)
    series = plot_series(read_trace(path), 0.0, 0.4)
    assert [span.name for span in series.pabs][:1] == ["01 clamp\\x00rear\\nnow"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["trace", "plot", str(path), "-o", str(tmp_path / "run.png")]) == 0
    assert not [w for w in caught if "Glyph" in str(w.message)]


def test_a_trace_of_another_tree_is_named_in_one_short_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """'render TREE --trace T' of another tree's trace said both names whole (a line of
    10 kB for a 10,000-character name), and a node named '' in the trace was 'missing'."""
    long = _records()
    long[0]["tree"]["nodes"][0]["name"] = "x" * 10_000
    long_path = _write(tmp_path / "long.jsonl", long)
    nameless = _write(tmp_path / "nameless.jsonl", _nameless())
    good = _write(tmp_path / "good.jsonl", _records())
    out = str(tmp_path / "d.dot")
    assert main(["render", str(good), "--trace", str(long_path), "-o", out]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"pirate-bt: {long_path} is not a trace of {good}: node '0' is 'pab'")
    assert err.endswith("(10000 characters) in the trace")
    assert len(err) < 400
    assert main(["render", str(good), "--trace", str(nameless), "-o", out]) == 2
    assert capsys.readouterr().err.strip().endswith("is 'pab' in the tree but '' in the trace")
    with pytest.raises(InputError) as caught:
        render_tree(good, out, trace=long_path, tick=1)
    assert len(str(caught.value)) < 400
    assert str(caught.value).endswith("(10000 characters) in the trace")
    assert not Path(out).exists()
