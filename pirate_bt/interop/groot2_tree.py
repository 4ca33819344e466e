"""The tree a Groot2 server shows: BT.CPP's XML of the running tree, with node UIDs.

BehaviorTree.CPP's ``Groot2Publisher`` answers a full-tree request with the
tree *as instantiated* (``WriteTreeToXML(tree, add_metadata=true, ...)``): one
``<BehaviorTree ID=... _fullpath=...>`` per subtree *instance* (the main tree's
``_fullpath`` is empty; a subtree called twice appears twice), every node with
its ``name`` and ``_uid``, a ``<SubTree ID=... _fullpath=...>`` node where a
subtree is called, with the ports the call remaps, and the node models. UIDs
are numbered 1, 2, 3, ... in the order BT.CPP's parser creates the nodes: depth
first, a subtree's nodes right after the ``<SubTree>`` node that calls it. The
status reply lists nodes subtree instance by subtree instance, each in creation
order.

:func:`served_tree` builds the same from a pirate_bt tree:

- for a tree loaded from a file or a mapping
  (:attr:`~pirate_bt.treefile.LoadedTree.source`), from its BT.CPP export
  (:func:`~pirate_bt.interop.btcpp.tree_to_xml`), expanded as BT.CPP's parser
  expands it, so Groot2 shows the subtrees as they are written. pirate_bt
  builds a subtree call as the subtree's root renamed; BT.CPP has a
  ``<SubTree>`` node above the subtree's root: both UIDs stand for the one
  py_trees node (the subtree root's status is the call's, reset to IDLE when
  it finishes, as BT.CPP's ``SubTreeNode`` resets its child);
- for any other tree (built in Python, or whose export does not match the
  running tree node for node), from the running tree itself: one
  ``<BehaviorTree>``, nodes numbered depth first (as in ``.btlog`` files,
  :func:`pirate_bt.interop.btlog.structure_xml`).
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import py_trees

from pirate_bt.errors import InputError
from pirate_bt.interop.btcpp_models import BTCPP_FORMAT
from pirate_bt.trace.structure import iter_with_ids, tree_structure

__all__ = ["ServedTree", "expand_xml", "served_tree"]

logger = logging.getLogger(__name__)

_MAX_UID = 0xFFFF
_RESERVED = frozenset(
    {
        "name",
        "ID",
        "_autoremap",
        # BT.CPP's scripted pre- and post-conditions (pirate_bt writes none)
        "_failureIf",
        "_successIf",
        "_skipIf",
        "_while",
        "_onSuccess",
        "_onFailure",
        "_onHalted",
        "_post",
    }
)


def _is_port(name: str) -> bool:
    """BT.CPP's ``IsAllowedPortName``: starts with a letter, not a reserved name."""
    return bool(name) and name[0].isalpha() and name not in _RESERVED


@dataclass(frozen=True)
class ServedTree:
    """What a Groot2 server serves for one tree.

    Attributes:
        xml: The full-tree reply: BT.CPP XML with ``_uid`` and ``_fullpath``.
        order: Node UIDs in the status reply's order.
        node_of: UID -> index of the py_trees node (depth first, as in traces).
        inner: UIDs of subtree roots, whose status is their ``<SubTree>`` node's,
            reset to IDLE when it finishes.
        uids_of: py_trees node index -> its UIDs (a subtree call has two).
        subtrees: Subtree instance name (``_fullpath``) -> its blackboard's own
            entries, as BT.CPP sets them: each port of the call given a constant
            (text), and each default of the subtree's model not given.
        paths: UID -> BT.CPP's path of the node (``pass bend/turn/clamp``).
        expanded: True when built from the export, with subtrees; False when
            built from the running tree (one ``<BehaviorTree>``).
        main_id: The main tree's ID (its first ``<BehaviorTree>``): BT.CPP serves the
            main tree's blackboard under it, as pirate_bt does under ``""`` too.
    """

    xml: str
    order: tuple[int, ...]
    node_of: Mapping[int, int]
    inner: frozenset[int] = frozenset()
    uids_of: Mapping[int, tuple[int, ...]] = field(default_factory=dict)
    subtrees: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    paths: Mapping[int, str] = field(default_factory=dict)
    expanded: bool = False
    main_id: str = ""


