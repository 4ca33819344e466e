"""Session 22 (R2): subtree names through BT.CPP XML and back (docs/interop.md).

Export then import renamed a subtree whose name is the tree's own (``inner`` in a tree
named ``inner``) or a node type's (``wait``): ``inner_2``, ``wait_2``. BT.CPP refuses
both as IDs (two ``<BehaviorTree>`` of one ID; *must not use the name of a registered
Node*), so the IDs stay renamed, and export keeps the name beside the ID (``_name``,
which BT.CPP ignores) for import to restore it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from pirate_bt.interop.btcpp import export_xml, import_xml, node_models
from pirate_bt.treefile import load_tree

TREE = """name: inner
subtrees:
  inner:
    root: {type: success}
  wait:
    root: {type: wait, duration: 1 s}
  keep:
    root: {type: subtree, ref: wait}
root:
  type: sequence
  children:
    - {type: subtree, ref: inner}
    - {type: subtree, ref: keep}
"""


def _round_trip(tmp_path: Path) -> tuple[Path, dict[str, Any]]:
    tree = tmp_path / "inner.yaml"
    tree.write_text(TREE, encoding="utf-8")
    xml = export_xml(tree, tmp_path / "inner.xml")
    back = import_xml(xml, tmp_path / "back.yaml")
    return xml, yaml.safe_load(back.read_text(encoding="utf-8"))


def test_subtrees_named_as_the_tree_or_a_node_type_keep_their_names(tmp_path: Path) -> None:
    _xml, data = _round_trip(tmp_path)
    assert data["name"] == "inner"
    assert sorted(data["subtrees"]) == ["inner", "keep", "wait"]
    assert [c["ref"] for c in data["root"]["children"]] == ["inner", "keep"]
    assert data["subtrees"]["keep"]["root"]["ref"] == "wait"
    assert load_tree(tmp_path / "back.yaml").name == "inner"


def test_bt_cpp_loads_the_exported_file_with_its_node_types_registered(tmp_path: Path) -> None:
    bt = pytest.importorskip("behaviortreepy")
    xml, _data = _round_trip(tmp_path)
    factory = bt.BehaviorTreeFactory()
    for model in node_models().values():
        if model.category == "Decorator":
            factory.register_simple_decorator(model.id, lambda status, node=None: status)
        elif model.category == "Condition":
            factory.register_simple_condition(model.id, lambda node: bt.NodeStatus.SUCCESS)
        elif model.category == "Action":
            factory.register_simple_action(model.id, lambda node: bt.NodeStatus.SUCCESS)
    factory.register_behavior_tree_from_text(xml.read_text(encoding="utf-8"))
    assert sorted(factory.registered_behavior_trees()) == ["inner", "inner_2", "keep", "wait_2"]


def test_a_name_beside_an_id_that_another_tree_has_is_not_taken(tmp_path: Path) -> None:
    xml = tmp_path / "hand.xml"
    xml.write_text(
        '<root BTCPP_format="4" main_tree_to_execute="M">\n'
        '  <BehaviorTree ID="M"><Sequence><SubTree ID="A"/><SubTree ID="B"/></Sequence>'
        "</BehaviorTree>\n"
        '  <BehaviorTree ID="A" _name="B"><AlwaysSuccess/></BehaviorTree>\n'
        '  <BehaviorTree ID="B" _name="x.yaml"><AlwaysFailure/></BehaviorTree>\n'
        "</root>\n",
        encoding="utf-8",
    )
    data = yaml.safe_load(import_xml(xml, tmp_path / "hand.yaml").read_text(encoding="utf-8"))
    assert sorted(data["subtrees"]) == ["A", "B"]
    assert [c["ref"] for c in data["root"]["children"]] == ["A", "B"]
