"""Load YAML files so that every later error can point at ``file:line:column``.

Parsing text and validating data are separate steps (as pydantic-over-YAML
projects do it): :func:`load_yaml` turns a file into plain Python data plus a
:class:`Locator` that maps a path inside that data (``("boards", 3, "id")``) back
to where it was written. Validators then raise with a path, and
:mod:`pirate_bt.yamlvalidate` translates pydantic's error locations into
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
whole number too long for Python to read are refused at their line too, and so are
values that are no JSON value (``!!binary``, ``!!set``, ``!!omap``, ``!!pairs``). Where
YAML 1.1 reads a plain value other than as YAML 1.2 (and an editor) reads it, a bare
date (``2001-12-14``) and a base-60 number (``1:30``, 90 in YAML 1.1) are the text
written, a number with an exponent (``1e3``: text in YAML 1.1) is the number, and a whole
number with a leading zero (``010``, octal 8) is refused.
"""

from __future__ import annotations

import re
import stat
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO, Final

import yaml

from pirate_bt.errors import LocatedError, SourceLocation, ValidationFailed, shown
from pirate_bt.yamlfile.aliases import use_alias_places
from pirate_bt.yamlfile.count import refuse_too_many_values
from pirate_bt.yamlfile.merge import SpecMergeLoader
from pirate_bt.yamlfile.scalars import (
    BOOL_TAG,
    INT_TAG,
    NOT_JSON,
    STR_TAG,
    TEXT_KEYS,
    VALUE_WORDS,
    node_mark,
    not_json,
    plain_reads_as_number,
    unfit,
    yaml11_number,
)

__all__ = [
    "HIDDEN_BREAK",
    "VALUE_WORDS",
    "Locator",
    "YamlDocument",
    "check_depth",
    "data_document",
    "decode_text",
    "load_yaml",
    "load_yaml_text",
    "plain_reads_as_number",
    "read_at_most",
    "refuse_hidden_break",
]

PathKey = tuple[str | int, ...]

MAX_NODES = 100_000
"""The most values (scalars, lists, mappings) a file may expand to, aliases included.

The largest bundled file expands to a few thousand; a real file that needs more
is not one a person writes."""
MAX_BYTES = 16 * 1024 * 1024
"""The largest file read (a device such as ``/dev/zero`` never ends: it is cut there)."""


def special_kind(mode: int) -> str | None:
    """What a file of ``mode`` is when it may not be read as an input file; ``None``
    when it may: a regular file, a directory (refused as such by its reader) or a
    character device (``/dev/zero`` is read up to the size limit). A named pipe nobody
    writes to would be waited on for ever when opened."""
    if stat.S_ISFIFO(mode):
        return "a named pipe"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISBLK(mode):
        return "a block device"
    return None


def special_file(path: Path) -> str | None:
    """:func:`special_kind` of the file at ``path`` (``None`` when it cannot be read:
    its reader says why when it opens it)."""
    try:
        return special_kind(path.stat().st_mode)
    except (OSError, ValueError):
        return None


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


_HIDDEN_BREAKS = {
    "\x0b": ("a vertical tab", "\\v"),
    "\x0c": ("a form feed", "\\f"),
    "\x1c": ("a file separator", "\\x1C"),
    "\x1d": ("a group separator", "\\x1D"),
    "\x1e": ("a record separator", "\\x1E"),
    "\x85": ("a next-line character", "\\N"),
    "\u2028": ("a line separator", "\\L"),
    "\u2029": ("a paragraph separator", "\\P"),
}
"""Characters a reader takes for a line break and an editor does not show as one (and
how double-quoted YAML text writes each): YAML 1.1 (libyaml) breaks lines at the last
three, Python's ``str.splitlines`` (a route) at all. Text after one in a comment would be
read as a line of its own, and every place after it would be a line off."""
HIDDEN_BREAK = re.compile("[" + "".join(_HIDDEN_BREAKS) + "]")
_LINE_BREAK = re.compile(r"\r\n|\r|\n")


def refuse_hidden_break(text: str, name: str, what: str) -> None:
    """Refuse the first character of :data:`_HIDDEN_BREAKS` in ``text`` (a ``what``
    file), at its line and column as an editor shows them (lines end at LF, CR LF, CR)."""
    match = HIDDEN_BREAK.search(text)
    if match is None:
        return
    before = text[: match.start()]
    breaks = list(_LINE_BREAK.finditer(before))
    column = len(before) - (breaks[-1].end() if breaks else 0) + 1
    label, escape = _HIDDEN_BREAKS[match.group()]
    hint = f"; in double-quoted text write {escape}" if what == "YAML" else ""
    message = (
        f"U+{ord(match.group()):04X} ({label}) is not allowed in {what} text: a reader takes"
        f" it for a line break, an editor does not{hint}"
    )
    raise ValidationFailed([LocatedError(message, SourceLocation(name, len(breaks) + 1, column))])


