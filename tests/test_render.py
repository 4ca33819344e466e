"""Diagrams and plots of trees and traces, and the trace/render command lines."""

from __future__ import annotations

import io
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import py_trees
import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError
from pirate_bt.render import plot_trace, render_tree, tree_graph
from pirate_bt.render.plot import plot_series
from pirate_bt.trace import live_view_hook, read_trace, tree_structure
from tests.trace_support import make_tree, run_and_record

SVG = "{http://www.w3.org/2000/svg}"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def trace_path(tmp_path: Path) -> Path:
    path = tmp_path / "run.jsonl"
    run_and_record(path)
    return path


def svg_nodes(path: Path) -> dict[str, ET.Element]:
    root = ET.parse(path).getroot()
    return {g.get("id", ""): g for g in root.iter(f"{SVG}g") if g.get("class") == "node"}


def test_svg_parses_and_contains_every_node(tmp_path: Path) -> None:
    tree = make_tree()
    out = render_tree(tree, tmp_path / "tree.svg")
    nodes = svg_nodes(out)
    structure = tree_structure(tree)
    assert set(nodes) == {n.id for n in structure}
    for node in structure:
        texts = [t.text for t in nodes[node.id].iter(f"{SVG}text")]
        assert node.name in texts
    assert (tmp_path / "tree.dot").exists()


def test_kinds_are_styled_apart() -> None:
    source = tree_graph(make_tree())
    assert 'shape="house"' in source  # the Timeout guard
    assert 'shape="octagon"' in source  # the selector
    assert "duration_s: 5" in source  # parameters are shown


def test_coloured_by_status_at_a_tick(trace_path: Path, tmp_path: Path) -> None:
    trace = read_trace(trace_path)
    frame = trace.frame_at(3)
    out = render_tree(trace.structure, tmp_path / "t3.svg", frame.status, frame.feedback)
    nodes = svg_nodes(out)
    fills = {node_id: next(iter(g.iter(f"{SVG}polygon")), None) for node_id, g in nodes.items()}
    root_shape = fills["0"]
    assert root_shape is not None and root_shape.get("fill") == "#fcd34d"  # RUNNING
    assert "RUNNING" in ET.tostring(nodes["0"], encoding="unicode")


def test_missing_dot_writes_dot_file_and_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(FileNotFoundError, match="Graphviz 'dot' is not installed"):
        render_tree(make_tree(), tmp_path / "a.svg")
    assert (tmp_path / "a.dot").read_text().startswith("digraph")
    trace = tmp_path / "run.jsonl"
    run_and_record(trace)
    assert main(["render", str(trace), "-o", str(tmp_path / "b.png")]) == 0
    assert "not installed" in capsys.readouterr().err
    assert (tmp_path / "b.dot").exists() and not (tmp_path / "b.png").exists()


def test_plot_is_a_nontrivial_png(trace_path: Path, tmp_path: Path) -> None:
    trace = read_trace(trace_path)
    series = plot_series(trace)
    assert [s.name for s in series.steps] == [
        "clamp rear",
        "within 5 s",
        "bend or retry",
        "unclamp",
    ]
    out = plot_trace(trace, tmp_path / "plot.png")
    data = out.read_bytes()
    assert data[:8] == PNG_MAGIC
    assert len(data) > 20_000


def test_live_view_lines_and_redraw() -> None:
    tree = make_tree()
    stream = io.StringIO()
    tree.add_post_tick_handler(live_view_hook(tree, stream, redraw=False, ascii_only=True))
    for _ in range(14):
        tree.tick()
    lines = stream.getvalue().splitlines()
    assert lines[0].endswith("pab > clamp rear")
    assert "step 2/4: within 5 s" in lines[1]
    assert lines[-1].endswith("pab: SUCCESS")
    tty = io.StringIO()
    hook = live_view_hook(make_tree(), tty, redraw=True, interval_s=0.0)
    hook(None)
    hook(None)
    assert "\x1b[" in tty.getvalue()
    quiet = io.StringIO()
    live_view_hook(tree, quiet, quiet=True)(None)
    assert quiet.getvalue() == ""


