"""Load YAML files so that every later error can point at ``file:line:column``.

Parsing text and validating data are separate steps (as pydantic-over-YAML
projects do it): :func:`load_yaml` turns a file into plain Python data plus a
:class:`Locator` that maps a path inside that data (``("boards", 3, "id")``) back
to where it was written. Validators then raise with a path, and
:func:`pydantic_errors` translates pydantic's error locations into
:class:`~pirate_bt.errors.LocatedError` objects.

The loader refuses what ``yaml.safe_load`` would quietly accept or crash on:
a directory, an empty file, a binary file, bytes that are not UTF-8, and a key
written twice in one mapping (PyYAML keeps the last one and loses the first),
and aliases that expand to more than :data:`MAX_NODES` values (the "billion
laughs" file: a few lines of nested ``*alias`` lists that expand to hundreds of millions of
values). Aliases are counted on the composed node graph, where an alias is one
shared node, before anything is expanded: the check costs time and memory in
proportion to the file, not to what it would expand to. An alias inside the
value it names (``&a [*a]``), values nested deeper than :data:`MAX_DEPTH` and a
whole number too long for Python to read are refused at their line too.
"""

from __future__ import annotations

import re
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from pirate_bt.errors import LocatedError, SourceLocation, ValidationFailed, shown

__all__ = [
    "Locator",
    "YamlDocument",
    "check_depth",
    "decode_text",
    "describe_error",
    "load_yaml",
    "load_yaml_text",
    "pydantic_errors",
    "read_at_most",
    "unique_errors",
    "validate_document",
    "validation_problems",
]

PathKey = tuple[str | int, ...]

MAX_NODES = 100_000
"""The most values (scalars, lists, mappings) a file may expand to, aliases included.

The largest bundled file expands to a few thousand; a real file that needs more
is not one a person writes."""
MAX_BYTES = 16 * 1024 * 1024
"""The largest file read (a device such as ``/dev/zero`` never ends: it is cut there)."""


def read_at_most(stream: BinaryIO, limit: int) -> bytes:
    """At most ``limit + 1`` bytes of ``stream`` (one more tells a file over the limit).

    Read in 64 KiB pieces: ``stream.read(limit + 1)`` would allocate the whole limit
    for every file, however small, and a device such as ``/dev/zero`` never ends.
    """
    chunks: list[bytes] = []
    total = 0
    while total <= limit:
        chunk = stream.read(min(65536, limit + 1 - total))
        if not chunk:
            break
        chunks.append(chunk)
        total += len(chunk)
    return b"".join(chunks)


MAX_DEPTH = 256
"""The deepest nesting of lists and mappings (libyaml itself stops at 1000, too deep
for the recursive code that later reads the data)."""
ModelT = TypeVar("ModelT", bound=BaseModel)
_INT_TAG = "tag:yaml.org,2002:int"
_BOOL_TAG = "tag:yaml.org,2002:bool"
_STR_TAG = "tag:yaml.org,2002:str"

_Loader: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@dataclass
class Locator:
    """Maps a path into the loaded data to its place in the file."""

    file: str
    marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)

    def locate(self, path: Sequence[str | int]) -> SourceLocation:
        """The place of ``path``, or of its deepest written ancestor.

        Path elements that are not in the file (pydantic's union tags, a missing
        key) are skipped, so the location is always a real place in the file.
        """
        exact = self.marks.get(tuple(path))
        if exact is not None:  # the usual case; the walk below costs O(len(path)^2)
            return SourceLocation(self.file, exact[0], exact[1])
        best = self.marks.get((), (1, 1))
        current: PathKey = ()
        for element in path:
            candidate = (*current, element)
            if candidate not in self.marks:
                # A value merged in with ``<<: *anchor`` is written in the anchor;
                # with ``<<: [*a, *b]`` in the first of them that has it.
                candidate = (*current, "<<", element)
                i = 0
                while candidate not in self.marks and (*current, "<<", i) in self.marks:
                    candidate = (*current, "<<", i, element)
                    i += 1
            if candidate in self.marks:
                current = candidate
                best = self.marks[candidate]
        return SourceLocation(self.file, best[0], best[1])

    def error(self, path: Sequence[str | int], message: str) -> LocatedError:
        """A :class:`LocatedError` for ``path``."""
        return LocatedError(message, self.locate(path))


