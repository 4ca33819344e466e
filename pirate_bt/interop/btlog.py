"""Traces as BehaviorTree.CPP ``FileLogger2`` logs (``.btlog``), which Groot2 replays.

The format, as BT.CPP 4 writes it (``src/loggers/bt_file_logger_v2.cpp``), all
integers little-endian:

======================  ==========================================================
bytes                   content
======================  ==========================================================
18                      ``BTCPP4-FileLogger2``
1                       protocol version, ``1``
4                       length *n* of the XML (signed 32-bit)
*n*                     the tree as XML (``WriteTreeToXML`` with metadata: every
                        node carries its ``_uid``)
8                       the time the log started, microseconds since 1970 (signed)
9 each, to the end      one status transition: 6 bytes of microseconds since the
                        start, 2 bytes of node UID, 1 byte of status (0 IDLE,
                        1 RUNNING, 2 SUCCESS, 3 FAILURE, 4 SKIPPED)
======================  ==========================================================

BT.CPP numbers the nodes of a tree 1, 2, 3, ... depth first, in the order its
XML parser creates them. A pirate_bt trace holds the tree as it ran, subtrees
expanded (see :mod:`pirate_bt.trace.structure`), nodes depth first: the log's
XML is that tree as one ``<BehaviorTree>``, so node *k* of the trace is UID
*k + 1*, which is what BT.CPP assigns when it loads the same XML. Composites
and decorators are written as BT.CPP's own nodes where they match (the mapping
of :mod:`pirate_bt.interop.btcpp`), the rest as pirate_bt node models.

A trace records each node's status at the end of each tick, not every step
inside it. The log is rebuilt from those: in each tick the tree is walked in the
order BT.CPP ticks it: a node that starts RUNNING on the way down (a composite or
decorator that finished within one tick is shown RUNNING first, as BT.CPP always
does before it ticks children), a completion on the way back up; then the nodes
that went back to IDLE. All carry the tick's time.
"""

from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any, Final

from pirate_bt.errors import InputError, file_argument, output_argument
from pirate_bt.interop.btcpp import TO_BTCPP, NodeModel, encode_value, node_models
from pirate_bt.interop.btcpp_xml import write_atomic_bytes
from pirate_bt.trace.structure import NodeInfo, TreeStructure
from pirate_bt.treefile.params import SI_UNITS
from pirate_bt.treefile.registry import Registry, default_registry
from pirate_bt.yamlfile import read_at_most, special_file

__all__ = [
    "MAGIC",
    "MAX_BTLOG_BYTES",
    "PROTOCOL",
    "STATUS_CODES",
    "BtLog",
    "Transition",
    "export_btlog",
    "read_btlog",
    "structure_xml",
    "trace_transitions",
    "write_btlog",
]

MAGIC: Final = b"BTCPP4-FileLogger2"
PROTOCOL: Final = 1
#: Trace status letter -> BT.CPP ``NodeStatus`` value.
STATUS_CODES: Final = {"I": 0, "R": 1, "S": 2, "F": 3}
_RECORD: Final = 9
MAX_BTLOG_BYTES: Final = 256 * 1024 * 1024
"""The largest ``.btlog`` read (about 28 million transitions; ``/dev/zero`` never ends)."""
_MAX_UID: Final = 0xFFFF
_MAX_US: Final = (1 << 48) - 1


@dataclass(frozen=True)
class Transition:
    """One status change: microseconds since the log started, node UID, BT.CPP status."""

    time_us: int
    uid: int
    status: int


@dataclass(frozen=True)
class BtLog:
    """A ``.btlog`` file's content.

    Attributes:
        xml: The tree (BT.CPP XML with ``_uid`` on every node).
        start_us: When the log started, microseconds since 1970.
        transitions: Every status change, in order.
        truncated: The file ended inside a transition record.
    """

    xml: str
    start_us: int
    transitions: tuple[Transition, ...]
    truncated: bool = False


# -- the tree ----------------------------------------------------------------------------

# py_trees decorators that pirate_bt adapts keep py_trees' own parameter names.
_ADAPTED_PARAMS: Final = {"num_failures": "attempts", "num_success": "times"}
_POLICIES: Final = {"SuccessOnAll": "all", "SuccessOnOne": "one", "SuccessOnSelected": "selected"}


def _types_by_class(registry: Registry) -> dict[str, str]:
    out: dict[str, str] = {}
    for name in registry.names():
        try:
            out.setdefault(registry.get(name).__name__, name)
        except ImportError:
            continue
    return out


def _port_text(value: Any, port_type: str) -> str:
    if port_type in SI_UNITS and isinstance(value, int | float) and not isinstance(value, bool):
        return f"{value!r} {SI_UNITS[port_type][1]}"  # traces hold SI numbers
    return encode_value(value, port_type)


_NOT_XML: Final = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
"""What XML 1.0 cannot hold, even escaped: control characters, lone surrogates, U+FFFE/F."""


def _xml_text(text: str) -> str:
    """``text`` with every character XML cannot hold replaced by U+FFFD.

    A tree built in Python (or a trace of one) may name a node anything; ElementTree
    writes such characters as they are, which no XML parser reads (and a lone
    surrogate is not even UTF-8).
    """
    return _NOT_XML.sub("\ufffd", text)


