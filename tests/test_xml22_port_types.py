"""A ``<SubTree>`` model's port typed as BT.CPP's own models and Groot2 write types (the
C++ names: ``int``, ``double``, ``bool``, ``std::string``) was refused ("type 'int' is
not a pirate_bt parameter type"); BT.CPP reads no type there and loads the file. Import
reads each C++ name as the pirate_bt type it holds (docs/interop.md, Subtrees and
parameters).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main
from pirate_bt.treefile import load_tree

_FILE = (
    '<root BTCPP_format="4" main_tree_to_execute="M">\n'
    '<BehaviorTree ID="M"><SubTree ID="S" x="GIVEN"/></BehaviorTree>\n'
    '<BehaviorTree ID="S">BODY</BehaviorTree>\n'
    '<TreeNodesModel><SubTree ID="S"><input_port name="x" type="TYPE"/></SubTree>'
    "</TreeNodesModel></root>\n"
)


def _text(given: str, body: str, cpp: str) -> str:
    return _FILE.replace("GIVEN", given).replace("BODY", body).replace("TYPE", cpp)


_REPEAT = '<Repeat num_cycles="{x}"><AlwaysSuccess/></Repeat>'


@pytest.mark.parametrize(
    ("cpp", "given", "node", "kind", "value"),
    [
        ("int", "3", _REPEAT, "integer", 3),
        ("unsigned int", "3", _REPEAT, "integer", 3),
        ("double", "2.5", '<log message="hi"/>', "number", 2.5),
        ("bool", "true", '<log message="hi"/>', "boolean", True),
        ("std::string", "hi", '<log message="{x}"/>', "string", "hi"),
    ],
    ids=["int", "unsigned int", "double", "bool", "std::string"],
)
def test_a_subtree_port_typed_in_cpp_is_read_as_its_pirate_bt_type(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    cpp: str,
    given: str,
    node: str,
    kind: str,
    value: object,
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_text(given, node, cpp), encoding="utf-8")
    out = tmp_path / "t.yaml"
    code = main(["import", "btcpp", str(xml), "-o", str(out)])
    assert (code, capsys.readouterr().err) == (0, "")
    load_tree(out)  # a tree file that loads
    written = yaml.safe_load(out.read_text(encoding="utf-8"))
    assert written["subtrees"]["S"]["params"]["x"]["type"] == kind
    assert written["root"]["params"] == {"x": value}


def test_a_type_of_neither_kind_names_both(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(_text("1", "<AlwaysSuccess/>", "BT::AnyTypeAllowed"), encoding="utf-8")
    assert main(["import", "btcpp", str(xml), "-o", str(tmp_path / "t.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"pirate-bt: {xml}:4:33: port 'x': type 'BT::AnyTypeAllowed' is not a pirate_bt"
        " parameter type (acceleration, "
    )
    assert err.endswith("nor a C++ type of one (int, double, bool, std::string...)\n")