@dataclass
class _Node:
    uid: int
    element: ET.Element
    children: list[int]
    subtree_root: int | None = None  # for a <SubTree> node: its subtree's root UID
    explicit_name: bool = False


class _Expander:
    """BT.CPP's ``XMLParser`` instantiation, for the parts a Groot2 reply shows."""

    def __init__(self, root: ET.Element) -> None:
        self.trees = {t.get("ID", ""): t for t in root.findall("BehaviorTree")}
        self.models: dict[str, dict[str, str]] = {}
        for model in root.findall("TreeNodesModel/SubTree"):
            defaults = {
                p.get("name", ""): p.get("default", "")
                for p in model
                if p.get("default") is not None
            }
            self.models[model.get("ID", "")] = defaults
        self.nodes: dict[int, _Node] = {}
        self.instances: list[tuple[str, str, list[int], ET.Element]] = []
        self.blackboards: dict[str, dict[str, Any]] = {}
        self.paths: dict[int, str] = {}
        self.uid = 0

    def instance(self, tree_id: str, path: str) -> int:
        tree = self.trees.get(tree_id)
        if tree is None or len(tree) != 1:
            raise InputError(f"no <BehaviorTree ID={tree_id!r}> with one root node")
        element = ET.Element("BehaviorTree", {"ID": tree_id, "_fullpath": path})
        uids: list[int] = []
        self.instances.append((tree_id, path, uids, element))
        return self.node(tree[0], path + "/" if path else "", uids, element)

    def node(self, xml: ET.Element, prefix: str, uids: list[int], parent: ET.Element) -> int:
        self.uid += 1
        uid = self.uid
        if uid > _MAX_UID:
            raise InputError(f"more than {_MAX_UID} nodes: Groot2 numbers nodes in 16 bits")
        uids.append(uid)
        subtree = xml.tag == "SubTree"
        type_id = xml.get("ID", "") if subtree else xml.tag
        name = xml.get("name") or type_id
        path = prefix + name + (f"::{uid}" if name == type_id else "")
        self.paths[uid] = path
        ports = {k: v for k, v in xml.attrib.items() if _is_port(k)}
        if subtree:
            out = ET.SubElement(parent, "SubTree", {"ID": type_id, "_fullpath": path})
        else:
            out = ET.SubElement(parent, xml.tag, {"name": name})
        out.set("_uid", str(uid))
        for key, value in ports.items():
            out.set(key, value)
        node = _Node(uid, out, [], explicit_name=xml.get("name") is not None)
        self.nodes[uid] = node
        if subtree:
            instance = prefix.rstrip("/")
            instance = f"{instance}/" if instance else ""
            instance += xml.get("name") or f"{type_id}::{uid}"
            own: dict[str, Any] = {}
            for key, value in {**self.models.get(type_id, {}), **ports}.items():
                if not (len(value) >= 3 and value[0] == "{" and value[-1] == "}"):
                    own[key] = value  # a constant: set in the subtree's blackboard
            self.blackboards[instance] = own
            node.subtree_root = self.instance(type_id, instance)
        else:
            for child in xml:
                node.children.append(self.node(child, prefix, uids, out))
        return uid


def expand_xml(text: str) -> tuple[str, list[tuple[str, str, list[int]]], dict[int, _Node], Any]:
    """BT.CPP XML (as :func:`~pirate_bt.interop.btcpp.tree_to_xml` writes it) as
    ``WriteTreeToXML`` writes the instantiated tree.

    Returns:
        ``(xml, instances, nodes, expander)``: the XML text; per subtree instance its
        tree ID, ``_fullpath`` and node UIDs in creation order; the nodes by UID.

    Raises:
        InputError: no main tree, a missing subtree, too many nodes.
    """
    root = ET.fromstring(text)
    main = root.get("main_tree_to_execute") or next(
        (t.get("ID", "") for t in root.findall("BehaviorTree")), ""
    )
    expander = _Expander(root)
    expander.instance(main, "")
    out = ET.Element("root", {"BTCPP_format": BTCPP_FORMAT})
    for _, _, _, element in expander.instances:
        out.append(element)
    models = ET.SubElement(out, "TreeNodesModel")
    for model in root.findall("TreeNodesModel/*"):
        if model.tag != "SubTree":
            models.append(model)
    instances = [(tree_id, path, uids) for tree_id, path, uids, _ in expander.instances]
    xml = ET.tostring(out, "unicode")
    return xml, instances, expander.nodes, expander