_BOOLS: Final = ("true", "false")
_Loader: type[yaml.SafeLoader] = SpecMergeLoader  # libyaml's when there; merges as YAML does


@dataclass
class Locator:
    """Maps a path into the loaded data to its place in the file."""

    file: str
    marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    yes_no: dict[PathKey, str] = field(default_factory=dict)
    """Each value YAML 1.1 read as a boolean though written otherwise (``no``, ``on``)."""

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
                        SourceLocation(file, *node_mark(node)),
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
            raise ValidationFailed([LocatedError(message, SourceLocation(file, *node_mark(node)))])
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
                    SourceLocation(locator.file, *node_mark(node)),
                )
            )
            return
        if node.tag in NOT_JSON:
            errors.append(not_json(node, locator.file))
            continue
        if isinstance(node, yaml.ScalarNode):
            problem = yaml11_number(node, locator.file)
            if problem is not None:
                errors.append(problem)
                continue
            limit = sys.get_int_max_str_digits()
            if node.tag == INT_TAG and limit and len(node.value) > limit:
                errors.append(
                    LocatedError(
                        f"a number of {len(node.value)} digits is too long",
                        SourceLocation(locator.file, *node_mark(node)),
                    )
                )
                continue
            problem = unfit(node, locator.file)
            if problem is not None:
                errors.append(problem)
            elif node.tag == BOOL_TAG and not node.style and node.value.lower() not in _BOOLS:
                locator.yes_no[path] = node.value
            continue
        items: list[tuple[PathKey, yaml.Node]] = []
        if isinstance(node, yaml.MappingNode):
            seen: dict[Any, yaml.Node] = {}
            for i, (key_node, value_node) in enumerate(node.value):
                problem = yaml11_number(key_node, locator.file)
                if problem is not None:
                    errors.append(problem)
                    continue
                if isinstance(key_node, yaml.ScalarNode) and key_node.tag in TEXT_KEYS:
                    # YAML 1.1 reads a bare key ``on``, ``off``, ``yes``, ``no``, ``y``,
                    # ``n`` as a boolean, ``1`` as a number, ``~`` as null: a key is its
                    # text (a value keeps its meaning; ``!!int abc:`` is the key 'abc').
                    # A new node: an anchored key may also be used as a value.
                    key_node = yaml.ScalarNode(
                        STR_TAG, key_node.value, key_node.start_mark, key_node.end_mark
                    )
                    node.value[i] = (key_node, value_node)
                if key_node.tag in NOT_JSON:
                    errors.append(not_json(key_node, locator.file))
                    continue
                if not isinstance(key_node, yaml.ScalarNode):
                    shape = "mapping" if isinstance(key_node, yaml.MappingNode) else "list"
                    errors.append(
                        LocatedError(
                            f"a key must be a plain value, not a {shape}",
                            SourceLocation(locator.file, *node_mark(key_node)),
                        )
                    )
                    continue
                key = key_node.value
                if key in seen:
                    first = seen[key].start_mark.line + 1
                    errors.append(
                        LocatedError(
                            f"duplicate key {shown(key)} (first written on line {first})",
                            SourceLocation(locator.file, *node_mark(key_node)),
                        )
                    )
                seen.setdefault(key, key_node)  # a third is told the first line too
                locator.marks[(*path, key)] = node_mark(key_node)
                items.append(((*path, key), value_node))
        elif isinstance(node, yaml.SequenceNode):
            for index, item in enumerate(node.value):
                locator.marks[(*path, index)] = node_mark(item)
                items.append(((*path, index), item))
        stack.extend((child, at) for at, child in reversed(items))