@dataclass
class YamlDocument:
    """Plain data loaded from YAML, with its :class:`Locator`."""

    data: Any
    locator: Locator

    @property
    def file(self) -> str:
        return self.locator.file


def _mark(node: yaml.Node) -> tuple[int, int]:
    return node.start_mark.line + 1, node.start_mark.column + 1


def _check_expansion(root: yaml.Node, file: str) -> None:
    """Refuse a node graph whose aliases expand to more than :data:`MAX_NODES` values.

    Each node's expanded size is computed once (memoised on the node, which an
    alias shares), so a bomb is found in time linear in the file. The error
    points at the smallest mapping or list that expands past the limit. An alias
    inside the very value it names (``&a [*a]``) would expand for ever: refused.
    """
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()  # nodes whose children are being sized
    # Iterative post-order: a deep file must not hit Python's recursion limit.
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        if id(node) in sizes:
            continue
        if not children_done and id(node) in open_nodes:
            raise ValidationFailed(
                [
                    LocatedError(
                        "YAML alias inside the value it names (a recursive alias)",
                        SourceLocation(file, *_mark(node)),
                    )
                ]
            )
        if isinstance(node, yaml.MappingNode):
            children = [n for pair in node.value for n in pair]
        elif isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        else:
            sizes[id(node)] = 1
            continue
        if not children_done:
            open_nodes.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in children if id(c) not in sizes)
            continue
        open_nodes.discard(id(node))
        size = 1 + sum(sizes.get(id(c), 1) for c in children)
        if size > MAX_NODES:
            if _distinct(node) <= MAX_NODES:
                message = (
                    f"YAML aliases expand this to more than {MAX_NODES} values"
                    " (an alias bomb?); write the values out or use fewer aliases"
                )
            else:
                message = (
                    f"this holds more than {MAX_NODES} values; a file this large is not"
                    " one a person writes"
                )
            raise ValidationFailed([LocatedError(message, SourceLocation(file, *_mark(node)))])
        sizes[id(node)] = size


def _distinct(root: yaml.Node) -> int:
    """How many distinct nodes ``root`` holds (an alias counted once), up to MAX_NODES + 1."""
    seen: set[int] = set()
    stack = [root]
    while stack and len(seen) <= MAX_NODES:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, yaml.MappingNode):
            stack.extend(n for pair in node.value for n in pair)
        elif isinstance(node, yaml.SequenceNode):
            stack.extend(node.value)
    return len(seen)


