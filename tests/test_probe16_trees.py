"""Probe 16 (hostile tree files, third round): what a user saw, each pinned.

- ``pirate-bt render`` drew a node's name or a parameter holding ``\\N``, ``\\G`` or
  ``\\E`` (a Windows path in a log message: ``C:\\New``) with the node's id or the
  graph's name in its place: Graphviz reads those escapes in an HTML-like label too.
  A line break in a message was drawn as nothing (``x\\ny`` as ``xy``).
- ``pirate-bt import btcpp a.xml -o b.xml`` wrote YAML into ``b.xml`` (replacing the
  XML there), which every reader then refused as "not well-formed XML".
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pirate_bt.cli import main

SVG = "{http://www.w3.org/2000/svg}"
needs_dot = pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz 'dot' missing")


def _texts(svg: Path) -> list[str]:
    return [t.text or "" for t in ET.parse(svg).getroot().iter(f"{SVG}text")]


@needs_dot
def test_backslash_escapes_in_node_names_and_values_are_drawn_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        "root:\n"
        "  type: sequence\n"
        "  name: 'seq \\N \\G \\E'\n"
        "  children:\n"
        "    - {type: log, name: 'C:\\Notes', message: 'saved to C:\\New\\Garage\\'}\n"
        '    - {type: log, name: two lines, message: "x\\ny"}\n',
        encoding="utf-8",
    )
    out = tmp_path / "tree.svg"
    assert main(["render", str(tree), "-o", str(out)]) == 0, capsys.readouterr().err
    texts = _texts(out)
    assert "seq \\N \\G \\E" in texts, texts
    assert "C:\\Notes" in texts, texts
    assert "message: saved to C:\\New\\Garage\\" in texts, texts
    assert "message: x\\ny" in texts, texts


@pytest.mark.parametrize("name", ["groot.xml", "tree.txt", "tree"])
def test_import_writes_a_yaml_file_only(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # `import btcpp a.xml -o b.xml` wrote YAML into b.xml (a Groot2 file there was
    # replaced), which every reader then took for XML: "not well-formed XML".
    source = tmp_path / "a.xml"
    assert main(["export", "btcpp", "trees/examples/patrol.yaml", "-o", str(source)]) == 0
    out = tmp_path / name
    out.write_text("<root/>\n", encoding="utf-8")
    capsys.readouterr()
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is written to a .yaml file" in err, err
    assert out.read_text(encoding="utf-8") == "<root/>\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted({"a.xml", name})
    assert main(["import", "btcpp", str(source), "-o", str(tmp_path / "b.YML")]) == 0
