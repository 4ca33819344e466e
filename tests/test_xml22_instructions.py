"""Processing instructions in BehaviorTree.CPP XML (docs/interop.md, How this is
tested): tinyxml2, BT.CPP's parser, reads every ``<?...?>`` as a declaration and
refuses the file when one comes after anything else (XML_ERROR_PARSING_DECLARATION);
import took such a file, which BT.CPP does not load, and said nothing.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_TREE = '<BehaviorTree ID="M"><AlwaysSuccess/></BehaviorTree>'
_ROOT = '<root BTCPP_format="4" main_tree_to_execute="M">'


@pytest.mark.parametrize(
    ("text", "place"),
    [
        (f"{_ROOT}\n<?foo bar?>{_TREE}</root>\n", "2:1"),
        (f'{_ROOT}\n<BehaviorTree ID="M"><AlwaysSuccess/><?x y?></BehaviorTree></root>\n', "2:38"),
        (f"{_ROOT}\n{_TREE}</root>\n<?x y?>\n", "3:1"),
        (f"<!-- c -->\n<?x y?>\n{_ROOT}\n{_TREE}</root>\n", "2:1"),
    ],
    ids=["in-root", "in-tree", "after-root", "after-a-comment"],
)
def test_a_processing_instruction_bt_cpp_refuses_is_refused_where_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, place: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(text, encoding="utf-8")
    assert main(["import", "btcpp", str(xml), "-o", str(tmp_path / "t.yaml")]) == 2
    assert capsys.readouterr().err == (
        f"pirate-bt: {xml}:{place}: a processing instruction (<?{text.split('<?')[1].split()[0]}"
        " ...?>) is only allowed before everything else in the file (BehaviorTree.CPP"
        " refuses it here)\n"
    )


def test_instructions_before_everything_else_are_read_as_bt_cpp_reads_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        f'<?xml version="1.0"?>\n<?xml-stylesheet href="a"?>\n{_ROOT}\n<!-- c -->{_TREE}</root>\n',
        encoding="utf-8",
    )
    assert main(["import", "btcpp", str(xml), "-o", str(tmp_path / "t.yaml")]) == 0
    assert capsys.readouterr().err == ""