class _TreeWriter:
    def __init__(self, structure: TreeStructure, registry: Registry) -> None:
        self.structure = structure
        self.models = node_models(registry)
        self.by_class = _types_by_class(registry)
        self.used: dict[str, NodeModel] = {}

    def element(self, node: NodeInfo, uid: int) -> ET.Element:
        params = dict(node.params)
        kind = self.by_class.get(node.type)
        tag: str
        attrs: dict[str, str] = {}
        if node.type in ("Sequence", "Selector") and node.kind == "composite":
            memory = bool(params.get("memory", node.type == "Sequence"))
            tag = {
                ("Sequence", True): "Sequence",
                ("Sequence", False): "ReactiveSequence",
                ("Selector", True): "Fallback",
                ("Selector", False): "ReactiveFallback",
            }[(node.type, memory)]
        elif node.type == "Parallel" and node.kind == "composite":
            tag = "parallel"
            self.used[tag] = self.models[tag]
            policy = _POLICIES.get(str(params.get("policy", "")))
            if policy:
                attrs["policy"] = policy
        elif kind is not None:
            model = self.models[kind]
            params = {_ADAPTED_PARAMS.get(k, k): v for k, v in params.items()}
            tag = kind
            renames: dict[str, str] = {}
            if kind in TO_BTCPP and kind != "oneshot":
                tag, renames = TO_BTCPP[kind]
            else:
                self.used[kind] = model
            for key, value in params.items():
                port = model.port(key)
                if port is not None and value is not None:
                    attrs[renames.get(key, key)] = _port_text(value, port.type)
        else:  # a behaviour of the caller's own, outside the registry
            tag = node.type if node.type.isidentifier() else "Behaviour"  # an XML name
            if tag not in self.used:
                category = {"composite": "Control", "leaf": "Action"}.get(node.kind, "Decorator")
                self.used[tag] = NodeModel(tag, category, ())
        element = ET.Element(tag, {"name": _xml_text(node.name), "_uid": str(uid)})
        for key, value in attrs.items():
            element.set(key, _xml_text(value))
        return element


def structure_xml(structure: TreeStructure, registry: Registry | None = None) -> str:
    """The tree of a trace as BT.CPP XML with ``_uid`` on every node (node *k* is UID *k+1*).

    Raises:
        InputError: the tree has more nodes than a ``.btlog`` can number.
    """
    if len(structure) > _MAX_UID:
        raise InputError(
            f"the tree has {len(structure)} nodes; BehaviorTree.CPP (a .btlog, Groot2)"
            f" numbers at most {_MAX_UID}"
        )
    writer = _TreeWriter(structure, registry or default_registry())
    root = ET.Element("root", {"BTCPP_format": "4"})
    tree = ET.SubElement(root, "BehaviorTree", {"ID": _xml_text(structure.name), "_fullpath": ""})
    elements: dict[str, ET.Element] = {}
    for uid, node in enumerate(structure, start=1):
        element = writer.element(node, uid)
        parent = tree if node.parent is None else elements[node.parent]
        parent.append(element)
        elements[node.id] = element
    models = ET.SubElement(root, "TreeNodesModel")
    for name in sorted(writer.used):
        model = writer.used[name]
        entry = ET.SubElement(models, model.category, {"ID": model.id})
        for port in model.ports:
            port_element = ET.SubElement(
                entry, "input_port", {"name": port.name, "type": port.type}
            )
            port_element.text = port.description or None
    ET.indent(root, space="    ")
    return ET.tostring(root, "unicode")


# -- the transitions -------------------------------------------------------------------


def trace_transitions(trace: Any) -> list[Transition]:
    """Every status change of a :class:`~pirate_bt.trace.reader.Trace`, as BT.CPP orders them.

    Raises:
        InputError: a status code the log cannot hold, or a run too long for it.
    """
    structure: TreeStructure = trace.structure
    order = [n.id for n in structure]
    uid = {node_id: i for i, node_id in enumerate(order, start=1)}
    leaf = {n.id: n.kind == "leaf" for n in structure}
    status = {node_id: "I" for node_id in order}
    out: list[Transition] = []
    for tick in trace.ticks:
        if not tick.status:
            continue
        time_us = round(tick.t_s * 1_000_000)
        if time_us < 0:  # a wall clock set back (it said "beyond a .btlog")
            raise InputError(
                f"{trace.path}: tick {tick.n} at {tick.t_s} s is before the run's start;"
                " a .btlog holds no time before it"
            )
        if time_us > _MAX_US:
            raise InputError(f"{trace.path}: tick {tick.n} at {tick.t_s} s is beyond a .btlog")
        new: dict[str, str] = {}
        for node_id, code in tick.status.items():
            if not isinstance(code, str) or code not in STATUS_CODES:  # a list: TypeError
                raise InputError(f"{trace.path}: tick {tick.n}: unknown status {code!r}")
            if node_id in uid and code != status[node_id]:
                new[node_id] = code
        stack: list[tuple[str, bool]] = [(structure.root.id, False)]
        while stack:  # in the order BT.CPP runs them: a start on the way down,
            node_id, done = stack.pop()  # a completion on the way back up
            code = new.get(node_id)
            if done:
                if code in ("S", "F"):
                    out.append(Transition(time_us, uid[node_id], STATUS_CODES[code]))
                continue
            if code == "R" or (code in ("S", "F") and not leaf[node_id] and status[node_id] != "R"):
                out.append(Transition(time_us, uid[node_id], STATUS_CODES["R"]))
            stack.append((node_id, True))
            stack.extend((c, False) for c in reversed(structure.node(node_id).children))
        for node_id in order:  # back to idle (halted or reset)
            if new.get(node_id) == "I":
                out.append(Transition(time_us, uid[node_id], STATUS_CODES["I"]))
        status.update(new)
    return out


