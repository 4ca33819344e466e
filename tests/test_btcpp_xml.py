"""BehaviorTree.CPP v4 XML both ways, checked by BT.CPP's own parser.

Every shipped tree is exported, parsed by BT.CPP (Python bindings, and the C++
port checker of ``tests/btcpp_checker``), imported back, and loaded again with
our loader: the structure and every parameter must survive.
"""

from __future__ import annotations

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from pirate_bt.cli import main
from pirate_bt.interop import btcpp_xml
from pirate_bt.interop.btcpp import export_xml, import_xml, node_models, tree_to_xml
from pirate_bt.treefile import load_tree
from pirate_bt.treefile.registry import Registry, default_registry

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = sorted(p for p in (ROOT / "trees").rglob("*.yaml"))


def _signature(spec: Any) -> tuple[Any, ...]:
    params = spec.params.model_dump() if hasattr(spec.params, "model_dump") else spec.params
    return (
        spec.node_type,
        spec.name,
        params,
        [_signature(c) for c in spec.conditions],
        [_signature(c) for c in spec.children],
    )


def _strip_ports(xml: str) -> str:
    """The XML with every port of a registered node removed (the bindings cannot declare ports)."""
    root = ET.fromstring(xml)
    for tree in root.iter("BehaviorTree"):
        for element in tree.iter():
            if element.tag in ("BehaviorTree", "SubTree"):
                continue
            for key in list(element.attrib):
                if key != "name":
                    del element.attrib[key]
    return ET.tostring(root, "unicode")


def _bindings_factory() -> Any:
    bt = pytest.importorskip("behaviortreepy")
    factory = bt.BehaviorTreeFactory()
    for model in node_models().values():
        if model.category == "Decorator":
            factory.register_simple_decorator(model.id, lambda status, node=None: status)
        elif model.category == "Condition":
            factory.register_simple_condition(model.id, lambda node: bt.NodeStatus.SUCCESS)
        elif model.category == "Action":
            factory.register_simple_action(model.id, lambda node: bt.NodeStatus.SUCCESS)
    return factory


@pytest.fixture(scope="session")
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


def _check(checker: Path, xml_path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(checker), str(xml_path)], capture_output=True, text=True, timeout=60)


# -- every shipped tree -----------------------------------------------------------------


@pytest.mark.parametrize("tree", SHIPPED, ids=lambda p: str(p.relative_to(ROOT / "trees")))
def test_shipped_tree_round_trips_through_xml(tree: Path, tmp_path: Path, capsys: Any) -> None:
    xml, back = tmp_path / "tree.xml", tmp_path / "back.yaml"
    assert main(["export", "btcpp", str(tree), "-o", str(xml)]) == 0
    assert main(["import", "btcpp", str(xml), "-o", str(back)]) == 0
    original = load_tree(tree, use_examples=True)
    again = load_tree(back, use_examples=True)
    assert _signature(again.spec) == _signature(original.spec)
    assert again.name == original.name
    assert again.params == original.params
    assert again.blackboard == original.blackboard
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("tree", SHIPPED, ids=lambda p: str(p.relative_to(ROOT / "trees")))
def test_bt_cpp_parses_every_shipped_tree(tree: Path) -> None:
    factory = _bindings_factory()
    xml = tree_to_xml(tree)
    factory.register_behavior_tree_from_text(xml)
    main_id = ET.fromstring(xml).get("main_tree_to_execute")
    assert main_id in factory.registered_behavior_trees()
    # without ports (the bindings cannot declare them) BT.CPP builds the whole tree,
    # subtrees and their remapped ports included
    built = _bindings_factory()
    built.register_behavior_tree_from_text(_strip_ports(xml))
    assert built.create_tree(main_id).root_node() is not None


def test_bt_cpp_checker_accepts_every_port_of_every_shipped_tree(
    checker: Path, tmp_path: Path
) -> None:
    for tree in SHIPPED:
        out = export_xml(tree, tmp_path / f"{tree.stem}.xml")
        result = _check(checker, out)
        assert result.returncode == 0, f"{tree}: {result.stdout}"
        assert result.stdout.startswith("ok ")


