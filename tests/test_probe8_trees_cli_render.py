"""Probe 8 (hostile trees), with the cli/render.py patch: render reads a .xml tree as
run and validate do, and never draws over the tree file it draws."""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

XML = """<root BTCPP_format="4" main_tree_to_execute="main">
  <BehaviorTree ID="main"><wait name="settle" duration="1 s" /></BehaviorTree>
</root>
"""


def test_render_draws_an_xml_tree(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.xml"
    tree.write_text(XML, encoding="utf-8")
    assert main(["render", str(tree), "-o", str(tmp_path / "tree.dot")]) == 0
    assert "settle" in (tmp_path / "tree.dot").read_text(encoding="utf-8")


def test_render_never_draws_over_its_tree(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.dot"
    tree.write_text("root: {type: wait, duration: 1 s}\n", encoding="utf-8")
    assert main(["render", str(tree), "-o", str(tmp_path / "tree.svg")]) == 2
    assert "nothing written" in capsys.readouterr().err
    assert tree.read_text(encoding="utf-8").startswith("root:")
