"""BehaviorTree.CPP v4 XML, both ways: what Groot2 opens, edits and saves.

BehaviorTree.CPP (BT.CPP) describes a tree as XML (``BTCPP_format="4"``): one
``<BehaviorTree ID=...>`` per tree, ``<SubTree ID=.../>`` to include another
tree with its ports remapped, and a ``<TreeNodesModel>`` that tells an editor
which node types exist and which ports (parameters) they take. A pirate_bt tree
file maps onto that closely:

- the tree file's root and every subtree it uses (in the same file or in
  another) become one ``<BehaviorTree>`` each; a subtree's declared parameters
  become the ports of its ``<SubTree>`` model, and ``params:`` at the call site
  become the ``<SubTree>``'s remapped ports;
- a whole-value parameter ``$roll`` becomes the blackboard pointer ``{roll}``,
  which is how a BT.CPP subtree reads its ports;
- composites and decorators go to BT.CPP's own nodes only where the semantics
  match (:data:`TO_BTCPP`; ``docs/interop.md`` has the table and the reasons);
  everything else, every leaf included, stays a pirate_bt node, declared in the
  ``<TreeNodesModel>`` with ports derived from the node class's parameter model
  (:func:`node_models`), never from a hand-written list.

A value is written as text in the port's own terms: ``0.7 N*m`` for a torque,
``3`` for an integer, ``true`` for a boolean. Values with no plain-text form
(lists, comparisons, a number where a string could also be meant) use BT.CPP's
``json:`` prefix. Reading back (:func:`import_xml`) undoes exactly that, so
YAML → XML → YAML keeps the structure and every parameter.

Reading refuses, at ``file:line:column``, what cannot become a pirate_bt tree:
malformed XML, DTDs and entities (see :mod:`pirate_bt.interop.btcpp_xml`),
unknown node types and ports, BT.CPP nodes with no pirate_bt counterpart,
scripts (``_skipIf`` and friends), missing IDs and subtrees that include each
other.
"""

from __future__ import annotations

from pirate_bt.interop.btcpp_export import export_xml, tree_to_xml
from pirate_bt.interop.btcpp_import import xml_to_tree
from pirate_bt.interop.btcpp_import_file import import_xml, load_xml_tree
from pirate_bt.interop.btcpp_models import (
    BTCPP_FORMAT,
    FROM_BTCPP,
    TO_BTCPP,
    NodeModel,
    PortModel,
    decode_value,
    encode_value,
    node_models,
)

__all__ = [
    "BTCPP_FORMAT",
    "FROM_BTCPP",
    "TO_BTCPP",
    "NodeModel",
    "PortModel",
    "decode_value",
    "encode_value",
    "export_xml",
    "import_xml",
    "load_xml_tree",
    "node_models",
    "tree_to_xml",
    "xml_to_tree",
]
