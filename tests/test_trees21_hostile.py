"""Session 21: hostile tree files, YAML and BehaviorTree.CPP v4 XML (docs/trees.md,
docs/interop.md), what the earlier probes (test_probe8..20_trees, _xml, test_hostile_trees)
left.

Findings, each with its test below:

- a subtree's name (a ``subtrees:`` key, a BT.CPP ``<BehaviorTree ID>``) or a subtree
  file's path holding a control character (ESC, CR: ``"a\\x1b[2J"``, ``ID="a&#xD;b"``)
  went raw into the one line said of it: a recursion's chain (*recursive subtree: a
  <CR>b -> a<CR>b*), *no subtree named 'x' in FILE* and export's *NAME: U+001B cannot be
  written in XML*. On a terminal the line was rewritten or the screen cleared, where a
  node's name with one is refused and a file's path at the line's start is escaped;
- a tree whose node's name (or the tree's) is longer than Graphviz takes in a label
  (16,384 characters) was not drawn; at 200,000 characters Graphviz stopped reading
  half-way, the BrokenPipeError went out of ``render_tree`` and ``pirate-bt render``
  took it for its own output closed: exit 0, the ``.dot`` written, no picture, not a
  word. A diagram now shows at most 80 characters of a name (its end as ``…``, as a
  parameter's 40), and dot is fed so that its exit and words are said however it stops;
- each ``ref`` to no subtree was compared with every subtree of the file for its *did
  you mean*: a file of 3,000 such refs and 3,000 subtrees took five minutes to validate
  (0.1 ms a comparison of similar names). One load now compares at most
  ``SUGGESTION_BUDGET`` (20,000) names for its hints; the lines past it have none;
- a blackboard key declared under a name that is a Python identifier but not ASCII
  (``café:``) was taken, where ``pirate-bt schema tree`` refuses it and every node's
  ``key`` refuses it as *must be an identifier (letters, digits and _, ...)*, which
  ``café`` is: it is refused where it is declared now, and the words say ASCII;
- a YAML file of more values than any file kind holds was refused only once PyYAML had
  composed its node graph (about 1 kB a value): a 7 MB flow mapping of 600,000 keys took
  1.2 GB of memory and 30 s before *this holds more than 100000 values*. A large text's
  values are now counted on the event stream first (``yamlfile.count``), with the same
  words at the same place;
- a guard's comparison written with check_blackboard's ``op: is_set`` (and so no
  ``value``) was one mistake said in two lines, *missing required key 'value'* and
  *op: 'is_set' is not one of ...*: it is one line now, naming check_blackboard;
- a parameter declared as ``x`` + U+212A KELVIN SIGN (refused: not ASCII) and used as
  ``$xK`` was said as *parameter name 'xK' must be an identifier of ASCII letters ...*
  and *unknown parameter $xK (parameters: $xK)*: two names shown alike, the second
  line listing the refused one as declared. The refusal names the character
  (*('K' is U+212A KELVIN SIGN)*), and a refused name is not listed;
- a BT.CPP ``<SubTree>`` call with a port its model does not declare listed every port
  of the model, whole: 5,000 ports of 200-character names made one line of 1 MB. It
  lists 20, each cut, as the YAML loader's *unknown parameter* does;
- a loop through 10,000 BT.CPP trees (``T0`` calls ``T1`` ... calls ``T0``) was said with
  its whole chain, one line of 89 kB: a long chain is said with its middle left out;
- a value tagged ``!!null`` whatever its text was null (PyYAML's reading): a node's
  ``name: !!null grip`` loaded as no name, a parameter's ``default: !!null 5 s`` as no
  default, without a word, and ``level: !!null error`` was said to be *null is not one
  of ...*; a value tagged ``!!timestamp`` was taken whatever its text (``message:
  !!timestamp hello``), where ``!!int abc`` and ``!!bool 3`` are refused at their place.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.errors import ValidationFailed
from pirate_bt.yamlfile import load_yaml_text


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


def test_a_null_tag_on_text_is_refused_where_it_is_not_taken_for_no_value(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params: {p: {type: duration, default: !!null 5 s}}\n"
        "root:\n  type: sequence\n  children:\n"
        "    - {type: wait, name: !!null grip, duration: $p}\n"
        "    - {type: log, message: !!timestamp hello, level: !!null error}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"{tree}:1:39: a YAML !!null value is null, ~ or nothing, not '5 s'",
        f"{tree}:5:26: a YAML !!null value is null, ~ or nothing, not 'grip'",
        f"{tree}:6:28: a YAML !!timestamp value is a date such as 2001-12-14, not 'hello'",
        f"{tree}:6:54: a YAML !!null value is null, ~ or nothing, not 'error'",
    ]


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("a: !!null\n", None),
        ("a: !!null ~\n", None),
        ("a: !!null null\n", None),
        ('a: !!null ""\n', None),
        ("a: ~\n", None),
        ("a: !!timestamp 2001-12-14\n", "2001-12-14"),
        ("a: 2001-12-14\n", "2001-12-14"),
    ],
)
def test_null_and_a_date_written_as_yaml_writes_them_are_read_as_before(
    text: str, value: object
) -> None:
    assert load_yaml_text(text, "f.yaml").data == {"a": value}


def test_a_null_tag_on_text_is_refused_in_every_file_kind() -> None:
    with pytest.raises(ValidationFailed) as caught:
        load_yaml_text("segments: !!null none\n", "n.yaml")
    assert str(caught.value) == "n.yaml:1:11: a YAML !!null value is null, ~ or nothing, not 'none'"


def test_a_tree_with_names_too_long_for_graphviz_is_drawn_with_them_cut(
    tmp_path: Path, capsys: Any
) -> None:
    long = "n" * 200_000
    tree = tmp_path / "t.yaml"
    tree.write_text(
        f"name: {'t' * 200_000}\n"
        f"root: {{type: sequence, name: {long}, children: [{{type: success, name: {long}x}}]}}\n",
        encoding="utf-8",
    )
    out = tmp_path / "t.svg"
    assert main(["render", str(tree), "-o", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"drew {out}"
    drawn = out.read_text(encoding="utf-8")
    assert "n" * 79 + "…" in drawn
    assert "n" * 80 not in drawn


def test_a_diagram_graphviz_stops_reading_half_way_is_said_not_taken_for_a_closed_output(
    tmp_path: Path,
) -> None:
    from pirate_bt.errors import InputError
    from pirate_bt.render.files import write_diagram

    out = tmp_path / "t.svg"
    # an HTML-like label longer than Graphviz takes: dot stops reading at it
    source = "digraph tree {\n  a [label=<<b>" + "x" * 400_000 + "</b>>];\n}\n"
    with pytest.raises(InputError) as caught:
        write_diagram(source, out)
    assert str(caught.value).startswith(f"{out}: Graphviz could not draw it (dot exit 1: ")
    assert not out.exists()
    assert (tmp_path / "t.dot").read_text(encoding="utf-8") == source


def test_did_you_mean_hints_stop_once_a_load_has_compared_its_budget_of_names(
    tmp_path: Path, capsys: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pirate_bt.treefile.header as header

    # 60 refs to no subtree, each against 60 subtrees: 3,600 names compared; with a
    # budget of 1,000 the first 16 refs get a hint and the rest none (a file of 3,000
    # of each took five minutes, under the real budget 3 s)
    monkeypatch.setattr(header, "SUGGESTION_BUDGET", 1_000, raising=False)
    tree = tmp_path / "t.yaml"
    calls = "".join(f"    - {{type: subtree, ref: subtre_{i}, name: c{i}}}\n" for i in range(60))
    trees = "".join(f"  subtree_{i}: {{root: success}}\n" for i in range(60))
    tree.write_text(
        f"root:\n  type: sequence\n  children:\n{calls}subtrees:\n{trees}", encoding="utf-8"
    )
    assert main(["validate", str(tree)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 60
    assert (
        lines[0]
        == f"{tree}:4:23: no subtree named 'subtre_0'; did you mean 'subtree_0' or 'subtree_50'?"
    )
    assert sum("did you mean" in line for line in lines) == 16
    assert lines[-1] == f"{tree}:63:23: no subtree named 'subtre_59'"


def test_a_blackboard_key_that_is_no_ascii_identifier_is_refused_where_it_is_declared(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard:\n  café: {type: integer, external: true}\n"
        "root: {type: check_blackboard, key: café, op: '==', value: 1}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"{tree}:2:3: blackboard key 'café' must be an identifier of ASCII letters, digits and"
        " '_', not first a digit ('é' is U+00E9 LATIN SMALL LETTER E WITH ACUTE)",
        f"{tree}:3:32: check_blackboard: key: 'café' must be an identifier (ASCII letters,"
        " digits and _, not first a digit)",
    ]


def test_a_file_of_too_many_values_is_refused_before_its_node_graph_is_built() -> None:
    import tracemalloc

    text = "root: [" + ", ".join(["1"] * 100_500) + "]\n"
    tracemalloc.start()
    try:
        with pytest.raises(ValidationFailed) as caught:
            load_yaml_text(text, "big.yaml")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(caught.value) == (
        "big.yaml:1:7: this holds more than 100000 values; a file this large is not one a"
        " person writes"
    )
    # the 100,502 nodes PyYAML composed took 45 MB here; counting events takes 1 MB
    assert peak < 15_000_000, peak


def test_a_large_file_within_the_bound_is_read_whole() -> None:
    text = "root: [" + ", ".join(["1    "] * 30_000) + "]\n"  # counted: 180,000 characters
    assert len(load_yaml_text(text, "wide.yaml").data["root"]) == 30_000


def test_a_guard_written_with_is_set_is_one_line_naming_check_blackboard(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "blackboard: {k: {type: number, default: 1}}\n"
        "root:\n  type: skip_if\n  condition: {blackboard: k, op: is_set}\n  child: success\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"{tree}:4:3: skip_if: op: 'is_set' is check_blackboard's; a guard compares with a"
        " value (==, !=, <, <=, >, >=): to test whether a key is set, use a check_blackboard"
        " with op: is_set"
    ]


def test_a_parameter_refused_for_a_look_alike_character_names_it_and_is_not_listed(
    tmp_path: Path, capsys: Any
) -> None:
    tree = tmp_path / "t.yaml"
    tree.write_text(
        "params:\n  x\u212a: {type: integer, default: 1}\n"
        "root: {type: retry, attempts: $xK, child: success}\n",
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"{tree}:2:3: parameter name 'x\u212a' must be an identifier of ASCII letters, digits"
        " and '_', as $name is written ('\u212a' is U+212A KELVIN SIGN)",
        f"{tree}:3:21: unknown parameter $xK (parameters: none declared)",
    ]


def test_an_xml_call_s_unknown_port_lists_at_most_twenty_of_the_model_s(
    tmp_path: Path, capsys: Any
) -> None:
    ports = "".join(
        f'<input_port name="p{i}_{"x" * 200}" type="string" default="a"/>' for i in range(30)
    )
    tree = tmp_path / "t.xml"
    tree.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="A">\n'
        f'<TreeNodesModel><SubTree ID="B">{ports}</SubTree></TreeNodesModel>\n'
        '<BehaviorTree ID="A"><SubTree ID="B" nope="1"/></BehaviorTree>\n'
        '<BehaviorTree ID="B"><AlwaysSuccess/></BehaviorTree>\n</root>\n',
        encoding="utf-8",
    )
    assert main(["validate", str(tree)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{tree}:3:22: <SubTree ID='B'>: port 'nope' is not a parameter of 'B'")
    assert "p19_xxx" in err and "p20_" not in err
    assert err.endswith("..., ... (10 more); declare them in <TreeNodesModel>)")
    assert len(err) < 1500


def test_a_long_recursion_is_said_with_the_middle_of_its_chain_left_out(
    tmp_path: Path, capsys: Any
) -> None:
    n = 300
    trees = "".join(
        f'<BehaviorTree ID="T{i}"><SubTree ID="T{(i + 1) % n}"/></BehaviorTree>\n' for i in range(n)
    )
    tree = tmp_path / "t.xml"
    tree.write_text(
        f'<root BTCPP_format="4" main_tree_to_execute="T0">\n{trees}</root>\n', encoding="utf-8"
    )
    assert main(["validate", str(tree)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"{tree}:301:25: recursive subtree: T0 -> T1 -> T2 -> T3 -> T4 -> ... (291 more)"
        " -> T296 -> T297 -> T298 -> T299 -> T0"
    )
