"""Session 22 (R2): BehaviorTree.CPP names the importer refused (docs/interop.md).

``name=""`` on a node was refused (*name: must be non-empty text*), where BT.CPP loads
it, an instance with an empty name (Groot2 shows it by its type). It is imported as a
node without a name attribute: its name is its type's, as BT.CPP shows it.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from pirate_bt.interop.btcpp import import_xml
from pirate_bt.treefile import load_tree

XML = """<root BTCPP_format="4" main_tree_to_execute="T">
  <BehaviorTree ID="T">
    <Sequence name="">
      <SubTree ID="S" name=""/>
      <AlwaysSuccess name="   "/>
      <AlwaysFailure name="x"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="S"><AlwaysSuccess name=""/></BehaviorTree>
</root>
"""


def test_an_empty_node_name_is_imported_as_no_name(tmp_path: Path) -> None:
    xml = tmp_path / "e.xml"
    xml.write_text(XML, encoding="utf-8")
    out = import_xml(xml, tmp_path / "e.yaml")
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    sequence = data["root"]
    assert "name" not in sequence
    assert [child.get("name") for child in sequence["children"]] == [None, None, "x"]
    assert "name" not in data["subtrees"]["S"]["root"]
    loaded = load_tree(out)
    # named by its type (numbered, as any two nodes of one name: the subtree's is first)
    names = [child.name for child in loaded.root.children]
    assert names[1].startswith("success") and names[2] == "x"


def test_bt_cpp_itself_loads_the_empty_names() -> None:
    bt = pytest.importorskip("behaviortreepy")
    factory = bt.BehaviorTreeFactory()
    factory.register_behavior_tree_from_text(XML)
    tree = factory.create_tree("T")
    assert tree.root_node().name() == ""
    assert tree.tick_while_running() == bt.NodeStatus.FAILURE