def _walk(root: yaml.Node, locator: Locator, errors: list[LocatedError]) -> None:
    """Record where each value is written; report duplicate and unusable keys.

    A key that YAML 1.1 resolves to a boolean (a bare ``on:``, ``yes:``, ``n:``) is
    retagged as text, its text kept, before the document is constructed.

    Iterative, so that nesting up to :data:`MAX_DEPTH` never meets the recursion limit.
    """
    stack: list[tuple[yaml.Node, PathKey]] = [(root, ())]
    while stack:
        node, path = stack.pop()
        if len(path) > MAX_DEPTH:
            errors.append(
                LocatedError(
                    f"values nested deeper than {MAX_DEPTH} levels",
                    SourceLocation(locator.file, *_mark(node)),
                )
            )
            return
        if isinstance(node, yaml.ScalarNode):
            limit = sys.get_int_max_str_digits()
            if node.tag == _INT_TAG and limit and len(node.value) > limit:
                errors.append(
                    LocatedError(
                        f"a number of {len(node.value)} digits is too long",
                        SourceLocation(locator.file, *_mark(node)),
                    )
                )
            continue
        items: list[tuple[PathKey, yaml.Node]] = []
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, yaml.Node] = {}
            for i, (key_node, value_node) in enumerate(node.value):
                if isinstance(key_node, yaml.ScalarNode) and key_node.tag == _BOOL_TAG:
                    # YAML 1.1 reads a bare key ``on``, ``off``, ``yes``, ``no``, ``y``,
                    # ``n`` as a boolean: a key is its text (a value keeps its meaning).
                    # A new node: an anchored key may also be used as a value.
                    key_node = yaml.ScalarNode(
                        _STR_TAG, key_node.value, key_node.start_mark, key_node.end_mark
                    )
                    node.value[i] = (key_node, value_node)
                if not isinstance(key_node, yaml.ScalarNode):
                    shape = "mapping" if isinstance(key_node, yaml.MappingNode) else "list"
                    errors.append(
                        LocatedError(
                            f"a key must be a plain value, not a {shape}",
                            SourceLocation(locator.file, *_mark(key_node)),
                        )
                    )
                    continue
                key = key_node.value
                if key in seen:
                    first = seen[key].start_mark.line + 1
                    errors.append(
                        LocatedError(
                            f"duplicate key {key!r} (first written on line {first})",
                            SourceLocation(locator.file, *_mark(key_node)),
                        )
                    )
                seen[key] = key_node
                locator.marks[(*path, key)] = _mark(key_node)
                items.append(((*path, key), value_node))
        elif isinstance(node, yaml.SequenceNode):
            for index, item in enumerate(node.value):
                locator.marks[(*path, index)] = _mark(item)
                items.append(((*path, index), item))
        stack.extend((child, at) for at, child in reversed(items))


def check_depth(data: Any, file: str) -> None:
    """Refuse data (a mapping given in Python) nested deeper than :data:`MAX_DEPTH`.

    What a file cannot hold, a mapping built in code (or read from JSON) may:
    lists in lists thousands deep, or a list that contains itself. Iterative,
    and it stops descending at the limit, so a cycle ends too.

    Raises:
        ValidationFailed: at ``file:1:1`` (a mapping has no lines).
    """
    stack: list[tuple[Any, int]] = [(data, 0)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, Mapping | list | tuple):
            if depth >= MAX_DEPTH:
                raise ValidationFailed(
                    [
                        LocatedError(
                            f"values nested deeper than {MAX_DEPTH} levels (or a value"
                            " that contains itself)",
                            SourceLocation(file),
                        )
                    ]
                )
            items = value.values() if isinstance(value, Mapping) else value
            stack.extend((item, depth + 1) for item in items)


def load_yaml_text(text: str, file: str = "<string>") -> YamlDocument:
    """Parse YAML ``text``; see :func:`load_yaml`.

    Raises:
        ValidationFailed: on a syntax error, an empty document or a duplicate key.
    """
    locator = Locator(file)
    loc = SourceLocation(file)
    if "\x00" in text:
        raise ValidationFailed([LocatedError("binary file, not YAML text", loc)])
    if not text.strip():
        raise ValidationFailed([LocatedError("file is empty", loc)])
    # libyaml's parser (when PyYAML was built with it) is ~10x faster and keeps marks.
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise ValidationFailed([LocatedError("file holds no YAML document", loc)])
        _check_expansion(node, file)
        # Walk before constructing: construction flattens merge keys (<<) in place.
        locator.marks[()] = _mark(node)
        errors: list[LocatedError] = []
        _walk(node, locator, errors)
        if errors:
            raise ValidationFailed(errors)
        data = loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = SourceLocation(file, mark.line + 1, mark.column + 1) if mark is not None else loc
        problem = exc.problem or exc.context or "invalid YAML"
        raise ValidationFailed([LocatedError(f"YAML syntax error: {problem}", where)]) from None
    except yaml.reader.ReaderError as exc:
        # a character YAML does not allow (a control character): PyYAML has no mark for
        # it, and a message over two lines. The reader stops at the first one, so that
        # character's first place in the text is where it is (libyaml counts its
        # position in bytes, PyYAML in characters).
        code = exc.character if isinstance(exc.character, int) else None
        at = text.find(chr(code)) if code is not None and 0 <= code < 0x110000 else -1
        before = text[: at if at >= 0 else max(0, min(exc.position, len(text)))]
        line = before.count("\n") + 1
        column = len(before) - (before.rfind("\n") + 1) + 1
        what = f"U+{code:04X}" if code is not None else "a character"
        raise ValidationFailed(
            [
                LocatedError(
                    f"YAML syntax error: {what} (a control character) is not allowed in YAML",
                    SourceLocation(file, line, column),
                )
            ]
        ) from None
    except yaml.YAMLError as exc:  # pragma: no cover - PyYAML marks nearly everything
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ValidationFailed([LocatedError(f"YAML error: {first}", loc)]) from None
    finally:
        loader.dispose()
    return YamlDocument(data, locator)


