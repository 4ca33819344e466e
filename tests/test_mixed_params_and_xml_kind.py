"""Parameters given from Python mix text with units and SI numbers, each read by
itself; ``validate --kind tree`` reads a BehaviorTree.CPP XML tree as ``run`` does."""

from __future__ import annotations

from pathlib import Path

import pytest

import pirate_bt
import pirate_bt.errors
from pirate_bt.cli import main


def test_text_beside_numbers_each_read_by_itself() -> None:
    mixed = pirate_bt.simulate_tree(
        "straight",
        network="straight",
        params={"distance": 0.3, "stop_at_feature": "false"},
    )
    text = pirate_bt.simulate_tree(
        "straight",
        network="straight",
        params={"distance": "0.3 m", "stop_at_feature": "false"},
    )
    assert mixed.status == text.status == "success"
    assert mixed.ticks == text.ticks


def test_validate_kind_tree_reads_xml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tree = tmp_path / "tree.xml"
    tree.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="main">\n'
        '  <BehaviorTree ID="main"><wait name="settle" duration="1 s" /></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    assert main(["validate", "--kind", "tree", str(tree)]) == 0, capsys.readouterr().err


def test_load_tree_reads_xml_and_places_its_problems(tmp_path: Path) -> None:
    good = tmp_path / "good.xml"
    good.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="main">\n'
        '  <BehaviorTree ID="main"><wait name="settle" duration="1 s" /></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    loaded = pirate_bt.load_tree(good)
    assert loaded.root.name == "settle"
    bad = tmp_path / "bad.xml"
    bad.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="main">\n'
        '  <BehaviorTree ID="main"><Fly/></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    placed = r"bad\.xml:2:\d+: unknown node type 'Fly'"
    with pytest.raises(pirate_bt.errors.PirateError, match=placed):
        pirate_bt.load_tree(bad)
