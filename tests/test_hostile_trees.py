"""Hostile tree files: YAML and BT.CPP XML written to break the loader, not to run.

Each case gives one clear line at ``file:line:column`` (or at the XML element),
exit code 2 through ``pirate-bt``, no traceback, no output file; through the
API the library's own :class:`~pirate_bt.errors.ValidationFailed` or
:class:`~pirate_bt.errors.LocatedError`, never a ``RecursionError``,
``TypeError`` or ``MemoryError``.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import InputError, ValidationFailed
from pirate_bt.interop.btcpp import export_xml, import_xml
from pirate_bt.robot import load_robot
from pirate_bt.treefile import load_tree
from tests.hostile_support import run_import_cli


def _validate(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str | bytes, **files: str
) -> tuple[int, list[str]]:
    for name, body in files.items():
        (tmp_path / name).write_text(body, encoding="utf-8")
    tree = tmp_path / "tree.yaml"
    if isinstance(text, bytes):
        tree.write_bytes(text)
    else:
        tree.write_text(text, encoding="utf-8")
    code = main(["validate", "--kind", "tree", str(tree)])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "internal error" not in captured.err
    return code, captured.err.splitlines()


def _where(tmp_path: Path, place: str, name: str = "tree.yaml") -> str:
    return f"{tmp_path / name}:{place}: "


# -- YAML ----------------------------------------------------------------------------


def test_a_recursive_alias_is_refused_not_expanded_for_ever(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = _validate(tmp_path, capsys, "root: &a [*a]\n")
    assert code == 2
    assert err == [
        _where(tmp_path, "1:7") + "YAML alias inside the value it names (a recursive alias)"
    ]


def test_a_whole_number_too_long_for_python_is_located(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "root: {type: retry, attempts: " + "9" * 5000 + ", child: success}\n"
    code, err = _validate(tmp_path, capsys, text)
    assert code == 2
    assert err == [_where(tmp_path, "1:31") + "a number of 5000 digits is too long"]


def test_a_mapping_as_a_key_is_named_in_the_words_of_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = _validate(tmp_path, capsys, "root: success\n? {a: 1}\n: 1\n")
    assert code == 2
    assert err == [_where(tmp_path, "2:3") + "a key must be a plain value, not a mapping"]


def test_a_value_merged_from_a_list_of_mappings_is_located_where_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = _validate(tmp_path, capsys, "root:\n  <<: [{type: wait}, {duration: 2}]\n")
    assert (code, err) == (
        2,
        [_where(tmp_path, "2:23") + "wait: 2 needs a unit: write it as e.g. '2 s'"],
    )


def test_utf16_is_named_as_such(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _validate(tmp_path, capsys, "root: success\n".encode("utf-16"))
    assert code == 2
    assert err == [_where(tmp_path, "1:1") + "UTF-16 text; save the file as UTF-8"]


def test_values_nested_990_deep_are_refused_without_recursion_error(tmp_path: Path) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text("description: " + "[" * 990 + "]" * 990 + "\nroot: success\n")
    with pytest.raises(ValidationFailed) as caught:
        load_tree(tree)
    assert [e.message for e in caught.value.errors] == ["values nested deeper than 256 levels"]


def test_a_large_file_without_aliases_is_not_called_an_alias_bomb(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("pirate_bt.yamlfile.MAX_NODES", 1000)  # keeps the test fast
    tree = tmp_path / "tree.yaml"
    tree.write_text("description: [" + "0," * 1001 + "0]\nroot: success\n")
    with pytest.raises(ValidationFailed) as caught:
        load_tree(tree)
    assert [str(e) for e in caught.value.errors] == [
        f"{tree}:1:14: this holds more than 1000 values; a file this large is not one a person"
        " writes"
    ]
    bomb = "a: &a [0, 0, 0, 0, 0, 0, 0, 0, 0, 0]\nb: &b [*a, *a, *a, *a, *a, *a, *a]\n"
    tree.write_text(bomb + "c: [" + ", ".join(["*b"] * 15) + "]\n")
    with pytest.raises(ValidationFailed, match="YAML aliases expand this to more than 1000"):
        load_tree(tree)


def test_a_subtree_name_that_is_not_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a key is its text (docs/trees.md): the subtree written `1:` is the subtree '1'
    # (before probe 12 it was the number 1, refused as "subtree name 1 must be text")
    code, err = _validate(
        tmp_path, capsys, "root: {type: subtree, ref: '1'}\nsubtrees:\n  1: {root: success}\n"
    )
    assert (code, err) == (0, [])
    code, err = _validate(tmp_path, capsys, "root: {type: subtree, ref: a}\nsubtrees: [a]\n")
    assert code == 2
    assert err == [_where(tmp_path, "2:1") + "subtrees: a mapping of name -> tree"]


CLAMP_FRONT = """name: clamp-front
root:
  type: retry
  name: clamp front
  attempts: 2
  child: success
