"""Probe 19: BehaviorTree.CPP XML both ways, at the seams with BT.CPP's own parser
(its sources in the behaviortreepy distribution) and with the tree loader (see
docs/interop.md).

Findings, each with its test below:

- a subtree parameter whose default is the empty text was exported as the model's
  ``default=""``, which BT.CPP takes for no default: every call of that subtree that
  left the parameter out was refused by BT.CPP ("is defining a mandatory port ...
  but you are not remapping it");
- a file in which another tree calls the main tree (main_tree_to_execute), as
  docs/interop.md suggests for running an exported tree in BT.CPP with its defaults
  (``<BehaviorTree ID="run"><SubTree ID="bend_2"/></BehaviorTree>``), was refused by
  import, validate and run with "no subtree named 'bend_2'", a tree the file has;
"""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest
import yaml

from pirate_bt.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def checker() -> Path:
    sys.path.insert(0, str(ROOT / "tests" / "btcpp_checker"))
    try:
        import build as checker_build  # type: ignore[import-not-found]
    finally:
        sys.path.pop(0)
    try:
        return Path(checker_build.build_checker())
    except checker_build.Unavailable as exc:
        pytest.skip(f"BT.CPP port checker unavailable: {exc}")


_EMPTY_DEFAULT = """\
name: t
subtrees:
  say:
    params:
      msg: {type: string, default: ""}
    root: {type: log, message: $msg}
root:
  type: sequence
  children:
    - {type: subtree, ref: say}
"""


def test_an_empty_default_is_given_at_each_call_and_read_back_as_the_default(
    tmp_path: Path, capsys: Any
) -> None:
    # BT.CPP reads a <SubTree> model's default="" as no default, and refused the call
    # that leaves the parameter out; the empty text is now written at the call
    source = tmp_path / "t.yaml"
    source.write_text(_EMPTY_DEFAULT, encoding="utf-8")
    xml, back = tmp_path / "t.xml", tmp_path / "back.yaml"
    assert main(["export", "btcpp", str(source), "-o", str(xml)]) == 0
    call = ET.parse(xml).getroot().find("BehaviorTree[@ID='t']//SubTree[@ID='say']")
    assert call is not None
    assert call.attrib.get("msg") == ""
    assert main(["import", "btcpp", str(xml), "-o", str(back)]) == 0
    assert yaml.safe_load(back.read_text(encoding="utf-8")) == yaml.safe_load(_EMPTY_DEFAULT)
    capsys.readouterr()