def data_document(data: object, name: object) -> YamlDocument:
    """Plain data given from Python (as a file would load), as a document named
    ``name`` (its problems placed at ``name:1:1``).

    Raises:
        ArgumentTypeError: ``data`` is no mapping (``None`` raised *'NoneType' object
            is not iterable*) or ``name`` no text.
    """
    from pirate_bt.errors import ArgumentTypeError, kind_of

    if not isinstance(data, Mapping):
        raise ArgumentTypeError(f"data: give a mapping of the file's keys, not {kind_of(data)}")
    if not isinstance(name, str):
        raise ArgumentTypeError(f"name: give text (the name messages show), not {kind_of(name)}")
    return YamlDocument(dict(data), Locator(name))


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
    refuse_hidden_break(text, file, "YAML")
    refuse_too_many_values(text, _Loader, file)  # before 1 kB a value is composed
    # libyaml's parser (when PyYAML was built with it) is ~10x faster and keeps marks.
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise ValidationFailed([LocatedError("file holds no YAML document", loc)])
        _check_expansion(node, file)
        # Walk before constructing: construction flattens merge keys (<<) in place.
        locator.marks[()] = node_mark(node)
        errors: list[LocatedError] = []
        _walk(node, locator, errors)
        if errors:  # once each: a value an alias repeats was met once per use
            raise ValidationFailed(list({str(e): e for e in errors}.values()))
        use_alias_places(text, _Loader, locator.marks)  # a '*alias' placed where it is used
        data = loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = _place(file, text, mark.line, mark.column) if mark is not None else loc
        problem = exc.problem or exc.context or "invalid YAML"
        said = _unknown_tag(problem) or f"YAML syntax error: {problem}"
        if problem.startswith("expected a mapping") and "for merging" in problem:
            # well-formed YAML whose merge key (<<) names no mapping: not its syntax
            said = f"merge key (<<): {problem.replace('for merging, but', 'to merge, but')}"
        elif problem == "exceeded maximum nesting depth":  # libyaml's bound (1000), not syntax
            said = f"values nested deeper than {MAX_DEPTH} levels"
        elif problem == "second occurrence" and exc.context_mark is not None:  # &a twice
            earlier = _place(file, text, exc.context_mark.line, exc.context_mark.column)
            said = f"YAML anchor defined twice (first at line {earlier.line}); name each its own"
        elif problem == "but found another document":  # a stream of two: valid YAML
            said = "a second YAML document (after '---'): a file holds one"
        elif problem == "found character that cannot start any token":  # libyaml: which?
            lines = text.removeprefix("\ufeff").splitlines()
            row = lines[where.line - 1] if 0 < (where.line or 0) <= len(lines) else ""
            char = row[where.column - 1 : where.column] if where.column else ""
            said = f"YAML syntax error: {_TOKEN_START.get(char, f'{char!r} cannot start a value')}"
        raise ValidationFailed([LocatedError(said, where)]) from None
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


_NO_CONSTRUCTOR: Final = "could not determine a constructor for the tag "


def _unknown_tag(problem: str) -> str | None:
    """A tag no value here has (``!include``, ``!!python/object:os.system``) in words that
    say so; it was "YAML syntax error: could not determine a constructor for the tag",
    though the file's syntax is fine. None for any other problem."""
    if not problem.startswith(_NO_CONSTRUCTOR):
        return None
    tag = problem[len(_NO_CONSTRUCTOR) :].strip("'")
    tag = "!!" + tag[len("tag:yaml.org,2002:") :] if tag.startswith("tag:yaml.org,2002:") else tag
    return (
        f"YAML tag {shown(tag)} is not known here: a value is text, a number, a boolean, a"
        " list or a mapping, with no tag but YAML's own (!!str, !!int, !!float, !!bool)"
    )


_TOKEN_START = {"\t": "a tab, where YAML indents with spaces", "": "a character cannot start here"}
"""What libyaml's *found character that cannot start any token* found, in words."""


def _place(file: str, text: str, line: int, column: int) -> SourceLocation:
    """A parser's mark as a location; a mark past the last line (the end of a file that
    ends without a newline, as libyaml reports it) is the end of that last line."""
    lines = text.splitlines() or [""]
    if line >= len(lines):
        line, column = len(lines) - 1, len(lines[-1])
    return SourceLocation(file, line + 1, column + 1)


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
    kind = special_file(p)
    if kind is not None:
        raise ValidationFailed([LocatedError(f"is {kind}, not a file to read", loc)])
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
            1:1; a byte that is not UTF-8, at its line and column (in characters). A
            line break an editor does not show is the text's readers' to refuse
            (:func:`load_yaml_text`, ``parse_route``: :func:`refuse_hidden_break`).
    """
    loc = SourceLocation(name)
    if raw.startswith((b"\xff\xfe", b"\xfe\xff", b"\x00\x00\xfe\xff")):  # byte-order marks
        bits = 32 if raw.startswith((b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")) else 16
        raise ValidationFailed([LocatedError(f"UTF-{bits} text; save the file as UTF-8", loc)])
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