"""


@pytest.mark.parametrize(
    ("tree", "first", "second"),
    [
        (  # two calls of one file: the included root's name is the file's
            "root:\n  type: sequence\n  children:\n"
            "    - {type: subtree, ref: lib.yaml}\n"
            "    - {type: subtree, ref: lib.yaml}\n",
            "4:7",
            "5:7",
        ),
        (  # a call naming the included root, a call of a subtree whose root is a call
            "root:\n  type: sequence\n  children:\n"
            "    - {type: subtree, ref: lib.yaml, name: clamp front}\n"
            "    - {type: subtree, ref: again}\n"
            "subtrees:\n  again: {root: {type: subtree, ref: lib.yaml}}\n",
            "4:7",
            "5:7",
        ),
    ],
    ids=["file", "nested"],
)
def test_duplicate_subtree_calls_are_reported_at_the_calls(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], tree: str, first: str, second: str
) -> None:
    # Was "lib.yaml:4:1: duplicate node name 'clamp front' among siblings (first at
    # lib.yaml:4:1)": the included root's place, twice, where nothing is wrong.
    code, err = _validate(tmp_path, capsys, tree, **{"lib.yaml": CLAMP_FRONT})
    assert (code, err) == (
        2,
        [
            _where(tmp_path, second)
            + "duplicate node name 'clamp front' among siblings"
            + f" (first at {tmp_path / 'tree.yaml'}:{first})"
        ],
    )


def test_an_unknown_parameter_is_one_line_not_two(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    unknown = "unknown parameter $pause (parameters: none declared)"
    code, err = _validate(tmp_path, capsys, "root: {type: wait, duration: $pause}\n")
    assert (code, err) == (2, [_where(tmp_path, "1:20") + unknown])
    code, err = _validate(
        tmp_path, capsys, "root: {type: sequence, memory: $pause, children: [success]}\n"
    )
    assert (code, err) == (2, [_where(tmp_path, "1:24") + unknown])


def test_names_and_descriptions_are_checked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = _validate(tmp_path, capsys, 'root: {type: success, name: "a\\x1b[31mb"}\n')
    assert (code, err) == (
        2,
        [_where(tmp_path, "1:23") + "name: must not contain control characters"],
    )
    code, err = _validate(tmp_path, capsys, "description: [a]\nroot: success\n")
    assert (code, err) == (2, [_where(tmp_path, "1:1") + "description: must be text"])


def test_the_tree_s_name_follows_the_rules_of_the_node_name_it_becomes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for name, problem in [
        ("a/b", "name: must not contain '/' (used in node paths)"),
        ("a\\x1bb", "name: must not contain control characters"),
        ("  ", "name: must be non-empty text"),
    ]:
        code, err = _validate(tmp_path, capsys, f'name: "{name}"\nroot: success\n')
        assert (code, err) == (2, [_where(tmp_path, "1:1") + problem])
    code, err = _validate(tmp_path, capsys, 'name: "a/b"\nroot: {type: success, name: s}\n')
    assert (code, err) == (0, [])  # the root keeps its own name


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("root: {type: " + "w" * 100_000 + "}\n", "unknown node type 'www"),
        ("root: {type: subtree, ref: " + "k" * 100_000 + "}\n", "no subtree named 'kkk"),
        ("root: {type: log, message: $" + "p" * 100_000 + "}\n", "unknown parameter $ppp"),
    ],
)
def test_a_huge_name_is_cut_short_in_the_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    code, err = _validate(tmp_path, capsys, text)
    assert code == 2 and len(err) == 1
    assert message in err[0] and "..." in err[0] and len(err[0]) < len(str(tmp_path)) + 150


def _inverters(levels: int) -> str:
    node = "success"
    for _ in range(levels):
        node = "{type: inverter, child: " + node + "}"
    return "root: " + node + "\n"


def test_a_tree_100_deep_loads_and_101_deep_is_refused_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = _validate(tmp_path, capsys, _inverters(99))  # 100 nodes deep
    assert (code, err) == (0, [])
    code, err = _validate(tmp_path, capsys, _inverters(100))
    assert code == 2
    assert err == [
        _where(tmp_path, "1:2400") + "nodes nested deeper than 100 levels (subtrees included)"
    ]


def test_a_long_chain_of_subtrees_is_refused_without_recursion_error(tmp_path: Path) -> None:
    lines = ["root: {type: subtree, ref: s0}", "subtrees:"]
    lines += [f"  s{i}: {{root: {{type: subtree, ref: s{i + 1}}}}}" for i in range(400)]
    lines.append("  s400: {root: success}")
    tree = tmp_path / "tree.yaml"
    tree.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValidationFailed) as caught:
        load_tree(tree)
    (error,) = caught.value.errors
    assert error.message == "nodes nested deeper than 100 levels (subtrees included)"
    assert (error.location.line, error.location.column) == (102, 9)


def _laughs(levels: int) -> str:
    lines = ["root: {type: subtree, ref: s0}", "subtrees:"]
    for i in range(levels):
        twice = f"{{type: subtree, ref: s{i + 1}}}"
        lines.append(f"  s{i}: {{root: {{type: sequence, children: [{twice}, {twice}]}}}}")
    lines.append(f"  s{levels}: {{root: success}}")
    return "\n".join(lines) + "\n"


def test_subtrees_that_double_at_each_level_are_refused_quickly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 2**30 nodes once expanded; the limit is lowered to keep the test fast.
    monkeypatch.setattr("pirate_bt.treefile.reader.MAX_TREE_NODES", 1000)
    tree = tmp_path / "tree.yaml"
    tree.write_text(_laughs(30))
    with pytest.raises(ValidationFailed) as caught:
        load_tree(tree)
    (error,) = caught.value.errors
    assert error.message == "the tree expands to more than 1000 nodes (subtrees included)"


def test_api_trees_that_are_not_mappings_or_nest_for_ever_are_refused() -> None:
    with pytest.raises(ValidationFailed, match="a tree is a mapping with a 'root' key or a"):
        load_tree(["root", "success"])  # type: ignore[arg-type]
    value: list[object] = []
    value.append(value)  # a list that holds itself
    node = {"type": "log", "message": "x"}
    node["message"] = value  # type: ignore[assignment]
    deep: object = "success"
    for _ in range(3000):
        deep = {"type": "inverter", "child": deep}
    for tree in ({"root": node}, {"root": deep}):
        with pytest.raises(ValidationFailed) as caught:
            load_tree(tree)
        assert [str(e) for e in caught.value.errors] == [
            "<dict>:1:1: values nested deeper than 256 levels (or a value that contains itself)"
        ]


# -- BT.CPP XML ---------------------------------------------------------------------------


def _xml(body: str, main_tree: str = "A", head: str = '<?xml version="1.0"?>') -> str:
    return f'{head}\n<root BTCPP_format="4" main_tree_to_execute="{main_tree}">\n{body}\n</root>\n'


def _at(tmp_path: Path, place: str) -> str:
    return f"pirate-bt: {tmp_path / 't.xml'}:{place}: "


def test_an_unknown_xml_encoding_is_located(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    head = '<?xml version="1.0" encoding="bogus-enc"?>'
    code, err = run_import_cli(
        tmp_path, capsys, _xml('<BehaviorTree ID="A"><AlwaysSuccess/></BehaviorTree>', head=head)
    )
    assert (code, err) == (
        2,
        [_at(tmp_path, "1:1") + "XML declaration: unknown encoding: bogus-enc"],
    )


def test_a_device_that_never_ends_is_cut_off_not_read_into_memory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("pirate_bt.yamlfile.MAX_BYTES", 1000)
    with pytest.raises(ValidationFailed) as caught:
        load_tree("/dev/zero")
    assert [str(e) for e in caught.value.errors] == [
        "/dev/zero:1:1: larger than the 1000 bytes a file may be"
    ]
    monkeypatch.undo()  # the robot file is longer than that
    monkeypatch.setattr("pirate_bt.interop.btcpp_xml.MAX_XML_BYTES", 1000)
    code = main(["import", "btcpp", "/dev/zero", "-o", str(tmp_path / "t.yaml")])
    assert code == 2
    assert capsys.readouterr().err.splitlines() == [
        "pirate-bt: /dev/zero:1:1: larger than the 1000 bytes a tree file may be"
    ]
    assert list(tmp_path.iterdir()) == []


def test_a_missing_or_unreadable_xml_file_is_located_like_a_yaml_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for source, message in [(tmp_path / "t.xml", "no such file"), (tmp_path, "is a directory")]:
        code = main(["import", "btcpp", str(source), "-o", str(tmp_path / "t.yaml")])
        err = capsys.readouterr().err.splitlines()
        assert code == 2
        assert len(err) == 1 and err[0].startswith(f"pirate-bt: {source}:1:1: {message}")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("json:" + "[" * 5000 + "]" * 5000, "bad json: nested deeper than 32 levels"),
        ("json:NaN", "bad json: value: NaN is not a JSON number"),
        ("json:1e999", "bad json: value: '1e999' is not a finite number"),
    ],
)
def test_json_port_values_are_bounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, message: str
) -> None:
    body = f'<BehaviorTree ID="A"><wait duration="{value}"/></BehaviorTree>'
    code, err = run_import_cli(tmp_path, capsys, _xml(body))
    assert (code, err) == (2, [_at(tmp_path, "3:22") + "wait: duration: " + message])


def test_a_chain_of_1200_subtrees_is_refused_without_recursion_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trees = [
        f'<BehaviorTree ID="s{i}"><SubTree ID="s{i + 1}"/></BehaviorTree>' for i in range(1200)
    ]
    trees.append('<BehaviorTree ID="s1200"><SubTree ID="s0"/></BehaviorTree>')
    code, err = run_import_cli(tmp_path, capsys, _xml("\n".join(trees), main_tree="s0"))
    # its middle left out (one line of the whole chain was 10 kB here; session 21)
    loop = "s0 -> s1 -> s2 -> s3 -> s4 -> ... (1192 more) -> s1197 -> s1198 -> s1199 -> s1200 -> s0"
    assert (code, err) == (2, [_at(tmp_path, "1203:26") + f"recursive subtree: {loop}"])
    # 200 trees, each the only node of the one before: 200 levels once expanded.
    trees = [*trees[:200], '<BehaviorTree ID="s200"><AlwaysSuccess/></BehaviorTree>']
    code, err = run_import_cli(tmp_path, capsys, _xml("\n".join(trees), main_tree="s0"))
    assert (code, err) == (
        2,
        [_at(tmp_path, "103:25") + "nodes nested deeper than 100 levels (subtrees included)"],
    )


def test_xml_nested_200_deep_is_refused_at_the_element(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    body = '<BehaviorTree ID="A">' + "<Sequence>" * 200 + "<AlwaysSuccess/>"
    body += "</Sequence>" * 200 + "</BehaviorTree>"
    code, err = run_import_cli(tmp_path, capsys, _xml(body))
    assert (code, err) == (2, [_at(tmp_path, "3:1022") + "nodes nested deeper than 100 levels"])


def test_subtrees_that_double_in_xml_are_refused_at_the_element(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("pirate_bt.treefile.reader.MAX_TREE_NODES", 1000)
    trees = [
        f'<BehaviorTree ID="s{i}"><Sequence><SubTree ID="s{i + 1}"/><SubTree ID="s{i + 1}"/>'
        "</Sequence></BehaviorTree>"
        for i in range(30)
    ]
    trees.append('<BehaviorTree ID="s30"><AlwaysSuccess/></BehaviorTree>')
    code, err = run_import_cli(tmp_path, capsys, _xml("\n".join(trees), main_tree="s0"))
    assert code == 2
    (line,) = err
    assert line.startswith(f"pirate-bt: {tmp_path / 't.xml'}:")
    assert line.endswith(": the tree expands to more than 1000 nodes (subtrees included)")


def test_xml_too_large_for_a_tree_file_is_refused_in_the_xml(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    body = (
        '<BehaviorTree ID="A"><Sequence>' + "<AlwaysSuccess/>" * 50 + "</Sequence></BehaviorTree>"
    )
    monkeypatch.setattr("pirate_bt.interop.btcpp_import.MAX_NODES", 100)
    code, err = run_import_cli(tmp_path, capsys, _xml(body))
    assert (code, err) == (
        2,
        [
            _at(tmp_path, "2:1") + "the tree converts to more than 100 values, more than a tree"
            " file may hold"
        ],
    )
    monkeypatch.undo()
    robot = load_robot()
    monkeypatch.setattr("pirate_bt.yamlfile.MAX_NODES", 100)  # the loader's own check
    with pytest.raises(ValidationFailed) as caught:
        import_xml(tmp_path / "t.xml", tmp_path / "t.yaml", robot=robot)
    assert [str(e) for e in caught.value.errors] == [
        f"{tmp_path / 't.xml'}:3:1: this holds more than 100 values; a file this large is not"
        " one a person writes"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.xml"]


@pytest.mark.parametrize(
    ("node", "message"),
    [
        ("<" + "w" * 60_000 + "/>", "unknown node type 'www"),
        ('<wait duration="1 s" ' + "k" * 60_000 + '="1"/>', "wait: unknown port 'kkk"),
    ],
)
def test_a_huge_xml_name_is_cut_short_in_the_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], node: str, message: str
) -> None:
    code, err = run_import_cli(
        tmp_path, capsys, _xml(f'<BehaviorTree ID="A">{node}</BehaviorTree>')
    )
    assert code == 2 and len(err) == 1
    assert message in err[0] and "..." in err[0] and len(err[0]) < len(str(tmp_path)) + 150


def test_a_message_names_places_in_the_xml_never_the_temporary_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    body = (
        '<BehaviorTree ID="A"><Sequence><AlwaysSuccess name="x"/><AlwaysSuccess name="x"/>'
        "</Sequence></BehaviorTree>"
    )
    code, err = run_import_cli(tmp_path, capsys, _xml(body))
    first = f"{tmp_path / 't.xml'}:3:32"
    assert (code, err) == (
        2,
        [_at(tmp_path, "3:57") + f"duplicate node name 'x' among siblings (first at {first})"],
    )


def test_an_unknown_pointer_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    body = '<BehaviorTree ID="A"><wait duration="{d}"/></BehaviorTree>'
    code, err = run_import_cli(tmp_path, capsys, _xml(body))
    assert (code, err) == (
        2,
        [
            _at(tmp_path, "3:22") + "{d}: the <BehaviorTree> this node is in has no port 'd'"
            " (its ports: none declared); declare it in that tree's <SubTree> model in"
            ' <TreeNodesModel>: <input_port name="d"/>'
        ],
    )


@pytest.mark.parametrize(
    ("body", "place", "message"),
    [
        (
            '<BehaviorTree ID="A"><SubTree ID="x.yaml"/></BehaviorTree>'
            '<BehaviorTree ID="x.yaml"><AlwaysSuccess/></BehaviorTree>',
            "3:59",
            "tree ID 'x.yaml' would read as a file in a pirate_bt subtree reference:"
            " no '#', no .yaml or .yml ending",
        ),
        (
            '<BehaviorTree ID="A"><SubTree ID="B" x="1"/></BehaviorTree>'
            '<BehaviorTree ID="B"><AlwaysSuccess/></BehaviorTree><TreeNodesModel>'
            '<SubTree ID="B"><input_port name="x" type="integer"/></SubTree><SubTree ID="B"/>'
            "</TreeNodesModel>",
            "3:191",
            "a second <SubTree ID='B'> model (first at {xml}:3:128)",
        ),
        (
            '<BehaviorTree ID="A"><SubTree ID="B" x="1"/></BehaviorTree>'
            '<BehaviorTree ID="B"><AlwaysSuccess/></BehaviorTree><TreeNodesModel>'
            '<SubTree ID="B"><input_port name="x" type="integer"/><input_port name="x"/>'
            "</SubTree></TreeNodesModel>",
            "3:181",
            "a second input_port 'x' in <SubTree ID='B'>",
        ),
    ],
)
def test_ids_and_models_that_would_be_misread(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], body: str, place: str, message: str
) -> None:
    code, err = run_import_cli(tmp_path, capsys, _xml(body))
    xml = tmp_path / "t.xml"
    assert (code, err) == (2, [_at(tmp_path, place) + message.format(xml=xml)])


# -- output files ------------------------------------------------------------------------


def test_a_fifo_as_the_output_is_refused_not_replaced(tmp_path: Path) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text("root: success\n")
    fifo = tmp_path / "out.xml"  # a name export takes: the fifo is what is refused
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="is not a regular file; nothing written"):
        export_xml(tree, fifo)
    source = tmp_path / "t.xml"
    source.write_text(_xml('<BehaviorTree ID="A"><AlwaysSuccess/></BehaviorTree>'))
    with pytest.raises(InputError, match="is not a regular file; nothing written"):
        import_xml(source, fifo)
    assert fifo.is_fifo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.xml", "t.xml", "tree.yaml"]


def test_an_output_that_is_the_input_is_refused_and_the_input_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text("root: success\n")
    assert main(["export", "btcpp", str(tree), "-o", str(tree)]) == 2
    source = tmp_path / "t.xml"
    source.write_text(_xml('<BehaviorTree ID="A"><AlwaysSuccess/></BehaviorTree>'))
    assert main(["import", "btcpp", str(source), "-o", str(source)]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"pirate-bt: {tree}: is the tree file being exported; nothing written",
        f"pirate-bt: {source}: is the XML file being imported; nothing written",
    ]
    assert tree.read_text() == "root: success\n"
    assert source.read_text().startswith("<?xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.xml", "tree.yaml"]


def test_control_characters_are_exported_as_well_formed_xml(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    tree = tmp_path / "tree.yaml"
    tree.write_text('root: {type: log, message: "red \\x1b[31m and nul \\0"}\n')
    assert main(["export", "btcpp", str(tree), "-o", str(tmp_path / "t.xml")]) == 0
    assert (
        main(["import", "btcpp", str(tmp_path / "t.xml"), "-o", str(tmp_path / "back.yaml")]) == 0
    )
    back = load_tree(tmp_path / "back.yaml")
    assert back.spec.params.message == "red \x1b[31m and nul \x00"
    tree.write_text('description: "bell \\a"\nroot: success\n')
    capsys.readouterr()
    assert main(["export", "btcpp", str(tree), "-o", str(tmp_path / "d.xml")]) == 2
    assert capsys.readouterr().err.splitlines() == [
        f"pirate-bt: {tree}:1:1: description: U+0007 cannot be written in XML"
    ]
    assert not (tmp_path / "d.xml").exists()