def test_bt_cpp_builds_a_call_that_leaves_an_empty_default_out(
    checker: Path, tmp_path: Path, capsys: Any
) -> None:
    source = tmp_path / "t.yaml"
    source.write_text(_EMPTY_DEFAULT, encoding="utf-8")
    xml = tmp_path / "t.xml"
    assert main(["export", "btcpp", str(source), "-o", str(xml)]) == 0
    result = subprocess.run(
        [str(checker), str(xml)], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.returncode == 0, result.stdout + result.stderr
    capsys.readouterr()


_CALLED_MAIN = (
    '<root BTCPP_format="4" main_tree_to_execute="M">'
    '<BehaviorTree ID="M"><Sequence name="main">{body}</Sequence></BehaviorTree>'
    '<BehaviorTree ID="run"><SubTree ID="M" name="the main tree"/></BehaviorTree>'
    "</root>\n"
)


def test_a_main_tree_another_tree_calls_is_imported_as_root_and_as_subtree(
    tmp_path: Path, capsys: Any
) -> None:
    source = tmp_path / "called.xml"
    source.write_text(_CALLED_MAIN.format(body='<AlwaysSuccess name="ok"/>'), encoding="utf-8")
    out = tmp_path / "called.yaml"
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 0
    assert "no subtree named" not in capsys.readouterr().err
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    assert data["name"] == "M"
    assert data["subtrees"]["M"]["root"] == data["root"]
    assert data["subtrees"]["run"]["root"] == {
        "type": "subtree",
        "name": "the main tree",
        "ref": "M",
    }
    assert main(["validate", str(source)]) == 0


def test_a_problem_of_a_called_main_tree_is_reported_once(tmp_path: Path, capsys: Any) -> None:
    source = tmp_path / "called.xml"
    body = '<drive velocity="9 m/s" distance="1 m"/>'
    source.write_text(_CALLED_MAIN.format(body=body), encoding="utf-8")
    out = tmp_path / "called.yaml"
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert "called.xml:1:92: drive: velocity: 9000 mm/s is above" in err
    assert not out.exists()


def test_the_docs_recipe_to_run_a_main_tree_in_bt_cpp_gives_an_empty_default_at_the_call(
    checker: Path, tmp_path: Path, capsys: Any
) -> None:
    # docs/interop.md said a tree of one's own calling the main tree "takes the
    # defaults": BT.CPP refuses straight.yaml's distance_key (default "") so called
    xml = tmp_path / "s.xml"
    tree = ROOT / "trees" / "straight.yaml"
    assert main(["export", "btcpp", str(tree), "--param", "distance=1m", "-o", str(xml)]) == 0
    capsys.readouterr()
    text = xml.read_text(encoding="utf-8").replace(
        'main_tree_to_execute="straight"', 'main_tree_to_execute="run"'
    )
    page = (ROOT / "docs" / "interop.md").read_text(encoding="utf-8")
    results = {}
    for call in ('<SubTree ID="straight"/>', '<SubTree ID="straight" distance_key=""/>'):
        wrapped = tmp_path / "run.xml"
        wrapped.write_text(
            text.replace("</root>", f'<BehaviorTree ID="run">{call}</BehaviorTree></root>'),
            encoding="utf-8",
        )
        results[call] = subprocess.run(
            [str(checker), str(wrapped)], capture_output=True, text=True, timeout=60, check=False
        )
    refused = results['<SubTree ID="straight"/>']
    assert refused.returncode != 0
    said = "is defining a mandatory port called [distance_key], but you are not remapping it"
    assert said in refused.stdout + refused.stderr
    assert results['<SubTree ID="straight" distance_key=""/>'].returncode == 0
    assert '`<SubTree ID="straight" distance_key=""/>`' in " ".join(page.split())
    assert f"*{said}*" in " ".join(page.split())


_POINTERS = (
    '<root BTCPP_format="4" main_tree_to_execute="M">'
    '<BehaviorTree ID="M"><Sequence>'
    '<drive velocity="80 mm/s" distance=" {d} "/>'
    '<drive velocity="80 mm/s" distance="="/>'
    '<SubTree ID="A" msg="="/>'
    "</Sequence></BehaviorTree>"
    '<BehaviorTree ID="A"><log message="{msg}"/></BehaviorTree>'
    "<TreeNodesModel>"
    '<SubTree ID="M"><input_port name="d" type="length" default="1 m"/>'
    '<input_port name="distance" type="length" default="2 m"/></SubTree>'
    '<SubTree ID="A"><input_port name="msg" type="string"/></SubTree>'
    "</TreeNodesModel></root>\n"
)


def test_port_text_bt_cpp_reads_as_a_pointer_is_imported_as_a_parameter(
    tmp_path: Path, capsys: Any
) -> None:
    source = tmp_path / "p.xml"
    source.write_text(_POINTERS, encoding="utf-8")
    out = tmp_path / "p.yaml"
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 0, capsys.readouterr().err
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    first, second, call = data["root"]["children"]
    assert first["distance"] == "$d"  # was the text ' {d} ': "not a quantity"
    assert second["distance"] == "$distance"  # was the text '='
    assert call["params"] == {"msg": "="}  # a <SubTree>'s "=" is text in BT.CPP too


@pytest.mark.parametrize("text", [" {x}", "{x} ", "  {note}  ", "="])
def test_text_bt_cpp_would_read_as_a_pointer_is_exported_as_text(
    text: str, tmp_path: Path, capsys: Any
) -> None:
    source = tmp_path / "t.yaml"
    tree = {"name": "t", "root": {"type": "log", "name": "l", "message": text}}
    source.write_text(yaml.safe_dump(tree), encoding="utf-8")
    xml, back = tmp_path / "t.xml", tmp_path / "back.yaml"
    assert main(["export", "btcpp", str(source), "-o", str(xml)]) == 0
    node = ET.parse(xml).getroot().find("BehaviorTree/log")
    assert node is not None
    written = node.attrib["message"]
    assert written.startswith("json:")
    assert main(["import", "btcpp", str(xml), "-o", str(back)]) == 0
    assert yaml.safe_load(back.read_text(encoding="utf-8"))["root"]["message"] == text
    capsys.readouterr()


def test_a_bad_byte_after_lines_ending_in_cr_is_placed_on_its_line(
    tmp_path: Path, capsys: Any
) -> None:
    text = (
        '<?xml version="1.0" encoding="Shift_JIS"?>\r<root BTCPP_format="4">\r'
        '<BehaviorTree ID="M">\r<AlwaysSuccess name="\u65e5"/>\r</BehaviorTree>\r'
    )
    source = tmp_path / "cr.xml"
    source.write_bytes(text.encode("shift_jis") + b"  \x81")
    out = tmp_path / "cr.yaml"
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "cr.xml:6:3: not Shift_JIS text, as its XML declaration says (byte 0x81)" in err
    assert not out.exists()