def load_yaml(path: str | Path) -> YamlDocument:
    """Read and parse a YAML file, keeping where every value was written.

    Raises:
        ValidationFailed: the file is missing, a directory, binary, not UTF-8,
            empty, or not valid YAML; each error is located.
    """
    p = Path(path)
    name = str(path)
    loc = SourceLocation(name)
    try:
        folder = p.is_dir()
    except (OSError, ValueError) as exc:  # a name the system refuses (a part too long)
        reason = getattr(exc, "strerror", None) or str(exc)
        raise ValidationFailed([LocatedError(f"cannot read: {reason}", loc)]) from None
    if folder:
        raise ValidationFailed([LocatedError("is a directory, not a file", loc)])
    try:
        with p.open("rb") as stream:
            raw = read_at_most(stream, MAX_BYTES)
    except FileNotFoundError:
        raise ValidationFailed([LocatedError("no such file", loc)]) from None
    except OSError as exc:
        raise ValidationFailed([LocatedError(f"cannot read: {exc.strerror}", loc)]) from None
    except ValueError:  # a NUL in the name
        raise ValidationFailed([LocatedError("cannot read: a NUL in the file name", loc)]) from None
    if len(raw) > MAX_BYTES:
        raise ValidationFailed(
            [LocatedError(f"larger than the {MAX_BYTES} bytes a file may be", loc)]
        )
    return load_yaml_text(decode_text(raw, name, "YAML"), name)


def decode_text(raw: bytes, name: str, what: str) -> str:
    """A file's bytes as text (UTF-8), for a file of ``what`` (``YAML``, ``route``).

    Raises:
        ValidationFailed: UTF-16 (its byte-order mark) or a NUL (a binary file), at
            1:1; a byte that is not UTF-8, at its line and column (in characters).
    """
    loc = SourceLocation(name)
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ValidationFailed([LocatedError("UTF-16 text; save the file as UTF-8", loc)])
    if b"\x00" in raw:
        raise ValidationFailed([LocatedError(f"binary file, not {what} text", loc)])
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        start = raw.rfind(b"\n", 0, exc.start) + 1
        line = raw.count(b"\n", 0, exc.start) + 1
        column = len(raw[start : exc.start].decode("utf-8")) + 1  # valid up to the bad byte
        raise ValidationFailed(
            [
                LocatedError(
                    f"not UTF-8 text (byte 0x{raw[exc.start]:02x})",
                    SourceLocation(name, line, column),
                )
            ]
        ) from None


# What a value of each shape is called, for "should be ..." when no union branch fits.
_SHAPES = {
    "model_type": "a mapping of keys",
    "model_attributes_type": "a mapping of keys",
    "dict_type": "a mapping of keys",
    "list_type": "a list",
    "tuple_type": "a list",
    "set_type": "a list",
    "string_type": "text",
    "int_type": "a whole number",
    "int_parsing": "a whole number",
    "float_type": "a number",
    "float_parsing": "a number",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
    "none_required": "empty",
}


