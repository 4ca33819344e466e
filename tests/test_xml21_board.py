"""A BT.CPP XML tree's blackboard said in the XML's words (docs/interop.md, Metadata).

An XML tree declares its blackboard keys in a ``<BehaviorTree>``'s ``_blackboard``
attribute, JSON after the ``json:`` prefix. A key read but not declared was said
*not declared under 'blackboard:'* (the YAML's words); ``_blackboard='{"k": ...}'``
without ``json:`` was said to be a *blackboard pointer*; a subtree's ``_blackboard``
was dropped unread.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pirate_bt.cli import main

_MAIN = (
    '<root BTCPP_format="4" main_tree_to_execute="m">\n'
    '<BehaviorTree ID="m"{board}>\n{body}\n</BehaviorTree>\n{more}</root>\n'
)


def _validate(tmp_path: Path, capsys: pytest.CaptureFixture[str], **parts: str) -> tuple[int, str]:
    xml = tmp_path / "t.xml"
    xml.write_text(_MAIN.format(**{"board": "", "more": "", **parts}), encoding="utf-8")
    code = main(["validate", str(xml)])
    return code, capsys.readouterr().err.replace(str(xml), "t.xml")


@pytest.mark.parametrize(
    ("body", "verb"),
    [
        ('<check_blackboard key="ready" op="is_set"/>', "read"),
        ('<set_blackboard key="ready" value="json:1"/>', "written"),
    ],
)
def test_an_undeclared_key_is_told_to_be_declared_in_a_blackboard_attribute(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], body: str, verb: str
) -> None:
    code, err = _validate(tmp_path, capsys, body=body)
    assert code == 2
    assert err == (
        f"t.xml:3:1: blackboard key 'ready' is {verb} but not declared in a <BehaviorTree>'s"
        """ _blackboard attribute (_blackboard='json:{"ready": {"type": "number"}}',"""
        " with the key's type)\n"
    ), err


def test_a_blackboard_attribute_without_the_json_prefix_is_told_to_take_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    board = """ _blackboard='{"ready": {"type": "integer", "default": 1}}'"""
    code, err = _validate(
        tmp_path, capsys, board=board, body='<check_blackboard key="ready" op="is_set"/>'
    )
    assert code == 2
    assert err == (
        "t.xml:2:1: _blackboard: JSON needs the json: prefix, as in"
        """ _blackboard='json:{"k": {"type": "number"}}'\n"""
    ), err
    assert "pointer" not in err


def test_json_without_its_prefix_in_a_node_s_port_is_told_to_take_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    board = """ _blackboard='json:{"ready": {"type": "integer", "default": 1}}'"""
    body = """<check_blackboard key="ready" op="==" value='{"a": 1}'/>"""
    code, err = _validate(tmp_path, capsys, board=board, body=body)
    assert code == 2
    assert err.count("\n") == 1 and "JSON needs the json: prefix (json:{...})" in err, err
    assert "parameters are identifiers" not in err


_SUBTREE = (
    '<BehaviorTree ID="s"{board}>'
    '<check_blackboard key="ready" op="==" value="json:1"/></BehaviorTree>\n'
)


def test_a_subtree_s_blackboard_attribute_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    board = """ _blackboard='json:{"ready": {"type": "integer", "default": 1}}'"""
    xml, out = tmp_path / "t.xml", tmp_path / "t.yaml"
    xml.write_text(
        _MAIN.format(board="", body='<SubTree ID="s"/>', more=_SUBTREE.format(board=board)),
        encoding="utf-8",
    )
    assert main(["import", "btcpp", str(xml), "-o", str(out)]) == 0, capsys.readouterr().err
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    assert data["blackboard"] == {"ready": {"type": "integer", "default": 1}}


def test_a_key_two_trees_declare_otherwise_is_refused_at_the_second(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = """ _blackboard='json:{"ready": {"type": "integer", "default": 1}}'"""
    second = """ _blackboard='json:{"ready": {"type": "number"}}'"""
    code, err = _validate(
        tmp_path, capsys, board=first, body='<SubTree ID="s"/>', more=_SUBTREE.format(board=second)
    )
    assert code == 2
    assert err == (
        "t.xml:5:1: _blackboard: key 'ready' is declared otherwise by another <BehaviorTree>"
        " of the file; a file has one blackboard\n"
    ), err


@pytest.mark.parametrize(
    ("declared", "value", "advice"),
    [
        (
            "integer",
            "5",
            "(text never equals a number and cannot be ordered with one; a number"
            ' is written value="json:5")',
        ),
        ("string", "json:5", "(text never equals it; for text, write the value without json:)"),
        ("boolean", "yes", "(write json:true or json:false)"),
    ],
)
def test_a_value_of_the_wrong_kind_is_told_how_xml_writes_the_right_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], declared: str, value: str, advice: str
) -> None:
    # the loader's advice was YAML's ("quote it for text", "write true or false"): in XML
    # value="5" is text and value="json:5" a number
    board = f""" _blackboard='json:{{"ready": {{"type": "{declared}"}}}}'"""
    body = f'<set_blackboard key="ready" value="{value}"/>'
    code, err = _validate(tmp_path, capsys, board=board, body=body)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("t.xml:3:1: set_blackboard: value: "), err
    assert err.endswith(f"is declared {declared} {advice}\n"), err