# -- the file ----------------------------------------------------------------------------


def btlog_bytes(xml: str, start_us: int, transitions: Iterable[Transition]) -> bytes:
    """The bytes of a ``.btlog`` file (see the module docstring)."""
    body = xml.encode("utf-8")
    parts = [
        MAGIC,
        bytes([PROTOCOL]),
        struct.pack("<i", len(body)),
        body,
        struct.pack("<q", start_us),
    ]
    for t in transitions:
        parts.append(t.time_us.to_bytes(6, "little") + struct.pack("<H", t.uid) + bytes([t.status]))
    return b"".join(parts)


def write_btlog(
    path: str | Path, xml: str, start_us: int, transitions: Sequence[Transition]
) -> Path:
    """Write a ``.btlog`` file atomically."""
    return write_atomic_bytes(Path(path), btlog_bytes(xml, start_us, transitions))


def read_btlog(path: str | Path) -> BtLog:
    """Read a ``.btlog`` file (ours or BT.CPP's); a cut-off last record is dropped.

    Raises:
        InputError: ``path`` is no file name, cannot be read or is larger than
            :data:`MAX_BTLOG_BYTES`; not a ``FileLogger2`` file, or a header that does
            not fit the file.
    """
    where = file_argument(path, "path")
    kind = special_file(where)  # a named pipe nobody writes to was waited on for ever
    if kind is not None:
        raise InputError(f"{where}: cannot read: it is {kind}, not a file")
    try:
        with where.open("rb") as stream:  # at most MAX_BTLOG_BYTES: /dev/zero never ends
            data = read_at_most(stream, MAX_BTLOG_BYTES)
    except OSError as exc:
        raise InputError(f"{where}: cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_BTLOG_BYTES:
        raise InputError(f"{where}: larger than the {MAX_BTLOG_BYTES} bytes a .btlog may be")
    head = len(MAGIC) + 1 + 4
    if len(data) < head or not data.startswith(MAGIC):
        raise InputError(f"{where}: not a BehaviorTree.CPP FileLogger2 log (.btlog)")
    if data[len(MAGIC)] != PROTOCOL:
        raise InputError(f"{where}: FileLogger2 protocol {data[len(MAGIC)]} is not 1")
    (size,) = struct.unpack_from("<i", data, len(MAGIC) + 1)
    if size < 0 or head + size + 8 > len(data):
        raise InputError(f"{where}: the XML length ({size} bytes) does not fit the file")
    try:
        xml = data[head : head + size].decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{where}: the tree XML is not UTF-8") from None
    (start_us,) = struct.unpack_from("<q", data, head + size)
    rest = memoryview(data)[head + size + 8 :]
    whole = len(rest) - len(rest) % _RECORD
    transitions = tuple(
        Transition(
            int.from_bytes(rest[i : i + 6], "little"),
            int.from_bytes(rest[i + 6 : i + 8], "little"),
            rest[i + 8],
        )
        for i in range(0, whole, _RECORD)
    )
    return BtLog(xml, start_us, transitions, truncated=whole != len(rest))


def _start_us(header: Any) -> int:
    text = header.get("created_utc") if hasattr(header, "get") else None
    if isinstance(text, str):
        try:
            return round(datetime.fromisoformat(text.replace("Z", "+00:00")).timestamp() * 1e6)
        except ValueError:
            pass
    return 0


def export_btlog(trace_path: Path, out_path: Path, registry: Registry | None = None) -> Path:
    """Write the trace at ``trace_path`` as a Groot2-replayable ``.btlog`` at ``out_path``.

    Returns:
        The file written.

    Raises:
        InputError: a path that is no file name (an output that is a folder too), the
            trace cannot be read or does not fit a ``.btlog``, or the output cannot be
            written.
    """
    from pirate_bt.trace.reader import read_trace

    out = output_argument(out_path, "out_path")
    trace = read_trace(file_argument(trace_path, "trace_path"))
    try:
        xml = structure_xml(trace.structure, registry)
    except InputError as exc:  # it named no file: "the tree has 70001 nodes; ..."
        raise InputError(f"{trace.path}: {exc}") from None
    try:
        return write_btlog(out, xml, _start_us(trace.header), trace_transitions(trace))
    except OSError as exc:
        raise InputError(f"out_path: cannot write {out}: {exc.strerror or exc}") from None