def describe_error(error: Any) -> str:
    """One pydantic error as a short sentence, e.g. ``unknown key 'x'``."""
    msg = str(error["msg"])
    kind = error.get("type", "")
    loc = error.get("loc", ())
    if kind == "extra_forbidden" and loc:
        return f"unknown key {loc[-1]!r}"
    if kind == "missing" and loc:
        return f"missing required key {loc[-1]!r}"
    if kind == "union_tag_not_found":  # a tagged union (``kind: angle``) without its tag
        return f"missing required key {_tag_key(error)!r}"
    if kind == "union_tag_invalid":  # the tags as text, not reprs (<SensorKind.IMU: 'imu'>)
        ctx = error.get("ctx") or {}
        tags = re.findall(r"'((?:[^'\\]|\\.)*)'", str(ctx.get("expected_tags", "")))
        return f"{_tag_key(error)}: {shown(ctx.get('tag'))} is not one of {', '.join(tags)}"
    for prefix in ("Value error, ", "Assertion failed, "):
        if msg.startswith(prefix):
            msg = msg[len(prefix) :]
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        # pydantic's own wording names classes ("instance of Motor"): say the shape.
        msg = f"should be {_SHAPES[kind]}"
    if kind in ("literal_error", "enum") or kind.endswith("_type") or kind.endswith("_parsing"):
        where = ".".join(str(p) for p in loc if not isinstance(p, int))
        if where:
            return f"{where.split('.')[-1]}: {msg}"
    return msg


def _tag_key(error: Any) -> str:
    """The key that tags the branches of a union (``kind``), from a tag error."""
    return str((error.get("ctx") or {}).get("discriminator", "kind")).strip("'\"")


_NO_DATA = object()


def _real_path(data: Any, loc: Sequence[str | int], kind: str) -> tuple[PathKey, bool, bool]:
    """``loc`` without pydantic's union-member tags; whether it had any; whether it ends on one.

    pydantic names the branch of a union it tried inside the location
    (``list[function-after[_check(), Comparison]]``). Walking the input data
    tells which elements are real keys and indices; the others are tags, except
    the last element of a missing or unknown key, which names the key.
    """
    if data is _NO_DATA:
        return tuple(loc), False, False
    path: list[str | int] = []
    tagged = ends_on_tag = False
    current = data
    for i, element in enumerate(loc):
        last = i == len(loc) - 1
        if (isinstance(current, Mapping) and element in current) or (
            isinstance(current, list)
            and isinstance(element, int)
            and not isinstance(element, bool)
            and 0 <= element < len(current)
        ):
            path.append(element)
            current = current[element]  # type: ignore[index]
        elif last and kind in ("missing", "extra_forbidden"):
            path.append(element)
        else:
            tagged = True
            ends_on_tag = last
    return tuple(path), tagged, ends_on_tag


def _value_at(data: Any, path: PathKey) -> Any:
    """The value at ``path`` in ``data``, or ``_NO_DATA``."""
    for element in path:
        try:
            data = data[element]
        except (KeyError, IndexError, TypeError):
            return _NO_DATA
    return data


