"""Probe 16 (hostile tree files, third round): what a user saw, each pinned.

- ``pirate-bt render`` drew a node's name or a parameter holding ``\\N``, ``\\G`` or
  ``\\E`` (a Windows path in a log message: ``C:\\New``) with the node's id or the
  graph's name in its place: Graphviz reads those escapes in an HTML-like label too.
  A line break in a message was drawn as nothing (``x\\ny`` as ``xy``).
- ``pirate-bt import btcpp a.xml -o b.xml`` wrote YAML into ``b.xml`` (replacing the
  XML there), which every reader then refused as "not well-formed XML".
- A blackboard pointer as a subtree port's ``default`` (``{d}``) was refused as "write
  $$d for the literal $d": the XML holds no ``$d``, and ``$$d`` there is the text ``$$d``.
- BT.CPP's ``<Timeout msec>`` and ``<Sleep msec>`` were refused as having "no pirate_bt
  counterpart", though docs/interop.md names ``timeout`` and ``wait`` as their own.
- A third sibling of the same name was told "(first at ...)" the second's place, and
  a key written a third time "(first written on line ...)" the second's line.
- An empty ``choices: []`` or ``statuses: []`` was refused in pydantic's words, without
  its key: "List should have at least 1 item after validation, not 0".
- A subtree no call used was not checked at all: a library of subtrees with a typo in one
  not yet used validated "ok".
- A tag YAML has no value for (``root: !include other.yaml``) was "YAML syntax error:
  could not determine a constructor for the tag", though the syntax is fine.
"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pirate_bt.cli import main

SVG = "{http://www.w3.org/2000/svg}"
needs_dot = pytest.mark.skipif(shutil.which("dot") is None, reason="Graphviz 'dot' missing")


def _texts(svg: Path) -> list[str]:
    return [t.text or "" for t in ET.parse(svg).getroot().iter(f"{SVG}text")]


@needs_dot
def test_backslash_escapes_in_node_names_and_values_are_drawn_as_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        "root:\n"
        "  type: sequence\n"
        "  name: 'seq \\N \\G \\E'\n"
        "  children:\n"
        "    - {type: log, name: 'C:\\Notes', message: 'saved to C:\\New\\Garage\\'}\n"
        '    - {type: log, name: two lines, message: "x\\ny"}\n',
        encoding="utf-8",
    )
    out = tmp_path / "tree.svg"
    assert main(["render", str(tree), "-o", str(out)]) == 0, capsys.readouterr().err
    texts = _texts(out)
    assert "seq \\N \\G \\E" in texts, texts
    assert "C:\\Notes" in texts, texts
    assert "message: saved to C:\\New\\Garage\\" in texts, texts
    assert "message: x\\ny" in texts, texts


@pytest.mark.parametrize("name", ["groot.xml", "tree.txt", "tree"])
def test_import_writes_a_yaml_file_only(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # `import btcpp a.xml -o b.xml` wrote YAML into b.xml (a Groot2 file there was
    # replaced), which every reader then took for XML: "not well-formed XML".
    source = tmp_path / "a.xml"
    assert main(["export", "btcpp", "trees/examples/patrol.yaml", "-o", str(source)]) == 0
    out = tmp_path / name
    out.write_text("<root/>\n", encoding="utf-8")
    capsys.readouterr()
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is written to a .yaml file" in err, err
    assert out.read_text(encoding="utf-8") == "<root/>\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted({"a.xml", name})
    assert main(["import", "btcpp", str(source), "-o", str(tmp_path / "b.YML")]) == 0


@pytest.mark.parametrize("pointer", ["{d}", "{=}"])
@pytest.mark.parametrize("key", ["default", "example"])
def test_a_pointer_as_a_port_s_default_is_refused_in_the_xml_s_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], pointer: str, key: str
) -> None:
    # was "default: '$d': a default names no parameter; write $$d for the literal $d":
    # the XML holds no '$d', and '$$d' there is the text '$$d'
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<?xml version="1.0"?>\n<root BTCPP_format="4" main_tree_to_execute="t">\n'
        '  <BehaviorTree ID="t"><wait duration="{d}"/></BehaviorTree>\n  <TreeNodesModel>\n'
        f'    <SubTree ID="t"><input_port name="d" type="duration" {key}="{pointer}"/></SubTree>\n'
        "  </TreeNodesModel>\n</root>\n",
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    assert capsys.readouterr().err == (
        f"{xml}:5:21: port 'd': {key} '{pointer}' is a blackboard pointer;"
        f" a parameter's {key} is a value, not another parameter\n"
    )


@pytest.mark.parametrize(
    ("node", "instead"),
    [
        ('<Timeout msec="500"><AlwaysSuccess/></Timeout>', '<timeout duration="500 ms">'),
        ('<Sleep msec="250"/>', '<wait duration="250 ms">'),
    ],
)
def test_bt_cpp_s_timeout_and_sleep_name_pirate_bt_s_own_node(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], node: str, instead: str
) -> None:
    # was "has no pirate_bt counterpart (see docs/interop.md)", where the table names them
    xml = tmp_path / "t.xml"
    xml.write_text(
        '<?xml version="1.0"?>\n<root BTCPP_format="4">\n'
        f'  <BehaviorTree ID="t">{node}</BehaviorTree>\n</root>\n',
        encoding="utf-8",
    )
    assert main(["validate", str(xml)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{xml}:3:24: BT.CPP node "), err
    assert f"write pirate_bt's own {instead}" in err and err.count("\n") == 1, err
    fixed = tmp_path / "fixed.xml"
    fixed.write_text(
        xml.read_text(encoding="utf-8")
        .replace('<Timeout msec="500">', instead)
        .replace("</Timeout>", "</timeout>")
        .replace('<Sleep msec="250"/>', instead.replace(">", "/>")),
        encoding="utf-8",
    )
    assert main(["validate", str(fixed)]) == 0, capsys.readouterr().err


def test_a_third_sibling_of_the_same_name_points_at_the_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the third said "(first at 5:7)", the second's place
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root:\n  type: sequence\n  children:\n"
        "    - {type: success, name: a}\n    - {type: failure, name: a}\n"
        "    - {type: running, name: a}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{tree}:5:7: duplicate node name 'a' among siblings (first at {tree}:4:7)",
        f"{tree}:6:7: duplicate node name 'a' among siblings (first at {tree}:4:7)",
    ]


def test_a_key_written_three_times_points_at_the_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the third said "(first written on line 3)", the second's line
    tree = tmp_path / "t.yaml"
    tree.write_text("root: success\nname: a\nname: b\nname: c\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{tree}:3:1: duplicate key 'name' (first written on line 2)",
        f"{tree}:4:1: duplicate key 'name' (first written on line 2)",
    ]


def test_an_empty_list_is_refused_by_its_key_in_the_file_s_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was "List should have at least 1 item after validation, not 0", no key named
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params: {a: {type: string, choices: [], default: x}}\n"
        "root: {type: scripted, statuses: []}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{tree}:1:28: choices: must have at least 1 item, not 0",
        f"{tree}:2:24: scripted: statuses: must have at least 1 item, not 0",
    ]


def test_a_subtree_no_call_uses_is_checked_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was "ok": a library of subtrees with a typo in one not yet used
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root: {type: subtree, ref: used, params: {d: 1 s}}\n"
        "subtrees:\n"
        "  used: {params: {d: duration}, root: {type: wait, duration: $d}}\n"
        "  later: {params: {d: duration}, root: {type: wiat, duration: $d}}\n"
        "  fine: {params: {d: duration}, root: {type: wait, duration: $d}}\n"
        "  loops: {root: {type: subtree, ref: loops}}\n"
        "  typo: {params: {d: duration}, root: {type: wait, duration: $dd}}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"{tree}:4:41: unknown node type 'wiat'; did you mean 'wait'?",
        f"{tree}:6:33: recursive subtree: {tree}#loops -> {tree}#loops",
        f"{tree}:7:52: unknown parameter $dd (parameters: $d)",
    ]


@pytest.mark.parametrize(
    ("value", "tag"),
    [
        ("!include other.yaml", "'!include'"),
        ("!!python/object:os.system {type: success}", "'!!python/object:os.system'"),
    ],
)
def test_an_unknown_tag_is_not_called_a_syntax_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, tag: str
) -> None:
    # was "YAML syntax error: could not determine a constructor for the tag ..."
    tree = tmp_path / "t.yaml"
    tree.write_text(f"root: {value}\n", encoding="utf-8")
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err == (
        f"{tree}:1:7: YAML tag {tag} is not known here: a value is text, a number, a"
        " boolean, a list or a mapping, with no tag but YAML's own (!!str, !!int, !!float,"
        " !!bool)\n"
    )


def test_a_choice_and_a_non_finite_number_are_refused_in_the_file_s_words(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # were "half: Input should be 'front' or 'rear'" (not what was written) and "Input
    # should be a finite number" with no key named: docs/trees.md promises messages in
    # the library's words, never the validator's
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "root:\n"
        "  type: sequence\n"
        "  children:\n"
        "    - {type: clamp, half: middle, torque: 0.5 N*m}\n"
        "    - {type: check_blackboard, key: k, op: '<', value: .nan}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"{tree}:4:21: clamp: half: 'middle' is not one of front, rear",
        f"{tree}:5:49: check_blackboard: value: must be a finite number, not nan",
    ], err


def test_a_number_compared_with_text_says_so_rather_than_only_false(tmp_path: Path) -> None:
    # value="9" in a Groot2 file is text: 5 < '9' cannot be compared, and the failure
    # only said "False" (probe 16); it now says why, and what to write
    import pirate_bt

    xml = tmp_path / "cb.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="cb">\n'
        '  <BehaviorTree ID="cb" _blackboard="json:{&quot;k&quot;:{&quot;default&quot;:5}}">\n'
        '    <check_blackboard key="k" op="&lt;" value="9" />\n'
        "  </BehaviorTree>\n"
        "</root>\n",
        encoding="utf-8",
    )
    result = pirate_bt.simulate_tree(xml)
    assert not result.succeeded
    assert "k=5 < '9': cannot compare int with str" in result.why, result.why
    assert "write json:9 in XML" in result.why
    fixed = xml.read_text(encoding="utf-8").replace('value="9"', 'value="json:9"')
    xml.write_text(fixed, encoding="utf-8")
    assert pirate_bt.simulate_tree(xml).succeeded