def test_cli_trace_commands(
    trace_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["trace", "summary", str(trace_path)]) == 0
    out = capsys.readouterr().out
    assert "outcome   success" in out and "rotate_needs_one_clamped" in out
    assert main(["trace", "show", str(trace_path), "--tick", "3", "--state"]) == 0
    out = capsys.readouterr().out
    assert "tick 3 of 14" in out and "clamp rear" in out and "joint_angle_rad.bend_1" in out
    assert main(["trace", "plot", str(trace_path), "-o", str(tmp_path / "p.png")]) == 0
    assert (tmp_path / "p.png").read_bytes()[:8] == PNG_MAGIC
    assert main(["trace", "schema"]) == 0
    assert '"pirate-bt-trace"' in capsys.readouterr().out


def test_cli_render_from_trace_with_tick(
    trace_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "t.svg"
    assert main(["render", str(trace_path), "--tick", "5", "-o", str(out)]) == 0
    assert set(svg_nodes(out)) == {n.id for n in read_trace(trace_path).structure}


def test_cli_render_tree_file(tmp_path: Path) -> None:
    tree_file = Path(__file__).parents[1] / "trees" / "examples" / "patrol.yaml"
    if not tree_file.exists():
        pytest.skip("no example tree file")
    out = tmp_path / "patrol.svg"
    assert main(["render", str(tree_file), "-o", str(out)]) == 0
    from pirate_bt.treefile.loader import load_tree

    structure = tree_structure(load_tree(tree_file).root)
    nodes = svg_nodes(out)
    assert set(nodes) == {n.id for n in structure}  # every node of the file, nothing else
    for node in structure:
        texts = [t.text for t in nodes[node.id].iter(f"{SVG}text")]
        assert node.name in texts, node.id
    groups = ET.parse(out).getroot().iter(f"{SVG}g")
    edges = {g.findtext(f"{SVG}title") for g in groups if g.get("class") == "edge"}
    expected = {f"{n.parent}->{n.id}" for n in structure if n.parent is not None}
    assert edges == expected


def test_cli_errors_are_one_line_exit_2(
    trace_path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.jsonl"
    lines = trace_path.read_text().splitlines()
    bad.write_text("\n".join([lines[0], "garbage", *lines[1:]]) + "\n")
    assert main(["trace", "summary", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{bad}:2:" in err[0]
    assert main(["trace", "show", str(trace_path), "--tick", "999"]) == 2
    assert main(["render", str(trace_path), "-o", str(tmp_path / "x.gif")]) == 2
    assert "use .dot, .svg or .png" in capsys.readouterr().err


def test_python_api_accepts_root_behaviour() -> None:
    root = py_trees.behaviours.Success("only")
    source = tree_graph(root)
    nodes = re.findall(r'^\s*"([^"]+)" \[', source, re.M)
    assert nodes == ["0"]  # one node, the root, with its name and class
    assert 'label=<<b>only</b><br/><font point-size="8">Success</font>>' in source
    assert "->" not in source  # and no edge


# --- render_tree takes what users have: a tree file, a LoadedTree, a tree, a trace ---------

ROOT = Path(__file__).resolve().parents[1]
STRAIGHT = ROOT / "trees" / "straight.yaml"
DRIVE, CLAMP_REAR_HALF = "0.0.2.0", "0.0.1.0.0.0.0"


def dot_nodes(source: str) -> dict[str, dict[str, str]]:
    """Every node statement of ``dot`` source: id -> its fill colour and label."""
    found = {}
    for node_id, attrs in re.findall(r'^  "([\d.]+)" \[(.*)\];$', source, re.MULTILINE):
        fill = re.search(r'fillcolor="([^"]+)"', attrs)
        label = re.search(r"label=<(.*)>$", attrs)
        found[node_id] = {
            "fill": fill.group(1) if fill else "",
            "label": label.group(1) if label else "",
        }
    return found


@pytest.fixture(scope="module")
def straight_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("straight") / "run.jsonl"
    run = ["run", str(STRAIGHT), "--param", "distance=0.2m", "--quiet", "--sim", "straight"]
    assert main([*run, "--trace", str(path)]) == 0
    return path


def test_render_tree_from_a_tree_file_a_loaded_tree_or_a_behaviour_tree(tmp_path: Path) -> None:
    from pirate_bt.robot.loader import load_robot
    from pirate_bt.treefile import load_tree

    by_path = render_tree(STRAIGHT, tmp_path / "path.dot").read_text()
    nodes = dot_nodes(by_path)
    assert len(nodes) == 22
    assert nodes["0"]["label"].startswith("<b>straight</b>")
    assert nodes[DRIVE]["label"].startswith("<b>drive straight</b>")
    assert "<b>clamp rear half</b>" in nodes[CLAMP_REAR_HALF]["label"]
    assert 'label="straight"' in by_path  # the tree's name is the caption
    assert nodes[DRIVE]["fill"] == "#e5e7eb"  # no trace: filled by kind (leaf)
    # The same drawing as the command line's, and as a bundled tree's name gives.
    assert main(["render", str(STRAIGHT), "-o", str(tmp_path / "cli.dot")]) == 0
    assert (tmp_path / "cli.dot").read_text() == by_path
    assert tree_graph("straight") == by_path
    loaded = load_tree(STRAIGHT, robot=load_robot(), use_examples=True)
    assert render_tree(loaded, tmp_path / "loaded.dot").read_text() == by_path
    assert tree_graph(loaded.behaviour_tree()) == by_path
    assert tree_graph(loaded.root) == by_path
    # Parameters of a tree file, as on the command line.
    far = dot_nodes(tree_graph(str(STRAIGHT), params={"distance": "1.5 m"}))
    assert "distance: 1.5 m<" in far[DRIVE]["label"]


def test_render_tree_coloured_by_a_trace_at_a_tick(straight_run: Path, tmp_path: Path) -> None:
    trace = read_trace(straight_run)
    driving = trace.first_tick("drive straight", "RUNNING")
    assert driving is not None
    ran = {"distance": "0.2m"}  # as the run was (the header keeps the parameters used)
    out = render_tree(STRAIGHT, tmp_path / "tick.dot", trace=straight_run, tick=driving, params=ran)
    source = out.read_text()
    nodes = dot_nodes(source)
    assert nodes[DRIVE]["fill"] == "#fcd34d"  # RUNNING
    assert "RUNNING" in nodes[DRIVE]["label"]
    assert nodes[CLAMP_REAR_HALF]["fill"] == "#86efac"  # SUCCESS: clamped before driving
    assert nodes["0.1"]["fill"] == "#ffffff"  # the recovery never ran
    assert f"straight: tick {driving} at " in source
    # A Trace object, a trace as the tree, or the CLI's --trace --tick: the same picture.
    assert tree_graph(STRAIGHT, trace=trace, tick=driving, params=ran) == source
    assert tree_graph(straight_run, tick=driving) == source
    assert tree_graph(trace, tick=driving) == source
    cli = tmp_path / "cli.dot"
    args = ["render", str(STRAIGHT), "--trace", str(straight_run), "--tick", str(driving)]
    assert main([*args, "--param", "distance=0.2m", "-o", str(cli)]) == 0
    assert cli.read_text() == source
    # Without a tick: the last one, where the whole tree succeeded.
    last = dot_nodes(tree_graph(STRAIGHT, trace=trace, title="done"))
    assert last["0"]["fill"] == last[DRIVE]["fill"] == "#86efac"


def test_render_tree_refuses_what_does_not_fit(straight_run: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="tick needs a trace"):
        tree_graph(STRAIGHT, tick=3)
    with pytest.raises(InputError, match="not a trace of tree 'bend'"):
        render_tree(ROOT / "trees" / "bend.yaml", tmp_path / "b.dot", trace=straight_run)
    with pytest.raises(ValueError, match="not both"):
        tree_graph(STRAIGHT, {"0": "S"}, trace=straight_run)
    with pytest.raises(InputError, match="no tick 9999"):
        tree_graph(STRAIGHT, trace=straight_run, tick=9999)
    with pytest.raises(TypeError, match="not int"):
        tree_graph(42)  # type: ignore[arg-type]


def test_a_folder_as_the_output_is_named_whole(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was "out: cannot draw to 'somefolder': use .dot, .svg or .png": the suffix
    # blamed, and only the last part of the path shown
    folder = tmp_path / "somefolder"
    folder.mkdir()
    assert main(["render", "trees/straight.yaml", "-o", str(folder)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"pirate-bt: -o: '{folder}' is a folder; name a file"
    assert list(folder.iterdir()) == []