class _Mismatch(Exception):
    """The export and the running tree differ."""


def _from_export(tree: py_trees.trees.BehaviourTree, text: str) -> ServedTree:
    xml, instances, nodes, expander = expand_xml(text)
    py_nodes = [node for _, node in iter_with_ids(tree)]
    index_of = {id(node): i for i, node in enumerate(py_nodes)}
    node_of: dict[int, int] = {}
    inner: set[int] = set()

    def match(uid: int, node: py_trees.behaviour.Behaviour, is_inner: bool) -> None:
        bt = nodes[uid]
        node_of[uid] = index_of[id(node)]
        if is_inner:
            inner.add(uid)
        if bt.subtree_root is not None:
            match(bt.subtree_root, node, True)
            return
        if bt.explicit_name and not is_inner and bt.element.get("name") != node.name:
            raise _Mismatch(f"node {uid}: {bt.element.get('name')!r} is {node.name!r}")
        if len(bt.children) != len(node.children):
            raise _Mismatch(f"node {uid} ({node.name!r}): children differ")
        for child_uid, child in zip(bt.children, node.children, strict=True):
            match(child_uid, child, False)

    match(1, tree.root, False)
    if len(set(node_of.values())) != len(py_nodes):
        raise _Mismatch("some running node has no UID")
    uids_of: dict[int, list[int]] = {}
    for uid in sorted(node_of):
        uids_of.setdefault(node_of[uid], []).append(uid)
    return ServedTree(
        xml=xml,
        order=tuple(uid for _, _, uids in instances for uid in uids),
        node_of=node_of,
        inner=frozenset(inner),
        uids_of={i: tuple(u) for i, u in uids_of.items()},
        subtrees=expander.blackboards,
        paths=expander.paths,
        expanded=True,
        main_id=instances[0][0] if instances else "",
    )


def _flat(tree: py_trees.trees.BehaviourTree, name: str | None) -> ServedTree:
    from pirate_bt.interop.btlog import structure_xml

    structure = tree_structure(tree, name=name)
    xml = structure_xml(structure)
    count = len(structure)
    names: dict[int, str] = {}
    for uid, node in enumerate(structure, start=1):
        names[uid] = node.name if node.parent is None else f"{node.name}::{uid}"
    return ServedTree(
        xml=xml,
        order=tuple(range(1, count + 1)),
        node_of={uid: uid - 1 for uid in range(1, count + 1)},
        uids_of={i: (i + 1,) for i in range(count)},
        paths=names,
        main_id=_first_tree_id(xml),
    )


def _first_tree_id(xml: str) -> str:
    first = ET.fromstring(xml).find("BehaviorTree")
    return first.get("ID", "") if first is not None else ""


def served_tree(
    tree: py_trees.trees.BehaviourTree,
    source: str | Path | Mapping[str, Any] | None = None,
    name: str | None = None,
    checked: Any = None,
) -> ServedTree:
    """What to serve for ``tree`` (see the module docstring).

    Args:
        tree: The running tree.
        source: What it was loaded from (a tree file or a mapping), to show its
            subtrees; ``None``: the running tree as it is.
        name: The tree's name, for the one-tree form.
        checked: The ``LoadedTree`` of ``source``, if the caller has it (spares
            loading it again to export it).

    Raises:
        InputError: a tree of more than 65,535 nodes.
    """
    if source is not None:
        from pirate_bt.interop.btcpp import tree_to_xml

        try:
            return _from_export(tree, tree_to_xml(source, checked=checked))
        except Exception as exc:  # any reason the export does not fit: show the tree as run
            logger.info("Groot2: showing the tree as it runs, without subtrees (%s)", exc)
    return _flat(tree, name)