def test_bt_cpp_checker_refuses_an_undeclared_port(checker: Path, tmp_path: Path) -> None:
    xml = tree_to_xml(ROOT / "trees/lib/clamp-rear.yaml")
    bad = tmp_path / "bad.xml"
    bad.write_text(xml.replace('half="rear"', 'half="rear" grip="hard"'))
    result = _check(checker, bad)
    assert result.returncode == 1
    assert "grip" in result.stdout


def test_bt_cpp_checker_refuses_a_count_that_is_not_a_number(checker: Path, tmp_path: Path) -> None:
    xml = tree_to_xml(ROOT / "trees/lib/clamp-rear.yaml")
    bad = tmp_path / "bad.xml"
    bad.write_text(xml.replace('num_attempts="2"', 'num_attempts="twice"'))
    result = _check(checker, bad)
    assert result.returncode == 1
    assert "num_attempts" in result.stdout


def test_bt_cpp_checker_refuses_a_subtree_call_without_a_required_parameter(
    checker: Path, tmp_path: Path
) -> None:
    xml = tree_to_xml(ROOT / "trees/examples/patrol.yaml")
    bad = tmp_path / "bad.xml"
    bad.write_text(xml.replace('<SubTree ID="report" count="1" />', '<SubTree ID="report" />'))
    result = _check(checker, bad)
    assert result.returncode == 1
    assert "count" in result.stdout


# -- the mapping ----------------------------------------------------------------------------


