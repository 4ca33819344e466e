"""BehaviorTree.CPP v4 XML import: an XML file read as the mapping of a pirate_bt tree file,
checked as it is read.

:func:`xml_to_tree`, re-exported by :mod:`pirate_bt.interop.btcpp`;
:mod:`pirate_bt.interop.btcpp_import_file` writes the mapping as a checked tree file
(:func:`~pirate_bt.interop.btcpp_import_file.import_xml`).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Final

from pydantic import ValidationError

from pirate_bt.errors import SourceLocation, file_argument
from pirate_bt.interop.btcpp_import_ports import (
    has_reference,
    literal,
    no_json,
    own_key,
    subtree_ports,
    tree_blackboard,
)
from pirate_bt.interop.btcpp_models import (
    _BTCPP_BUILTINS,
    _FALSE,
    _HINT,
    _MODEL_TAGS,
    _SCRIPT_ATTRS,
    _TRUE,
    BTCPP_FORMAT,
    FROM_BTCPP,
    TO_BTCPP,
    _shown,
    btcpp_port_name,
    decode_value,
    node_models,
    own_instead,
)
from pirate_bt.interop.btcpp_xml import XmlElement, parse_xml
from pirate_bt.treefile.params import chain_text, listed
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.treefile.spec import MAX_TREE_DEPTH
from pirate_bt.yamlfile import MAX_NODES
from pirate_bt.yamlfile.alike import alike_among, alike_note
from pirate_bt.yamlvalidate import close_matches, validation_problems

__all__ = ["xml_to_tree"]

# The logger keeps the name it had before the split (pirate_bt.interop.btcpp).
_log = logging.getLogger("pirate_bt.interop.btcpp")


def _suggest(name: str, known: list[str]) -> str:
    close = close_matches(name, known, n=2)
    note = alike_note(name, close[0]) if len(close) == 1 else ""  # 'durаtion', Cyrillic а
    return f"; did you mean {' or '.join(map(repr, close))}?{note}" if close else ""


def _file_like(name: str) -> bool:
    """A pirate_bt subtree reference would read ``name`` as a file's."""
    return "#" in name or name.lower().endswith((".yaml", ".yml"))


_UNNAMED: Final = "BehaviorTree_0"
"""The ID BT.CPP gives a lone <BehaviorTree> written without one."""


