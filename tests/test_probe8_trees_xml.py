"""Probe 8 (hostile trees): a BehaviorTree.CPP XML file given where a YAML tree is read.

``pirate-bt run`` and ``validate``, ``simulate_tree`` and ``load_xml_tree`` read a
``.xml`` tree as it is; ``render``, ``export btcpp``, ``render_tree``,
``pirate_bt.treefile.load_tree`` (and ``pirate_bt.load_tree``) read it as YAML and said
*YAML syntax error: mapping values are not allowed in this context* somewhere in the XML.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.treefile import load_tree

XML = """<?xml version="1.0" encoding="UTF-8"?>
<root BTCPP_format="4" main_tree_to_execute="main">
  <BehaviorTree ID="main">
    <Sequence name="main">
      <wait name="settle" duration="1 s" />
      <log message="done: ok" />
    </Sequence>
  </BehaviorTree>
</root>
"""


@pytest.fixture
def xml_tree(tmp_path: Path) -> Path:
    path = tmp_path / "tree.xml"
    path.write_text(XML, encoding="utf-8")
    return path


def test_the_yaml_loader_names_an_xml_tree_for_what_it_is(xml_tree: Path) -> None:
    with pytest.raises(ValidationFailed) as caught:
        load_tree(xml_tree)
    (error,) = caught.value.errors
    assert str(error).startswith(f"{xml_tree}:1:1: a BehaviorTree.CPP XML tree")
    assert "YAML syntax error" not in str(error)
    assert "pirate_bt.load_xml_tree" in str(error)
    assert pirate_bt.load_xml_tree(xml_tree).name == "main"  # which reads it


def test_render_and_export_of_an_xml_tree_say_what_it_is(
    xml_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(ValidationFailed, match=r"BehaviorTree\.CPP XML tree"):
        pirate_bt.render_tree(xml_tree, tmp_path / "tree.svg")
    assert main(["export", "btcpp", str(xml_tree), "-o", str(tmp_path / "again.xml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "BehaviorTree.CPP XML tree" in err
    assert "YAML syntax error" not in err
    assert not (tmp_path / "tree.svg").exists()
    assert not (tmp_path / "tree.dot").exists()
    assert not (tmp_path / "again.xml").exists()


def test_file_names_near_the_system_s_limit_are_read_and_written(
    xml_tree: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A temporary file named after the input or the output (.NAME.XXXXXXXX.tmp) was
    # longer than the 255 bytes a name may have: validate and run of a 255-byte
    # tree.xml named a file in a temporary folder, 'File name too long'; export and
    # import refused a legal output name.
    long_xml = tmp_path / ("x" * 251 + ".xml")
    long_xml.write_text(XML, encoding="utf-8")
    assert main(["validate", str(long_xml)]) == 0, capsys.readouterr().err
    assert main(["run", str(long_xml), "--quiet"]) == 0, capsys.readouterr().err
    long_yaml = tmp_path / ("y" * 250 + ".yaml")
    assert main(["import", "btcpp", str(xml_tree), "-o", str(long_yaml)]) == 0
    assert main(["export", "btcpp", str(long_yaml), "-o", str(long_yaml.with_suffix(".xml"))]) == 0
    capsys.readouterr()
    assert sorted(p.name[:3] for p in tmp_path.iterdir()) == ["tre", "xxx", "yyy", "yyy"]
