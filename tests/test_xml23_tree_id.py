"""A main ``<BehaviorTree>`` ID that is no tree name said in the XML's words
(docs/interop.md, What the XML holds).

The tree file's ``name`` is the main tree's ID (or its ``_name``), and an ID that is no
name (blank, with a space around it, a ``/``, a zero-width space) was refused as
*name: must not contain '/'*, a ``name`` attribute the file does not have.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main


@pytest.mark.parametrize(
    ("tree_id", "said"),
    [
        (" ", "must be non-empty text"),
        ("a/b", "must not contain '/' (used in node paths)"),
        ("M&#x200B;", "must not contain U+200B ZERO WIDTH SPACE"),
    ],
    ids=["blank", "slash", "zero-width"],
)
def test_a_main_tree_id_that_is_no_name_is_said_to_be_the_id(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tree_id: str, said: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        f'<root BTCPP_format="4" main_tree_to_execute="{tree_id}">\n'
        f'<BehaviorTree ID="{tree_id}"><AlwaysSuccess/></BehaviorTree>\n</root>\n',
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err.replace(str(xml), "t.xml")
    assert err.startswith(f"t.xml:2:1: <BehaviorTree> ID (the tree's name): {said}"), err
    assert err.count("\n") == 1


def test_a_node_name_keeps_its_words(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        '<BehaviorTree ID="M"><wait name="a/b" duration="1 s"/></BehaviorTree>\n</root>\n',
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    assert capsys.readouterr().err.replace(str(xml), "t.xml") == (
        "t.xml:2:22: name: must not contain '/' (used in node paths)\n"
    )