class _Importer:
    def __init__(self, root: XmlElement, registry: Registry) -> None:
        self.root = root
        self.registry = registry
        self.models = node_models(registry)
        self.trees: dict[str, XmlElement] = {}
        self.subtree_models: dict[str, XmlElement] = {}
        self.origin: dict[int, tuple[object, XmlElement]] = {}
        """``id()`` of each mapping made (a node, a tree, a parameter) -> the mapping and
        its element. The mapping is kept (alive) beside its element: a mapping that was
        freed would leave its ``id()`` to a later one, which would then be placed at an
        element it does not come from (:meth:`place`, :meth:`locations`)."""
        self.called: set[str] = set()
        """The IDs of the trees a ``<SubTree>`` calls (:meth:`check_cycles`)."""
        self.depth = 0
        """How deep :meth:`node` is (bounded by the loader's MAX_TREE_DEPTH)."""
        self.keys: dict[str, str] = {}
        """Each tree's ID -> its name under ``subtrees:`` (:meth:`subtree_keys`)."""

    def read(self) -> dict[str, Any]:
        root = self.root
        if root.tag != "root":
            raise root.error(f"expected <root>, found <{root.tag}>")
        fmt = root.attrs.get("BTCPP_format")
        if fmt != BTCPP_FORMAT:
            raise root.error(
                f"BTCPP_format={_shown(fmt)}: only BehaviorTree.CPP version 4 files are read"
                " (convert version 3 files with BT.CPP's convert_v3_to_v4.py)"
                if fmt
                else 'missing BTCPP_format="4" on <root>'
            )
        models_seen = False
        for child in root.children:
            if child.tag == "BehaviorTree":
                tree_id = child.attrs.get("ID")
                if not tree_id and len(root.children) == 1:
                    tree_id = _UNNAMED  # BT.CPP reads it when it is all <root> holds
                if not tree_id:
                    raise child.error("<BehaviorTree> without an ID")
                if tree_id in self.trees:
                    raise child.error(
                        f"a second <BehaviorTree ID={_shown(tree_id)}> (first at"
                        f" {self.trees[tree_id].location})"
                    )
                if tree_id in self.models or tree_id in _BTCPP_BUILTINS:
                    raise child.error(f"tree ID {_shown(tree_id)} is the name of a node type")
                if _file_like(tree_id):
                    raise child.error(
                        f"tree ID {_shown(tree_id)} would read as a file in a pirate_bt subtree"
                        " reference: no '#', no .yaml or .yml ending"
                    )
                if len(child.children) != 1:
                    raise child.error(
                        f"<BehaviorTree ID={_shown(tree_id)}> must have exactly one child,"
                        f" not {len(child.children)}"
                    )
                self.trees[tree_id] = child
            elif child.tag == "TreeNodesModel":
                if models_seen:
                    raise child.error("a second <TreeNodesModel>")
                models_seen = True
                self.read_models(child)
            elif child.tag == "include":
                raise child.error("<include> is not supported: put every tree in one file")
            else:
                raise child.error(
                    f"unexpected <{child.tag}> under <root>; expected <BehaviorTree>"
                    " or <TreeNodesModel>"
                )
        if not self.trees:
            raise root.error("no <BehaviorTree> in the file")
        main = root.attrs.get("main_tree_to_execute")
        if main is None:
            if len(self.trees) > 1:
                raise root.error(
                    "several <BehaviorTree> and no main_tree_to_execute to say which one runs"
                )
            main = next(iter(self.trees))
        elif main not in self.trees:
            raise root.error(
                f"main_tree_to_execute={_shown(main)}: no such <BehaviorTree>"
                + _suggest(main, list(self.trees))
            )
        self.check_cycles(main)
        main_tree = self.trees[main]
        out: dict[str, Any] = {}
        self.place(out, main_tree)
        # without an ID (nor a _name) the tree takes its file's name, as a YAML tree does
        written_name = main_tree.attrs.get("_name", main if main_tree.attrs.get("ID") else "")
        if written_name:  # empty: the tree file had no name (it takes the file's)
            out["name"] = written_name
        if "_description" in main_tree.attrs:
            out["description"] = main_tree.attrs["_description"]
        params = self.params(main)
        if params:
            out["params"] = params
        # one blackboard a file, as a tree file's: every tree's _blackboard (a subtree's
        # was dropped unread), the main tree's first
        board: dict[str, Any] = {}
        for element in (main_tree, *(t for t in self.trees.values() if t is not main_tree)):
            for key, decl in tree_blackboard(element).items():
                if board.setdefault(key, decl) != decl:
                    raise element.error(
                        f"_blackboard: key {_shown(key)} is declared otherwise by another"
                        " <BehaviorTree> of the file; a file has one blackboard"
                    )
        if board:
            out["blackboard"] = board
        self.keys = self.subtree_keys(main)
        out["root"] = self.node(main_tree.children[0])
        subtrees: dict[str, Any] = {}
        for tree_id, element in self.trees.items():
            if tree_id == main and main not in self.called:
                continue  # a main tree another calls is also a subtree: the YAML's root is none
            body: dict[str, Any] = {}
            self.place(body, element)
            if "_description" in element.attrs:
                body["description"] = element.attrs["_description"]
            params = self.params(tree_id)
            if params:
                body["params"] = params
            body["root"] = self.node(element.children[0])
            subtrees[self.keys.get(tree_id, tree_id)] = body
        if subtrees:
            out["subtrees"] = subtrees
        return out

    def subtree_keys(self, main: str) -> dict[str, str]:
        """Each tree's name under ``subtrees:``: its ID, or the ``_name`` export writes
        where BT.CPP refuses the name as an ID (``ID="wait_2" _name="wait"``) unless
        another tree goes by it or a ref would read it as a file (the main tree's is the
        file's name)."""
        keys = {tree_id: tree_id for tree_id in self.trees}
        used = set(self.trees) if main in self.called else set(self.trees) - {main}
        for tree_id, element in self.trees.items():
            wanted = element.attrs.get("_name", "")
            if tree_id != main and wanted and wanted not in used and not _file_like(wanted):
                keys[tree_id] = wanted
                used.add(wanted)
        return keys

    def read_models(self, models: XmlElement) -> None:
        for model in models.children:
            if model.tag not in _MODEL_TAGS:
                raise model.error(
                    f"unexpected <{model.tag}> in <TreeNodesModel>; expected one of"
                    f" {', '.join(_MODEL_TAGS)}"
                )
            model_id = model.attrs.get("ID")
            if not model_id:
                raise model.error(f"<{model.tag}> in <TreeNodesModel> without an ID")
            if model.tag == "SubTree":
                if model_id in self.subtree_models:
                    raise model.error(
                        f"a second <SubTree ID={_shown(model_id)}> model (first at"
                        f" {self.subtree_models[model_id].location})"
                    )
                self.subtree_models[model_id] = model
            elif model_id not in self.models:
                # A node type of another program: fine as long as no tree uses it.
                _log.info(
                    "%s: node model %r is not a pirate_bt node type", model.location, model_id
                )

    def check_cycles(self, main: str) -> None:
        """Refuse a <SubTree> of an unknown tree, and trees that include each other.

        A depth-first walk with its own stack: a chain of thousands of trees must
        not meet Python's recursion limit.
        """
        state: dict[str, int] = {}  # 1: on the chain, 2: done

        def targets(tree_id: str) -> list[XmlElement]:
            found: list[XmlElement] = []
            stack = [self.trees[tree_id]]
            while stack:
                element = stack.pop()
                stack.extend(reversed(element.children))
                if element.tag == "SubTree":
                    found.append(element)
            return found

        for start in [main, *self.trees]:
            if start in state:
                continue
            state[start] = 1
            chain = [start]
            pending = [iter(targets(start))]
            while pending:
                element = next(pending[-1], None)
                if element is None:
                    state[chain.pop()] = 2
                    pending.pop()
                    continue
                target = element.attrs.get("ID")
                if not target:
                    raise element.error("<SubTree> without an ID")
                if target not in self.trees:
                    raise element.error(
                        f"<SubTree ID={_shown(target)}>: no such <BehaviorTree>"
                        + _suggest(target, list(self.trees))
                    )
                self.called.add(target)
                if state.get(target) == 1:
                    loop = chain_text([*chain[chain.index(target) :], target])
                    raise element.error(f"recursive subtree: {loop}")
                if state.get(target) is None:
                    state[target] = 1
                    chain.append(target)
                    pending.append(iter(targets(target)))

    def place(self, value: dict[str, Any], element: XmlElement) -> None:
        """Record that ``value`` (a mapping of the output) comes from ``element``."""
        self.origin[id(value)] = (value, element)

    def params(self, tree_id: str, *, placed: bool = True) -> dict[str, Any]:
        """The parameters ``tree_id`` declares in ``<TreeNodesModel>``; ``placed``: each
        declaration is part of the output, placed at its ``<input_port>``."""
        model = self.subtree_models.get(tree_id)
        if model is None:
            return {}
        return subtree_ports(tree_id, model, self.place if placed else None)

    def node(self, element: XmlElement) -> dict[str, Any]:
        if self.depth >= MAX_TREE_DEPTH:
            raise element.error(f"nodes nested deeper than {MAX_TREE_DEPTH} levels")
        self.depth += 1
        try:
            return self.read_node(element)
        finally:
            self.depth -= 1

    def read_node(self, element: XmlElement) -> dict[str, Any]:
        tag = element.tag
        attrs = dict(element.attrs)
        if tag in ("Action", "Condition", "Control", "Decorator"):
            tag = attrs.pop("ID", "")
            if not tag:
                raise element.error(f"<{element.tag}> without an ID")
        elif tag != "SubTree" and "ID" in attrs:  # BT.CPP refuses it: "not allowed"
            raise element.error(
                f"<{tag}>: an ID attribute is not allowed on a node named by its tag"
                " (BehaviorTree.CPP refuses it)"
            )
        for key in attrs:
            if key in _SCRIPT_ATTRS:
                raise element.error(
                    f"{key}: BT.CPP scripts are not supported; use pirate_bt's guard"
                    " decorators (skip_if, failure_if, while)"
                )
        out: dict[str, Any] = {}
        name = attrs.pop("name", None)
        if name is not None and not name.strip():
            # BT.CPP takes name="" (or blank) as it is, an instance shown by its type in
            # Groot2; a pirate_bt name is never blank: the node takes its type's name,
            # as with no name attribute
            name = None
        description = attrs.pop("_description", None)
        hint = attrs.pop(_HINT, None)
        # BT.CPP ignores an attribute it takes for no port (IsAllowedPortName): '_x', 'éx'
        ports = {k: v for k, v in attrs.items() if btcpp_port_name(k)}
        if tag == "SubTree":
            out = self.subtree(element, ports, name)
        elif tag in FROM_BTCPP and tag not in self.models:
            out = self.builtin(element, tag, ports, name, hint)
        elif tag in self.models:
            out = self.registered(element, tag, ports, name)
        elif tag in _BTCPP_BUILTINS:
            raise element.error(
                f"BT.CPP node {_shown(tag)} has no pirate_bt counterpart"
                + (own_instead(tag, attrs) or " (see docs/interop.md)")
            )
        else:
            known = sorted({*self.models, *FROM_BTCPP})
            raise element.error(f"unknown node type {_shown(tag)}" + _suggest(tag, known))
        if description is not None:
            out["description"] = description
        self.place(out, element)
        return out

    def locations(self, data: Any) -> dict[tuple[str | int, ...], SourceLocation]:
        """Where in the XML each mapping of ``data`` (:meth:`read`'s) comes from, by path."""
        found: dict[tuple[str | int, ...], SourceLocation] = {}
        stack: list[tuple[tuple[str | int, ...], Any]] = [((), data)]
        while stack:
            path, value = stack.pop()
            if isinstance(value, dict):
                entry = self.origin.get(id(value))
                if entry is not None and entry[0] is value:
                    found[path] = entry[1].location
                stack.extend(((*path, k), v) for k, v in value.items())
            elif isinstance(value, list):
                stack.extend(((*path, i), v) for i, v in enumerate(value))
        return found

    def named(self, kind: str, name: str | None) -> dict[str, Any]:
        return {"type": kind, "name": name} if name is not None else {"type": kind}

    def subtree(
        self, element: XmlElement, ports: dict[str, str], name: str | None
    ) -> dict[str, Any]:
        if element.children:
            raise element.error("<SubTree> must not have children")
        target = element.attrs.get("ID", "")
        autoremap = element.attrs.get("_autoremap")
        if autoremap is not None and autoremap not in _FALSE:
            if autoremap in _TRUE:
                raise element.error("_autoremap is not supported: remap each port explicitly")
            raise element.error(  # BT.CPP: "convertFromString(): invalid bool conversion"
                f"_autoremap={_shown(autoremap)}: expected true or false"
                " (BT.CPP reads true, True, TRUE or 1, false, False, FALSE or 0)"
            )
        declared = self.params(target, placed=False)  # only to check the call
        out = self.named("subtree", name)
        out["ref"] = self.keys.get(target, target)
        given: dict[str, Any] = {}
        for key, text in ports.items():
            decl = declared.get(key)
            if decl is None:
                known = listed(list(declared)) or "none declared"  # 20, each cut: not 1 MB
                raise element.error(
                    f"<SubTree ID={_shown(target)}>: port {_shown(key)} is not a parameter"
                    f" of {_shown(target)}"
                    f" (parameters: {known}; declare them in <TreeNodesModel>)"
                    + alike_among(key, list(declared))
                )
            if text == "" and decl.get("default") == "":
                continue  # its default, written out for BT.CPP (it takes default="" for none)
            try:
                given[key] = decode_value(text, decl["type"], key)
            except ValueError as exc:
                raise element.error(f"{key}: {exc}") from None
        if given:
            out["params"] = given
        return out

    def children(self, element: XmlElement, least: int) -> list[dict[str, Any]]:
        if len(element.children) < least:
            raise element.error(f"<{element.tag}> needs at least {least} child(ren)")
        return [self.node(child) for child in element.children]

    def only_child(self, element: XmlElement) -> dict[str, Any]:
        if len(element.children) != 1:
            raise element.error(
                f"<{element.tag}> is a decorator: exactly one child, not {len(element.children)}"
            )
        return self.node(element.children[0])

    def builtin(
        self,
        element: XmlElement,
        tag: str,
        ports: dict[str, str],
        name: str | None,
        hint: str | None,
    ) -> dict[str, Any]:
        kind = FROM_BTCPP[tag]
        allowed = {
            "Parallel": {"success_count", "failure_count"},
            "RetryUntilSuccessful": {"num_attempts"},
            "Repeat": {"num_cycles"},
            "RunOnce": {"then_skip"},
        }.get(tag, set())
        for key in ports:
            if key not in allowed:
                known = ", ".join(sorted(allowed)) or "none"
                raise element.error(f"<{tag}> has no port {_shown(key)} (ports: {known})")
        if hint == "eternal_guard" and tag == "ReactiveSequence":
            kids = self.children(element, 2)
            out = self.named("eternal_guard", name)
            out["conditions"] = kids[:-1]
            out["child"] = kids[-1]
            return out
        if hint is not None:  # a ReactiveSequence's other value is no mark pirate_bt wrote
            where = "is only known on a <ReactiveSequence>"
            if tag == "ReactiveSequence":
                where = 'is not known: pirate_bt writes only _pirate_bt="eternal_guard"'
            raise element.error(f"{_HINT}={_shown(hint)} {where}")
        out = self.named(kind, name)
        if tag in ("Sequence", "ReactiveSequence", "Fallback", "ReactiveFallback"):
            memory = tag in ("Sequence", "Fallback")
            if memory != (kind == "sequence"):
                out["memory"] = memory
            out["children"] = self.children(element, 1)
            return out
        if tag == "Parallel":
            counts = (ports.get("success_count", "-1"), ports.get("failure_count", "1"))
            read: list[Any] = []
            for key, text in zip(("success_count", "failure_count"), counts, strict=True):
                no_json(element, key, text)
                try:  # as BT.CPP reads an int ('01' is 1, '+1' is refused)
                    read.append(decode_value(text, "integer", key))
                except ValueError as exc:
                    raise element.error(f"{key}: {exc}") from None
            if read == [-1, 1]:
                pass  # policy: all, synchronised (the defaults)
            elif read == [1, 1]:
                out["policy"] = "one"
            else:
                raise element.error(
                    f"<Parallel success_count={_shown(counts[0])}"
                    f" failure_count={_shown(counts[1])}>:"
                    " pirate_bt's parallel succeeds on all (-1, 1) or one (1, 1) child"
                )
            out["children"] = self.children(element, 1)
            return out
        if tag == "RunOnce":
            try:
                then_skip = decode_value(ports.get("then_skip", "true"), "boolean")
            except ValueError as exc:
                raise element.error(f"then_skip: {exc}") from None
            if then_skip is not False:  # also a pointer ({skip}), which a run cannot know
                raise element.error(
                    '<RunOnce> without then_skip="false" returns SKIPPED after the first'
                    " run, a status pirate_bt does not have"
                )
            out["child"] = self.only_child(element)
            return out
        renames = {btcpp: ours for ours, btcpp in TO_BTCPP[kind][1].items()}
        missing = sorted(set(renames) - set(ports))  # BT.CPP has no default for a count
        if missing:
            key = missing[0]
            raise element.error(f'<{tag}> needs {key}, as in BT.CPP (<{tag} {key}="3">)')
        for key, text in ports.items():
            no_json(element, key, text)
            try:
                value = decode_value(own_key(text), "integer", key)
            except ValueError as exc:
                raise element.error(f"{key}: {exc}") from None
            if isinstance(value, int) and value < 1:
                raise element.error(
                    f"{key}={_shown(text)}: pirate_bt's {kind} needs a count of at least 1"
                )
            out[renames[key]] = value
        if self.models[kind].category == "Decorator":
            out["child"] = self.only_child(element)
        elif element.children:
            raise element.error(f"<{tag}> is a leaf and takes no children")
        return out

    def registered(
        self, element: XmlElement, kind: str, ports: dict[str, str], name: str | None
    ) -> dict[str, Any]:
        model = self.models[kind]
        out = self.named(kind, name)
        params: dict[str, Any] = {}
        for key, text in ports.items():
            port = model.port(key)
            if port is None:
                known = ", ".join(p.name for p in model.ports) or "none"
                raise element.error(
                    f"{kind}: unknown port {_shown(key)} (ports: {known})"
                    + _suggest(key, [p.name for p in model.ports])
                )
            try:
                params[key] = decode_value(own_key(text), port.type, key)
            except ValueError as exc:
                raise element.error(f"{kind}: {key}: {exc}") from None
        if kind != "parallel":
            self.check_params(element, kind, params)
        out.update(params)
        if model.category == "Decorator":
            out["child"] = self.only_child(element)
        elif model.category == "Control":
            out["children"] = self.children(element, 1)
        elif element.children:
            raise element.error(f"{_shown(kind)} is a leaf and takes no children")
        return out

    def check_params(self, element: XmlElement, kind: str, params: dict[str, Any]) -> None:
        """Validate a node's parameters here, where the XML can be pointed at."""
        if has_reference(params):
            return  # checked when the converted tree is loaded, with the values bound
        cls = self.registry.get(kind)
        try:  # each value as the XML wrote it and a run reads it: '$$x' is the text '$x'
            cls.Params.model_validate(
                literal(params), context={"units_required": True, "magnitude_limits": True}
            )
        except ValidationError as exc:
            problems = validation_problems(exc, params)
            where, message = problems[0] if problems else ((), str(exc))
            field = ".".join(str(p) for p in where)
            if not field or message.startswith(f"{field}:"):  # "value: value: should be"
                field = ""
            raise element.error(f"{kind}: {field + ': ' if field else ''}{message}") from None


def xml_to_tree(path: str | Path, registry: Registry | None = None) -> dict[str, Any]:
    """Read a BT.CPP v4 XML file into the mapping of a pirate_bt tree file.

    Raises:
        LocatedError: the file cannot be read (at ``file:1:1``), or anything that
            cannot become a pirate_bt tree, located.
    """
    return _read(file_argument(path, "path"), registry or default_registry())[0]


def _read(
    path: Path, registry: Registry
) -> tuple[dict[str, Any], dict[tuple[str | int, ...], SourceLocation]]:
    importer = _Importer(parse_xml(path), registry)
    data = importer.read()
    if _values(data) > MAX_NODES:  # refused here, not by the loader in a temporary file
        raise importer.root.error(
            f"the tree converts to more than {MAX_NODES} values, more than a tree file may hold"
        )
    return data, importer.locations(data)


def _values(data: Any) -> int:
    """How many values ``data`` is as YAML (each mapping, list, key and scalar), as
    :mod:`pirate_bt.yamlfile` counts them."""
    count = 0
    stack = [data]
    while stack:
        value = stack.pop()
        count += 1
        if isinstance(value, dict):
            count += len(value)  # the keys
            stack.extend(value.values())
        elif isinstance(value, list):
            stack.extend(value)
    return count
