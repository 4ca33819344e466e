"""Probe 8 (hostile trees): drawing a tree whose text Graphviz would misread.

A tree's name, a node's parameter or a trace's header are other people's text: a
backslash ends a quoted DOT string, a control character is refused by Graphviz's
HTML-like labels. Either made ``pirate-bt render`` fail with exit 1 ("internal
error: CalledProcessError") after writing a ``.dot`` file Graphviz cannot read.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ArgumentValueError, InputError
from pirate_bt.render import render_tree, tree_graph
from pirate_bt.trace.structure import NodeInfo, TreeStructure
from pirate_bt.treefile import load_tree

SVG = "{http://www.w3.org/2000/svg}"
needs_dot = pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz 'dot' missing")


def _texts(svg: Path) -> list[str]:
    return [t.text or "" for t in ET.parse(svg).getroot().iter(f"{SVG}text")]


@needs_dot
@pytest.mark.parametrize("name", ["ends in a backslash\\\\", "graph \\\\G and node \\\\N"])
def test_a_backslash_in_the_tree_s_name_is_drawn_as_written(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(f'name: "{name}"\nroot: {{type: wait, duration: 1 s}}\n', encoding="utf-8")
    out = tmp_path / "tree.svg"
    assert main(["render", str(tree), "-o", str(out)]) == 0, capsys.readouterr().err
    assert name.replace("\\\\", "\\") in _texts(out)


@needs_dot
def test_control_characters_in_a_parameter_are_shown_escaped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text('root: {type: log, message: "a\\x07b\\x1bc\\u0085d"}\n', encoding="utf-8")
    out = tmp_path / "tree.svg"
    assert main(["render", str(tree), "-o", str(out)]) == 0, capsys.readouterr().err
    assert any("a\\x07b\\x1bc\\x85d" in t for t in _texts(out))


@needs_dot
def test_a_hostile_trace_header_cannot_break_the_dot_source(tmp_path: Path) -> None:
    # What a trace file's header may hold: ids and names are read as written.
    html_like = '<x>]; "y" [label=<z>'
    nodes = (
        NodeInfo('0" [shape=none]; "x', "root\\", "Sequence\x07", "composite", None, ('1"\\',)),
        NodeInfo('1"\\', "leaf \x00", "Log", "leaf", '0" [shape=none]; "x', (html_like,)),
        NodeInfo(html_like, "html?", "Log", "leaf", '1"\\', (), {"m": "\x1b"}),
    )
    structure = TreeStructure(name='quote " and \\', nodes=nodes)
    source = tree_graph(structure)
    assert source.count(" -> ") == 2
    out = render_tree(structure, tmp_path / "t.svg")
    groups = [g for g in ET.parse(out).getroot().iter(f"{SVG}g") if g.get("class") == "node"]
    assert len(groups) == 3
    assert 'quote " and \\' in _texts(out)


def test_a_tree_file_is_never_drawn_over(tmp_path: Path) -> None:
    # A tree file named tree.dot, drawn to tree.svg: the .dot written beside the
    # picture replaced the tree itself. A link to the tree as the output did too.
    tree = tmp_path / "tree.dot"
    text = "root: {type: wait, duration: 1 s}\n"
    tree.write_text(text, encoding="utf-8")
    (tmp_path / "link.svg").symlink_to(tree)
    for out in ("tree.svg", "tree.png", "tree.dot", "link.svg"):
        with pytest.raises(ArgumentValueError, match="a file being drawn; nothing written"):
            render_tree(tree, tmp_path / out)
        loaded = load_tree(tree, use_examples=True)
        with pytest.raises(ArgumentValueError, match="would replace"):
            render_tree(loaded, tmp_path / out)
    assert tree.read_text(encoding="utf-8") == text
    assert not (tmp_path / "tree.svg").exists()


def test_the_file_that_cannot_be_written_is_the_one_named(tmp_path: Path) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text("root: {type: wait, duration: 1 s}\n", encoding="utf-8")
    (tmp_path / "out.dot").mkdir()  # the .dot written beside out.svg cannot be
    with pytest.raises(
        InputError, match=r"cannot write '.*out\.dot' beside '.*out\.svg': Is a directory"
    ):
        render_tree(tree, tmp_path / "out.svg")
