"""BehaviorTree.CPP v4 XML export: a pirate_bt tree file (and the files it uses) as XML.

:func:`tree_to_xml` and :func:`export_xml`, re-exported by
:mod:`pirate_bt.interop.btcpp`.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Final

from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    InputError,
    LocatedError,
    file_argument,
    shown,
)
from pirate_bt.interop.btcpp_models import (
    _BTCPP_BUILTINS,
    _HINT,
    _PARALLEL_MODEL,
    BTCPP_FORMAT,
    PORT_NAME_RULE,
    TO_BTCPP,
    NodeModel,
    _json,
    _xml_safe,
    btcpp_port_name,
    encode_value,
    node_models,
)
from pirate_bt.interop.btcpp_xml import caller_params_origin, output_file, write_atomic
from pirate_bt.treefile.names import printable
from pirate_bt.treefile.params import SI_UNITS
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.yamlfile import Locator, YamlDocument, load_yaml

__all__ = ["export_xml", "tree_to_xml"]

_MAPPING = "<dict>"
"""The file name of a tree given as a mapping (as the loader names it)."""


def _params_mapping(params: object) -> dict[str, Any]:
    """``params`` as given to a function that reads an XML tree or writes one: a
    mapping of names to values, or None.

    Raises:
        ArgumentTypeError: not a mapping (a list of ``name=value`` texts, a string).
    """
    if params is None:
        return {}
    if not isinstance(params, Mapping):
        name = type(params).__name__
        article = "an" if name[:1].lower() in "aeiou" else "a"
        raise ArgumentTypeError(
            "params: give a mapping of names to values ({'roll': '90 deg'}),"
            f" not {article} {name}"
        )
    return dict(params)


def _params_argument(params: object) -> dict[str, Any]:
    """``params`` as given to :func:`tree_to_xml` or :func:`export_xml`
    (:func:`_params_mapping`), each a value XML can carry.

    Raises:
        ArgumentTypeError: not a mapping.
        ArgumentValueError: a text holding half a surrogate pair.
    """
    params = _params_mapping(params)
    for key, value in params.items():
        half = re.search("[\ud800-\udfff]", value) if isinstance(value, str) else None
        if half is not None:  # a byte of the command line that is no UTF-8 ($'\xff')
            raise ArgumentValueError(
                f"parameter {key!r}: {shown(value)} holds U+{ord(half[0]):04X}, half a"
                " surrogate pair (a byte that is no UTF-8 text), which XML cannot carry;"
                " nothing written"
            )
    return dict(params)


def _located(doc: YamlDocument, path: tuple[str | int, ...], message: str) -> LocatedError:
    return LocatedError(printable(message), doc.locator.locate(path))


def _text(doc: YamlDocument, path: tuple[str | int, ...], text: str) -> str:
    """``text`` for an XML attribute; a control character XML 1.0 cannot carry is refused."""
    if not _xml_safe(text):
        bad = next(c for c in text if not _xml_safe(c))
        what = str(path[-1]) if path else "name"
        raise _located(doc, path, f"{what}: U+{ord(bad):04X} cannot be written in XML")
    return text


def _port_name(doc: YamlDocument, path: tuple[str | int, ...], name: str) -> None:
    """Refuse a parameter name BT.CPP takes for no port (:func:`btcpp_port_name`): the
    value of such a parameter was silently lost in BT.CPP, or ran as a script, or
    (``ID``) named another tree."""
    if btcpp_port_name(name):
        return
    raise _located(
        doc,
        path,
        f"parameter {name!r}: BehaviorTree.CPP takes no port of this name ({PORT_NAME_RULE});"
        " rename it to export the tree",
    )


class _Exporter:
    """Walks the tree files (as written, before parameters are substituted)."""

    def __init__(self, registry: Registry, models: dict[str, NodeModel]) -> None:
        self.registry = registry
        self.models = models
        self.docs: dict[str, YamlDocument] = {}
        self.ids: dict[str, str] = {}  # file#name -> BehaviorTree ID
        self.trees: list[ET.Element] = []
        self.params: dict[str, tuple[YamlDocument, tuple[str | int, ...], Any]] = {}
        self.taken = set(models) | set(_BTCPP_BUILTINS)

    def document(self, path: Path) -> YamlDocument:
        key = str(path.resolve())
        if key not in self.docs:
            self.docs[key] = load_yaml(path)
        return self.docs[key]

    def tree(self, doc: YamlDocument, name: str, tree_id: str | None = None) -> str:
        ident = f"{Path(doc.file).resolve()}#{name}"
        if ident in self.ids:
            return self.ids[ident]
        data = doc.data
        if not tree_id:
            if name:
                tree_id = name if doc is self.root_doc else f"{self.file_id(doc)}.{name}"
            else:
                tree_id = self.file_id(doc)
        # an ID pirate_bt's import would read as a file reference (a '#', a .yaml
        # ending) could not come back: BT.CPP took the file, `import btcpp` refused it
        tree_id = tree_id.replace("#", "_")
        if tree_id.lower().endswith((".yaml", ".yml")):
            tree_id += "_"
        base, n = tree_id, 1
        while tree_id in self.taken:
            n += 1
            tree_id = f"{base}_{n}"
        self.taken.add(tree_id)
        self.ids[ident] = tree_id
        prefix: tuple[str | int, ...] = ("subtrees", name) if name else ()
        body = data["subtrees"][name] if name else data
        id_path = ("subtrees", name) if name else ("name",)
        element = ET.Element("BehaviorTree", {"ID": _text(doc, id_path, tree_id)})
        if name and doc is self.root_doc and tree_id != name:
            # BT.CPP refuses a tree ID that is a node type's, and two trees of one ID:
            # the name the ID could not be is kept beside it, for import to restore
            element.set("_name", _text(doc, id_path, name))
        if isinstance(body.get("description"), str):
            element.set("_description", _text(doc, (*prefix, "description"), body["description"]))
        self.trees.append(element)
        self.params[tree_id] = (doc, (*prefix, "params"), body.get("params") or {})
        for key, decl in (body.get("params") or {}).items():
            _port_name(doc, (*prefix, "params", key), key)
            if isinstance(decl, dict) and isinstance(decl.get("description"), str):
                _text(doc, (*prefix, "params", key, "description"), decl["description"])
        element.append(self.node(doc, (*prefix, "root"), body["root"]))
        return tree_id

    def value(self, doc: YamlDocument, value: Any, port_type: str) -> str:
        """A value as port text; a mapping's numbers are SI, so they get their unit."""
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if doc.file == _MAPPING and number and port_type in SI_UNITS:
            return f"{value!r} {SI_UNITS[port_type][1]}"
        return encode_value(value, port_type)

    def file_id(self, doc: YamlDocument) -> str:
        name = doc.data.get("name")
        return name if isinstance(name, str) and name else Path(doc.file).stem

    def node(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        if isinstance(raw, str):
            raw = {"type": raw}
        kind: str = raw["type"]
        if kind == "subtree":
            element = self.subtree(doc, path, raw)
        elif kind in ("sequence", "selector", "parallel", "eternal_guard"):
            element = self.composite(doc, path, raw)
        else:
            element = self.registered(doc, path, raw)
        if isinstance(raw.get("description"), str):
            element.set("_description", _text(doc, (*path, "description"), raw["description"]))
        return element

    def subtree(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        ref: str = raw["ref"]
        file_part, hash_sign, tree_name = ref.partition("#")
        if file_part.lower().endswith((".yaml", ".yml")):
            target = self.document(Path(doc.file).parent / file_part)
            name = tree_name if hash_sign else ""
        else:
            target, name = doc, file_part
        tree_id = self.tree(target, name)
        element = ET.Element("SubTree", {"ID": tree_id})
        if raw.get("name"):
            element.set("name", _text(doc, (*path, "name"), raw["name"]))
        decls = self.declared(target, name)
        given = raw.get("params") or {}
        for key, value in given.items():
            element.set(key, self.value(doc, value, decls.get(key, "string")))
        for key in self.empty_defaults(target, name):
            # BT.CPP takes a model's empty default for none (the call "is not remapping
            # a mandatory port"): the empty text is given here, where it reads as itself
            if key not in given:
                element.set(key, "")
        return element

    def empty_defaults(self, doc: YamlDocument, name: str) -> list[str]:
        """The parameters of tree ``name`` of ``doc`` whose default is written as empty
        port text (``default: ""``)."""
        body = doc.data["subtrees"][name] if name else doc.data
        return [
            key
            for key, decl in (body.get("params") or {}).items()
            if isinstance(decl, dict)
            and decl.get("default") is not None
            and encode_value(decl["default"], str(decl.get("type", "string"))) == ""
        ]

    def declared(self, doc: YamlDocument, name: str) -> dict[str, str]:
        body = doc.data["subtrees"][name] if name else doc.data
        out: dict[str, str] = {}
        for key, decl in (body.get("params") or {}).items():
            out[key] = decl if isinstance(decl, str) else str(decl.get("type", "string"))
        return out

    def composite(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        kind = raw["type"]
        attrs: dict[str, str] = {}
        if kind == "eternal_guard":
            tag = "ReactiveSequence"
            kids = [*raw["conditions"], raw["child"]]
            paths = [
                *((*path, "conditions", i) for i in range(len(raw["conditions"]))),
                (*path, "child"),
            ]
            attrs[_HINT] = "eternal_guard"
        else:
            kids = raw["children"]
            paths = [(*path, "children", i) for i in range(len(kids))]
            if kind in ("sequence", "selector"):
                memory = raw.get("memory", kind == "sequence")
                if not isinstance(memory, bool):
                    raise _located(
                        doc,
                        (*path, "memory"),
                        "memory: a parameter cannot choose between BT.CPP's node types;"
                        " write true or false",
                    )
                tag = {
                    ("sequence", True): "Sequence",
                    ("sequence", False): "ReactiveSequence",
                    ("selector", True): "Fallback",
                    ("selector", False): "ReactiveFallback",
                }[(kind, memory)]
            else:
                tag, attrs = self.parallel(raw)
        element = ET.Element(tag)
        if raw.get("name"):
            element.set("name", _text(doc, (*path, "name"), raw["name"]))
        for key, value in attrs.items():
            element.set(key, value)
        for kid_path, kid in zip(paths, kids, strict=True):
            element.append(self.node(doc, kid_path, kid))
        return element

    def parallel(self, raw: Mapping[str, Any]) -> tuple[str, dict[str, str]]:
        policy = raw.get("policy", "all")
        sync = raw.get("synchronise", policy != "one")
        if "selected" not in raw:
            if policy == "all" and sync is True:
                return "Parallel", {"success_count": "-1", "failure_count": "1"}
            if policy == "one" and sync is False:
                return "Parallel", {"success_count": "1", "failure_count": "1"}
        attrs: dict[str, str] = {}
        for key in ("policy", "synchronise", "selected"):
            if key in raw:
                port = _PARALLEL_MODEL.port(key)
                attrs[key] = encode_value(raw[key], port.type if port else "string")
        return "parallel", attrs

    def registered(self, doc: YamlDocument, path: tuple[str | int, ...], raw: Any) -> ET.Element:
        kind: str = raw["type"]
        model = self.models[kind]
        params = {k: v for k, v in raw.items() if k not in ("type", "name", "description", "child")}
        tag: str = kind
        renames: dict[str, str] = {}
        if kind in TO_BTCPP and (
            kind != "oneshot" or params.get("on", "completion") == "completion"
        ):
            tag, renames = TO_BTCPP[kind]
            if kind == "oneshot":
                params = {"then_skip": False}
        element = ET.Element(tag)
        if raw.get("name"):
            element.set("name", _text(doc, (*path, "name"), raw["name"]))
        for key, value in params.items():
            port = model.port(key)
            port_type = port.type if port else "boolean"
            text = self.value(doc, value, port_type)
            # a node's port "=" is BT.CPP's pointer to the port's own key: the text as JSON
            element.set(renames.get(key, key), _json(text) if text == "=" else text)
        if "child" in raw:
            element.append(self.node(doc, (*path, "child"), raw["child"]))
        return element

    root_doc: YamlDocument


_READ_AS_TEXT: Final = frozenset({"boolean", "integer", "number"})
"""Parameter types whose command-line text (``yes``, ``+3``, ``+1.5``) BT.CPP and the
import do not read as a run does: written as the run read it."""


def _model_element(model: NodeModel) -> ET.Element:
    element = ET.Element(model.category, {"ID": model.id})
    for port in model.ports:
        attrs = {"name": port.name, "type": port.type}
        if port.default is not None:
            attrs["default"] = port.default
        if port.choices:
            attrs["choices"] = ";".join(port.choices)
        child = ET.SubElement(element, "input_port", attrs)
        child.text = port.description or None
    return element


def _subtree_model(
    tree_id: str, decls: Mapping[str, Any], given: Mapping[str, Any], values: Mapping[str, Any]
) -> ET.Element:
    """``given``: the caller's parameters of this tree; ``values``: as the loader read them."""
    element = ET.Element("SubTree", {"ID": tree_id})
    for name, decl in decls.items():
        decl = {"type": decl} if isinstance(decl, str) else dict(decl)
        kind = str(decl.get("type", "string"))
        attrs = {"name": name, "type": kind}
        text = given.get(name)
        if name in given and (not isinstance(text, str) or kind in _READ_AS_TEXT):
            # as the run read it: "yes" is true, "+3" is 3 (BT.CPP and the import read
            # neither); a value given from Python (3, True) has no text of its own
            attrs["default"] = encode_value(values[name], kind)
        elif isinstance(text, str):  # the caller's text, as it is: escaped as a file would
            attrs["default"] = encode_value("$" + text if text.startswith("$") else text, kind)
        elif decl.get("default") is not None:
            attrs["default"] = encode_value(decl["default"], kind)
        if decl.get("example") is not None:
            attrs["example"] = encode_value(decl["example"], kind)
        if decl.get("choices"):
            attrs["choices"] = _json(list(decl["choices"]))
        if decl.get("description"):  # where BT.CPP's parser reads a <SubTree> model's
            attrs["description"] = str(decl["description"])  # (and spaces, CR survive)
        port = ET.SubElement(element, "input_port", attrs)
        port.text = str(decl["description"]) if decl.get("description") else None
    return element


def tree_to_xml(
    path: str | Path | Mapping[str, Any],
    params: Mapping[str, Any] | None = None,
    registry: Registry | None = None,
    checked: Any = None,
) -> str:
    """The tree file at ``path`` (and every file it uses) as BT.CPP v4 XML text.

    The tree is checked first, with the loader (a parameter without a default
    takes ``params``, then its ``example``). Values given in ``params`` become
    the defaults of the main tree's ports. ``path`` may also be a tree as a
    mapping (planner code, a mission's tree): its numbers are SI and are written
    with their unit (``2.0 s``); its subtree files are found from the current
    folder, as the loader finds them. ``checked``: the
    :class:`~pirate_bt.treefile.LoadedTree` of ``path``, already loaded and
    checked by the caller, which is then not loaded again.

    Raises:
        ArgumentTypeError: ``params`` is not a mapping.
        ValidationFailed: the tree does not load.
        LocatedError: the tree uses something XML cannot say.
    """
    from pirate_bt.treefile import load_tree

    reg = registry or default_registry()
    given = _params_argument(params)
    source: Path | Mapping[str, Any] = (
        path if isinstance(path, Mapping) else file_argument(path, "path")
    )
    loaded = checked
    if loaded is None:
        loaded = load_tree(
            source,
            params=given,
            params_from_text=True,
            use_examples=True,
            registry=reg,
            params_origin=caller_params_origin() if given else None,
        )
    exporter = _Exporter(reg, node_models(reg))
    if isinstance(source, Mapping):
        exporter.root_doc = YamlDocument(dict(source), Locator(_MAPPING))
    else:
        exporter.root_doc = exporter.document(source)
    main_id = exporter.tree(exporter.root_doc, "", loaded.name)
    written_name = exporter.root_doc.data.get("name")
    if not isinstance(written_name, str):  # the file has no name: say so (empty)
        exporter.trees[0].set("_name", "")
    elif main_id != written_name:  # the name is a node type's: keep it beside the ID
        exporter.trees[0].set("_name", written_name)
    root = ET.Element("root", {"BTCPP_format": BTCPP_FORMAT, "main_tree_to_execute": main_id})
    board = {key: decl.model_dump(exclude_defaults=True) for key, decl in loaded.blackboard.items()}
    if board:
        exporter.trees[0].set("_blackboard", _json(board))
    root.extend(exporter.trees)
    models = ET.SubElement(root, "TreeNodesModel")
    for name in sorted(exporter.models):
        models.append(_model_element(exporter.models[name]))
    for element in exporter.trees:
        tree_id = element.get("ID", "")
        _doc, _where, decls = exporter.params[tree_id]
        mine = given if tree_id == main_id else {}
        models.append(_subtree_model(tree_id, decls, mine, loaded.params))
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, "unicode") + "\n"


def export_xml(
    tree_path: str | Path,
    out_path: str | Path,
    params: Mapping[str, Any] | None = None,
    registry: Registry | None = None,
) -> Path:
    """Write ``tree_path`` as BT.CPP v4 XML to ``out_path`` (atomically); see :func:`tree_to_xml`.

    Returns:
        The file written.

    Raises:
        InputError: a path that is no file name (an output that is a folder too), the
            tree file itself as the output, an output not named ``.xml``, or an output
            that cannot be written.
        ArgumentTypeError: ``params`` is not a mapping.
        ValidationFailed: the tree does not load.
    """
    tree = file_argument(tree_path, "tree_path")
    out = output_file(out_path, "out_path")
    given = _params_argument(params)
    if out.exists() and out.resolve() == tree.resolve():
        raise InputError(f"{out}: is the tree file being exported; nothing written")
    if out.suffix.lower() != ".xml":  # was written, XML in x.json, Groot2 then refusing it
        raise InputError(
            f"{out}: BehaviorTree.CPP XML is written to a .xml file (as Groot2 opens it),"
            f" not {out.suffix or 'a name without a suffix'}; nothing written"
        )
    text = tree_to_xml(tree, given, registry)
    try:
        return write_atomic(out, text)
    except OSError as exc:
        raise InputError(f"{out}: cannot write: {exc.strerror or exc}") from None