def validation_problems(exc: ValidationError, data: Any = _NO_DATA) -> list[tuple[PathKey, str]]:
    """pydantic's errors as ``(path into data, message)``: one clear message per problem.

    Union branches that failed only because the value has another shape (the
    list branch of "a comparison or a list of comparisons" given a mapping) are
    dropped when another branch says what is wrong; when every branch failed on
    shape, one message says which shapes are allowed. Locations and messages
    never carry pydantic's internal names.

    Args:
        exc: The validation error.
        data: The input that was validated (to tell real keys from union tags);
            without it every location element is taken as a key.
    """
    entries = []
    for e in exc.errors():
        kind = str(e.get("type", ""))
        path, tagged, ends_on_tag = _real_path(data, e["loc"], kind)
        entries.append((path, tagged and ends_on_tag and kind in _SHAPES, tagged, e))
    # Paths where some union branch failed on something other than shape.
    substantive = [path for path, shape, tagged, _ in entries if tagged and not shape]
    shapes: dict[PathKey, list[str]] = {}
    for path, shape, _, e in entries:
        if shape:
            shapes.setdefault(path, []).append(_SHAPES[str(e["type"])])
    out: list[tuple[PathKey, str]] = []
    for path, shape, _, e in entries:
        if shape:
            if any(p[: len(path)] == path for p in substantive):
                continue  # another branch of the same union says what is wrong
            name = next((str(p) for p in reversed(path) if isinstance(p, str)), "value")
            out.append((path, f"{name}: should be {' or '.join(dict.fromkeys(shapes[path]))}"))
            continue
        if e["type"] == "union_tag_invalid":  # located at the tag's value, shown as written
            path = (*path, _tag_key(e))
            value = _value_at(data, path)
            if value is not _NO_DATA:
                e = {**e, "ctx": {**e["ctx"], "tag": value}}
        out.append((path, describe_error({**e, "loc": path})))
    return list(dict.fromkeys(out))


def pydantic_errors(
    exc: ValidationError, locator: Locator, data: Any = _NO_DATA
) -> list[LocatedError]:
    """Translate pydantic's errors into located ones, in file order.

    Args:
        exc: The validation error.
        locator: Where each path of the file was written.
        data: The validated input, to tell keys from pydantic's union tags.
    """
    errors = [locator.error(path, msg) for path, msg in validation_problems(exc, data)]
    errors.sort(key=lambda e: (e.location.line, e.location.column))
    return unique_errors(errors)


def unique_errors(errors: Iterable[LocatedError]) -> list[LocatedError]:
    """``errors`` without repeats (the same message at the same place), order kept."""
    seen: set[str] = set()
    out: list[LocatedError] = []
    for e in errors:
        if str(e) not in seen:
            seen.add(str(e))
            out.append(e)
    return out


def validate_document(
    doc: YamlDocument, model: type[ModelT], what: str, context: dict[str, Any]
) -> ModelT:
    """Validate a loaded YAML document as ``model``, every problem at its place.

    The shape and each field come from pydantic; then, when the model has a
    ``cross_check()`` returning ``(path, message)`` pairs (rules that span the
    file), those are located too; a triple ``(path, message, first_path)`` (a
    duplicate) adds ``(first at FILE:LINE:COLUMN)``. The model should defer its
    own cross-check raising when ``context`` says ``defer_cross_checks``.

    Args:
        doc: The loaded document.
        model: The pydantic model of the file kind.
        what: What people call the file kind ("a pipe network").
        context: The pydantic validation context (``units_required`` for files).

    Raises:
        ValidationFailed: every problem, in file order.
    """
    if not isinstance(doc.data, dict):
        raise ValidationFailed([doc.locator.error((), f"{what} must be a mapping of keys")])
    try:
        value = model.model_validate(doc.data, context=context)
    except ValidationError as exc:
        raise ValidationFailed(pydantic_errors(exc, doc.locator, doc.data)) from None
    cross_check = getattr(value, "cross_check", None)
    problems: list[tuple[Any, ...]] = cross_check() if callable(cross_check) else []
    if problems:
        raise ValidationFailed(
            sorted(
                (_cross_error(doc.locator, *problem) for problem in problems),
                key=lambda e: (e.location.line, e.location.column),
            )
        )
    return value


def _cross_error(
    locator: Locator, path: PathKey, message: str, first: PathKey | None = None
) -> LocatedError:
    """A cross-check's problem at ``path``; a duplicate names its ``first`` place too."""
    if first is not None:
        message = f"{message} (first at {locator.locate(first)})"
    return locator.error(path, message)
