"""Session 21: hostile tree files, YAML and BehaviorTree.CPP v4 XML (docs/trees.md,
docs/interop.md), what the earlier probes (test_probe8..20_trees, _xml, test_hostile_trees)
left.

Findings, each with its test below:

- a subtree's name (a ``subtrees:`` key, a BT.CPP ``<BehaviorTree ID>``) or a subtree
  file's path holding a control character (ESC, CR: ``"a\\x1b[2J"``, ``ID="a&#xD;b"``)
  went raw into the one line said of it: a recursion's chain (*recursive subtree: a
  <CR>b -> a<CR>b*), *no subtree named 'x' in FILE* and export's *NAME: U+001B cannot be
  written in XML*. On a terminal the line was rewritten or the screen cleared, where a
  node's name with one is refused and a file's path at the line's start is escaped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pirate_bt.cli import main


def _said(capsys: Any) -> str:
    err: str = capsys.readouterr().err
    return err


def test_a_recursion_through_subtree_names_with_control_characters_is_said_escaped(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        'root: {type: subtree, ref: "a\\e[2Jb"}\n'
        'subtrees:\n  "a\\e[2Jb": {root: {type: subtree, ref: "a\\e[2Jb"}}\n',
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = _said(capsys)
    assert "\x1b" not in err
    assert err.count("\n") == 1
    chain = " -> ".join([f"{tree}#a\\x1b[2Jb"] * 2)
    assert err.strip() == f"{tree}:3:37: recursive subtree: {chain}"


def test_a_subtree_file_whose_path_holds_an_escape_is_named_escaped(
    tmp_path: Path, capsys: Any
) -> None:
    own = tmp_path / "r\x1b[2Jx.yaml"
    own.write_text('root: {type: subtree, ref: "r\\e[2Jx.yaml"}\n', encoding="utf-8")
    caller = tmp_path / "t.yaml"
    caller.write_text(
        "root:\n  type: sequence\n  children:\n"
        '    - {type: subtree, ref: "r\\e[2Jx.yaml"}\n'
        '    - {type: subtree, ref: "r\\e[2Jx.yaml#nope"}\n',
        encoding="utf-8",
    )
    assert main(["validate", str(caller)]) == 2
    err = _said(capsys)
    assert "\x1b" not in err
    shown = str(own).replace("\x1b", "\\x1b")
    assert sorted(err.strip().splitlines()) == sorted(
        [
            f"{shown}:1:23: recursive subtree: {shown} -> {shown}",
            f"{caller}:5:23: no subtree named 'nope' in {shown}",
        ]
    )


def test_an_xml_recursion_through_ids_with_a_carriage_return_is_said_escaped(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.xml"
    tree.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        '<BehaviorTree ID="M"><Sequence><SubTree ID="a&#xD;b"/></Sequence></BehaviorTree>\n'
        '<BehaviorTree ID="a&#xD;b"><SubTree ID="a&#xD;b"/></BehaviorTree>\n</root>\n',
        encoding="utf-8",
    )
    for command in (["validate", str(tree)], ["run", str(tree), "-q"]):
        assert main(command) == 2
        err = _said(capsys)
        assert "\r" not in err
        assert err.count("\n") == 1
        assert err.strip().endswith("t.xml:3:28: recursive subtree: a\\rb -> a\\rb"), err


def test_export_names_a_subtree_it_cannot_write_escaped(tmp_path: Path, capsys: Any) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        'root: {type: subtree, ref: "a\\eb"}\nsubtrees:\n  "a\\eb": {root: success}\n',
        encoding="utf-8",
    )
    out = tmp_path / "t.xml"
    assert main(["export", "btcpp", str(tree), "-o", str(out)]) == 2
    err = _said(capsys)
    assert "\x1b" not in err
    assert err.strip().endswith("t.yaml:3:3: a\\x1bb: U+001B cannot be written in XML")
    assert not out.exists()