def _write(tmp_path: Path, text: str, name: str = "t.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_composites_map_to_bt_cpp_nodes_only_where_semantics_match(tmp_path: Path) -> None:
    tree = _write(
        tmp_path,
        """
root:
  type: sequence
  name: top
  children:
    - {type: sequence, name: reactive, memory: false, children: [success]}
    - {type: selector, name: priorities, children: [success]}
    - {type: selector, name: fallback, memory: true, children: [success]}
    - {type: parallel, name: all, children: [success, running]}
    - {type: parallel, name: one, policy: one, children: [success, running]}
    - {type: parallel, name: unsynced, synchronise: false, children: [success, running]}
    - {type: oneshot, name: once, child: success}
    - {type: oneshot, name: until ok, "on": success, child: success}
    - {type: retry, name: again, attempts: 3, child: success}
    - {type: timeout, name: limit, duration: 2 s, child: success}
""",
    )
    root = ET.fromstring(tree_to_xml(tree))
    by_name = {e.get("name"): e for e in root.find("BehaviorTree").iter()}  # type: ignore[union-attr]
    assert by_name["top"].tag == "Sequence"
    assert by_name["reactive"].tag == "ReactiveSequence"
    assert by_name["priorities"].tag == "ReactiveFallback"
    assert by_name["fallback"].tag == "Fallback"
    assert (by_name["all"].tag, by_name["all"].get("success_count")) == ("Parallel", "-1")
    assert (by_name["one"].tag, by_name["one"].get("success_count")) == ("Parallel", "1")
    assert by_name["unsynced"].tag == "parallel"  # py_trees re-ticks finished children
    assert (by_name["once"].tag, by_name["once"].get("then_skip")) == ("RunOnce", "false")
    assert by_name["until ok"].tag == "oneshot"
    assert (by_name["again"].tag, by_name["again"].get("num_attempts")) == (
        "RetryUntilSuccessful",
        "3",
    )
    assert (by_name["limit"].tag, by_name["limit"].get("duration")) == ("timeout", "2 s")
    back = tmp_path / "back.yaml"
    import_xml(export_xml(tree, tmp_path / "t.xml"), back)
    assert _signature(load_tree(back).spec) == _signature(load_tree(tree).spec)


def test_tree_nodes_model_declares_every_registered_node_with_its_ports(tmp_path: Path) -> None:
    root = ET.fromstring(tree_to_xml(ROOT / "trees/examples/patrol.yaml"))
    models = {e.get("ID"): e for e in root.find("TreeNodesModel")}  # type: ignore[union-attr]
    registry = default_registry()
    for name in registry.names():
        assert name in models, name
        ports = [p.get("name") for p in models[name].iter("input_port")]
        assert ports == list(registry.get(name).Params.model_fields), name
    clamp = {p.get("name"): p for p in models["clamp"].iter("input_port")}
    assert clamp["torque"].get("type") == "torque"
    assert clamp["half"].get("choices") == "front;rear"
    assert clamp["timeout"].get("default") == "5.0 s"
    assert models["retry"].find("input_port").get("type") == "integer"  # type: ignore[union-attr]
    assert models["check_blackboard"].tag == "Condition"
    assert models["timeout"].tag == "Decorator"
    report = {p.get("name"): p for p in models["report"].iter("input_port")}
    assert report["count"].get("type") == "integer" and "default" not in report["count"].attrib


def test_a_node_registered_from_python_appears_in_the_model(tmp_path: Path) -> None:
    from pydantic import Field

    from pirate_bt.behaviours.base import Leaf, NodeParams

    class BeepParams(NodeParams):
        pitch_hz: int = Field(440, description="how high")

    class Beep(Leaf):
        """Beeps."""

        Params = BeepParams

        def update(self) -> Any:
            return None

    registry = Registry()
    registry.register("beep", Beep)
    tree = _write(tmp_path, "root: {type: beep, pitch_hz: 880}\n")
    root = ET.fromstring(tree_to_xml(tree, registry=registry))
    assert root.find("BehaviorTree/beep").get("pitch_hz") == "880"  # type: ignore[union-attr]
    model = root.find("TreeNodesModel/Action[@ID='beep']/input_port")
    assert model is not None and model.get("type") == "integer" and model.text == "how high"


def test_param_values_become_the_main_tree_port_defaults(tmp_path: Path) -> None:
    out = tmp_path / "bend.xml"
    assert (
        main(
            [
                "export",
                "btcpp",
                str(ROOT / "trees/bend.yaml"),
                "-o",
                str(out),
                "--param",
                "roll=-90deg",
            ]
        )
        == 0
    )
    root = ET.parse(out).getroot()
    port = root.find("TreeNodesModel/SubTree[@ID='bend_2']/input_port[@name='roll']")
    assert port is not None and port.get("default") == "-90deg"
    assert root.find("BehaviorTree").get("_name") == "bend"  # type: ignore[union-attr]


def test_values_that_would_read_as_pointers_or_json_survive(tmp_path: Path) -> None:
    tree = _write(
        tmp_path,
        """
blackboard:
  a: {type: string}
  b: {type: string}
  c: {type: number}
  d: {type: boolean}
root:
  type: sequence
  children:
    - {type: set_blackboard, name: brace, key: a, value: "{not a pointer}"}
    - {type: set_blackboard, name: dollar, key: b, value: "$$literal"}
    - {type: set_blackboard, name: number, key: c, value: 3}
    - {type: set_blackboard, name: flag, key: d, value: true}
""",
    )
    back = tmp_path / "back.yaml"
    import_xml(export_xml(tree, tmp_path / "t.xml"), back)
    assert _signature(load_tree(back).spec) == _signature(load_tree(tree).spec)


def test_a_dollar_in_a_default_means_one_thing_in_xml_and_in_a_run(tmp_path: Path) -> None:
    # the port default was written "$fromdefault" while a run used "$$fromdefault"
    tree = _write(
        tmp_path,
        """
params:
  g: {type: string, default: "$$fromdefault"}
  h: {type: string, default: plain}
root: {type: log, message: $g}
""",
    )
    xml = export_xml(tree, tmp_path / "t.xml", {"h": "$$cli"})
    ports = ET.parse(xml).getroot().findall("TreeNodesModel/SubTree/input_port")
    assert {p.get("name"): p.get("default") for p in ports} == {"g": "$fromdefault", "h": "$$cli"}
    back = load_tree(import_xml(xml, tmp_path / "back.yaml"))
    assert (
        back.params
        == {"g": "$fromdefault", "h": "$$cli"}
        == load_tree(tree, params={"h": "$$cli"}, params_from_text=True).params
    )
    # a given value that would read as a pointer stays text
    braces = export_xml(tree, tmp_path / "b.xml", {"h": "{h}"})
    assert load_tree(import_xml(braces, tmp_path / "b.yaml")).params["h"] == "{h}"


def test_a_folder_as_the_output_is_named_as_typed(tmp_path: Path, capsys: Any) -> None:
    # was "out_path: '/tmp/somefolder' is a folder; name a file": a Python name on
    # the command line
    folder = tmp_path / "somefolder"
    folder.mkdir()
    xml = export_xml(ROOT / "trees/straight.yaml", tmp_path / "s.xml")
    for argv in (
        ["export", "btcpp", str(ROOT / "trees/straight.yaml"), "-o", str(folder)],
        ["import", "btcpp", str(xml), "-o", str(folder)],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err == f"pirate-bt: -o: '{folder}' is a folder; name a file", err
    assert list(folder.iterdir()) == []


# -- unhappy paths ---------------------------------------------------------------------


def _import(tmp_path: Path, xml: str, capsys: Any) -> tuple[int, str, Path]:
    source = tmp_path / "in.xml"
    source.write_text(xml)
    out = tmp_path / "out.yaml"
    code = main(["import", "btcpp", str(source), "-o", str(out)])
    return code, capsys.readouterr().err, out


def _assert_refused(tmp_path: Path, xml: str, capsys: Any, pattern: str) -> str:
    code, err, out = _import(tmp_path, xml, capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert re.search(pattern, lines[0]), lines[0]
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["in.xml"]  # nothing half-written
    return lines[0]


def _doc(body: str, models: str = "") -> str:
    return (
        f'<root BTCPP_format="4" main_tree_to_execute="T">\n{body}\n'
        f"<TreeNodesModel>{models}</TreeNodesModel>\n</root>\n"
    )


def test_malformed_xml_is_located(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        '<root BTCPP_format="4">\n  <BehaviorTree ID="T">\n    <Sequence>\n</root>\n',
        capsys,
        r"in\.xml:4:\d+: not well-formed XML: mismatched tag",
    )


def test_an_entity_expansion_bomb_is_refused_before_expanding(tmp_path: Path, capsys: Any) -> None:
    lol = "".join(f'<!ENTITY l{i} "{("&l" + str(i - 1) + ";") * 10}">' for i in range(1, 10))
    bomb = f'<?xml version="1.0"?>\n<!DOCTYPE root [<!ENTITY l0 "lol">{lol}]>\n<root>&l9;</root>'
    _assert_refused(tmp_path, bomb, capsys, r"in\.xml:2:\d+: a DOCTYPE is not allowed")


def test_a_huge_file_is_refused_without_reading_it(
    tmp_path: Path, capsys: Any, monkeypatch: Any
) -> None:
    monkeypatch.setattr(btcpp_xml, "MAX_XML_BYTES", 1000)
    _assert_refused(tmp_path, _doc("<!--" + "x" * 2000 + "-->"), capsys, r"larger than")


def test_deep_nesting_is_refused(tmp_path: Path, capsys: Any) -> None:
    body = '<BehaviorTree ID="T">' + "<Inverter>" * 300 + "<AlwaysSuccess/>"
    body += "</Inverter>" * 300 + "</BehaviorTree>"
    _assert_refused(tmp_path, _doc(body), capsys, r"nested deeper than 256")


def test_unknown_node_type_names_close_ones(tmp_path: Path, capsys: Any) -> None:
    line = _assert_refused(
        tmp_path,
        _doc(
            '<BehaviorTree ID="T">\n  <Sequence>\n    <clamb half="front"/>\n  </Sequence>\n'
            "</BehaviorTree>"
        ),
        capsys,
        r"in\.xml:4:5: unknown node type 'clamb'; did you mean 'clamp'",
    )
    assert "Traceback" not in line


def test_bt_cpp_nodes_without_a_counterpart_are_refused(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        _doc('<BehaviorTree ID="T"><Sleep msec="100"/></BehaviorTree>'),
        capsys,
        r"in\.xml:2:\d+: BT\.CPP node 'Sleep' has no pirate_bt counterpart",
    )


def test_scripts_are_refused(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        _doc('<BehaviorTree ID="T"><AlwaysSuccess _skipIf="x == 1"/></BehaviorTree>'),
        capsys,
        r"_skipIf: BT\.CPP scripts are not supported",
    )


def test_missing_tree_id_is_refused(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        _doc(
            '<BehaviorTree ID="T"><AlwaysSuccess/></BehaviorTree>\n'
            "<BehaviorTree><AlwaysSuccess/></BehaviorTree>"
        ),
        capsys,
        r"in\.xml:3:1: <BehaviorTree> without an ID",
    )


def test_subtrees_that_include_each_other_are_refused(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        _doc(
            '<BehaviorTree ID="T"><SubTree ID="A"/></BehaviorTree>\n'
            '<BehaviorTree ID="A"><SubTree ID="B"/></BehaviorTree>\n'
            '<BehaviorTree ID="B"><Sequence><SubTree ID="A"/></Sequence></BehaviorTree>'
        ),
        capsys,
        r"in\.xml:4:\d+: recursive subtree: A -> B -> A",
    )


def test_a_missing_subtree_is_refused(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        _doc(
            '<BehaviorTree ID="T"><SubTree ID="Reprot"/></BehaviorTree>\n'
            '<BehaviorTree ID="Report"><AlwaysSuccess/></BehaviorTree>'
        ),
        capsys,
        r"<SubTree ID='Reprot'>: no such <BehaviorTree>; did you mean 'Report'",
    )


def test_unknown_port_and_bad_values_are_located(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        _doc('<BehaviorTree ID="T">\n<wait duraton="1 s"/></BehaviorTree>'),
        capsys,
        r"in\.xml:3:1: wait: unknown port 'duraton'.*did you mean 'duration'",
    )
    (tmp_path / "in.xml").unlink()
    _assert_refused(
        tmp_path,
        _doc('<BehaviorTree ID="T">\n<wait duration="2 mm"/></BehaviorTree>'),
        capsys,
        r"in\.xml:3:1: wait: duration: .*time",
    )
    (tmp_path / "in.xml").unlink()
    _assert_refused(
        tmp_path,
        _doc(
            '<BehaviorTree ID="T">\n<RetryUntilSuccessful num_attempts="-1"><AlwaysSuccess/>'
            "</RetryUntilSuccessful></BehaviorTree>"
        ),
        capsys,
        r"num_attempts='-1': pirate_bt's retry needs a count of at least 1",
    )


def test_version_3_files_are_refused(tmp_path: Path, capsys: Any) -> None:
    _assert_refused(
        tmp_path,
        '<root main_tree_to_execute="T">'
        '<BehaviorTree ID="T"><AlwaysSuccess/></BehaviorTree></root>',
        capsys,
        r'in\.xml:1:1: missing BTCPP_format="4"',
    )


def test_a_failed_import_keeps_the_previous_output(tmp_path: Path, capsys: Any) -> None:
    source = tmp_path / "in.xml"
    source.write_text(_doc('<BehaviorTree ID="T"><Sleep msec="1"/></BehaviorTree>'))
    out = tmp_path / "out.yaml"
    out.write_text("previous\n")
    assert main(["import", "btcpp", str(source), "-o", str(out)]) == 2
    assert out.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.xml", "out.yaml"]


def test_export_refuses_memory_chosen_by_a_parameter(tmp_path: Path, capsys: Any) -> None:
    tree = _write(
        tmp_path,
        "params:\n  m: {type: boolean, default: true}\n"
        "root:\n  type: sequence\n  memory: $m\n  children: [success]\n",
    )
    out = tmp_path / "t.xml"
    assert main(["export", "btcpp", str(tree), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert re.fullmatch(r"pirate-bt: .*t\.yaml:5:\d+: memory: a parameter cannot choose.*", err)
    assert not out.exists()


def test_export_of_an_invalid_tree_reports_the_tree_error(tmp_path: Path, capsys: Any) -> None:
    tree = _write(tmp_path, "root: {type: wiat, duration: 1 s}\n")
    assert main(["export", "btcpp", str(tree), "-o", str(tmp_path / "t.xml")]) == 2
    assert "did you mean 'wait'" in capsys.readouterr().err
    assert not (tmp_path / "t.xml").exists()


def test_export_needs_a_target(capsys: Any) -> None:
    assert main(["export", "nosuch", "x.yaml", "-o", "y"]) == 2
