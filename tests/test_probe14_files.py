"""Probe 14 (hostile trees, XML and campaign specs): what a user notices.

A tree parameter whose declaration is refused (an unknown ``type``, a misspelt key,
``choices`` that are not a list) was said twice: at the declaration, and again at
every use as ``unknown parameter $p (parameters: $p)``, a line that contradicts
itself. One mistake is one line (docs/trees.md, Static checks).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from pirate_bt.cli import main

_DECLS = {
    "type": "p: {type: strin, default: c}",
    "key": "p: {type: string, default: c, bogus: 1}",
    "choices": "p: {type: string, default: c, choices: a}",
    "empty choices": "p: {type: string, default: c, choices: []}",
    "choices of a number": "p: {type: number, default: 1, choices: [1]}",
}


@pytest.mark.parametrize("decl", list(_DECLS.values()), ids=list(_DECLS))
def test_a_refused_parameter_declaration_is_one_line(
    tmp_path: Path, decl: str, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(f"params:\n  {decl}\nroot: {{type: log, message: $p}}\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{tree}:2:"), lines
    assert "unknown parameter" not in lines[0]


def test_a_refused_subtree_parameter_declaration_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root: {type: subtree, ref: s}\n"
        "subtrees:\n"
        "  s:\n"
        "    params: {p: {type: strin, default: c}}\n"
        "    root: {type: log, message: $p}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines
    assert f"{tree}:4:" in lines[0]


def test_a_refused_choices_in_xml_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="m">\n'
        '  <BehaviorTree ID="m"><log message="{p}"/></BehaviorTree>\n'
        '  <TreeNodesModel><SubTree ID="m">\n'
        '    <input_port name="p" type="string" default="c" choices="a;b"/>\n'
        "  </SubTree></TreeNodesModel>\n"
        "</root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines
    assert f"{xml}:4:5: " in lines[0]


# BehaviorTree.CPP reads a <BehaviorTree> without an ID when it is the only element
# under <root> (xml_parsing.cpp: VerifyXML, then "BehaviorTree_0"); pirate_bt refused
# it ("<BehaviorTree> without an ID").
_NO_ID = (
    '<root BTCPP_format="4">\n'
    "  <BehaviorTree>\n"
    '    <Sequence><AlwaysSuccess/><wait duration="100 ms"/></Sequence>\n'
    "  </BehaviorTree>\n"
    "</root>\n"
)


def test_a_lone_behaviour_tree_without_an_id_runs_as_btcpp_reads_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from pirate_bt import load_tree, simulate_tree

    xml = tmp_path / "lone.xml"
    xml.write_text(_NO_ID, encoding="utf-8")
    assert main(["validate", str(xml)]) == 0, capsys.readouterr().err
    assert load_tree(xml).name == "lone"  # no ID, no name: the file's, as a YAML tree's
    assert simulate_tree(xml).status == "success"


@pytest.mark.parametrize(
    "extra",
    [
        '  <BehaviorTree ID="b"><AlwaysSuccess/></BehaviorTree>\n',
        "  <TreeNodesModel/>\n",
    ],
)
def test_a_behaviour_tree_without_an_id_beside_another_element_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: str
) -> None:
    xml = tmp_path / "two.xml"
    xml.write_text(_NO_ID.replace("</root>", f"{extra}</root>"), encoding="utf-8")
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{xml}:2:3: <BehaviorTree> without an ID" in err, err


@pytest.mark.parametrize(
    "node",
    ['<wait ID="sleep" duration="1 s"/>', '<Sequence ID="x"><AlwaysSuccess/></Sequence>'],
)
def test_an_id_on_a_node_named_by_its_tag_is_refused_as_btcpp_refuses_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], node: str
) -> None:
    # BT.CPP: "Attribute [ID] is not allowed in <wait>"; pirate_bt dropped it silently,
    # so the file ran here and not in BT.CPP (and <wait ID="sleep"> looked like a Sleep)
    xml = tmp_path / "t.xml"
    xml.write_text(
        f'<root BTCPP_format="4">\n  <BehaviorTree ID="m">\n    {node}\n'
        "  </BehaviorTree>\n</root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{xml}:3:5: " in err and "ID" in err, err


@pytest.mark.parametrize("value", ["1_0", "\u0663", "\uff13"])
def test_an_xml_count_is_written_in_ascii_digits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    # Python's int() took '1_0' as 10 and Arabic-Indic or full-width digits as 3, where
    # BT.CPP refuses them and a --param is refused them (docs/trees.md)
    xml = tmp_path / "t.xml"
    xml.write_text(
        f'<root BTCPP_format="4"><BehaviorTree ID="m">\n'
        f'  <RetryUntilSuccessful num_attempts="{value}"><AlwaysSuccess/></RetryUntilSuccessful>\n'
        "</BehaviorTree></root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{xml}:2:3: num_attempts: expected an integer" in err, err


@pytest.mark.parametrize("value", ["1_0", "\u0663", "1_0.5"])
def test_an_xml_number_port_default_is_written_in_ascii_digits(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4"><BehaviorTree ID="m"><AlwaysSuccess/></BehaviorTree>\n'
        '<TreeNodesModel><SubTree ID="m">\n'
        f'  <input_port name="x" type="number" default="{value}"/>\n'
        "</SubTree></TreeNodesModel></root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{xml}:3:3: " in err and "expected a number" in err, err


@pytest.mark.parametrize("value", ["False", "FALSE", "false", "0"])
def test_autoremap_false_as_btcpp_spells_it_is_accepted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    # BT.CPP reads False and FALSE as false; they were refused as "_autoremap is not
    # supported", as if the call asked for it
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="m">\n'
        f'  <BehaviorTree ID="m"><SubTree ID="s" _autoremap="{value}"/></BehaviorTree>\n'
        '  <BehaviorTree ID="s"><AlwaysSuccess/></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 0, capsys.readouterr().err
