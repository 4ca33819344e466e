"""A tree file with a value YAML refuses where it is written: the rest still checked.

:func:`~pirate_bt.yamlfile.load_yaml` refuses a whole number written with a leading
zero (``attempts: 010``: YAML 1.1 reads it as the octal 8, YAML 1.2 and editors as
10) and returns no document. For a tree file that one refusal would hide every other
problem of the file, so :func:`read_tree_yaml` reads the file again with each such
number blanked out: a run of one private-use character in its place (the same length,
so every other value keeps its line and column; another character for each number, so
that two keys stay two). The reader treats a blanked value as unknown: it
reports nothing about it (the refusal said what is wrong) and skips every check that
depends on it (the node it is in, a parameter declared with it as its default).

Only that refusal is recovered from: any other problem of the YAML (a syntax error,
a key written twice, a value that is no JSON value) raises as ``load_yaml`` does.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from pirate_bt.errors import LocatedError, ValidationFailed
from pirate_bt.yamlfile import (
    MAX_BYTES,
    YamlDocument,
    decode_text,
    load_yaml,
    load_yaml_text,
    read_at_most,
)

__all__ = ["holds_blank", "read_tree_yaml", "shows_blank"]

_FIRST, _LAST = 0xE000, 0xF8FF
"""The private-use characters, which YAML allows in a plain value, that blank refused
values out; a file that holds one is not recovered (its own would be taken for one)."""
_BLANK = re.compile(f"[{chr(_FIRST)}-{chr(_LAST)}]")
_SHOWN = re.compile(_BLANK.pattern + r"|\\u(e[0-9a-f]{3}|f[0-8][0-9a-f]{2})")
"""A blank in a message: as it is, or as ``repr`` writes it (a backslash, ``ue000``)."""

_LEADING_ZERO = "has a leading zero, which YAML 1.1 reads as an octal number"
"""The refusal recovered from (:func:`pirate_bt.yamlfile.load_yaml`'s words)."""
_NUMBER = re.compile(r"[-+]?0[0-7_]+")
"""Such a number as written (as ``load_yaml`` matches it)."""
_ENDS = frozenset([*" \t,]}:#", ""])
"""What may follow a plain number on its line ("": the line ends there)."""
_BREAK = re.compile("(\r\n|\r|\n|\x85|\u2028|\u2029)")
"""YAML 1.1's line breaks, as the parser counts lines."""


def read_tree_yaml(path: Path) -> tuple[YamlDocument, list[LocatedError]]:
    """The YAML file at ``path``, and the values it refused where they were written.

    Raises:
        ValidationFailed: as :func:`~pirate_bt.yamlfile.load_yaml`, unless every
            problem is a number written with a leading zero: then the document is
            returned with each blanked out, and those problems.
    """
    try:
        return load_yaml(path), []
    except ValidationFailed as exc:
        refused = list(exc.errors)
        doc = _blanked(path, refused)
        if doc is None:
            raise
        return doc, refused


def _blanked(path: Path, refused: list[LocatedError]) -> YamlDocument | None:
    """The file at ``path`` with each number of ``refused`` blanked out; None when a
    problem is of another kind or the file is not as it was when it was refused."""
    name = str(path)
    if not all(_LEADING_ZERO in e.message and e.location.file == name for e in refused):
        return None
    try:
        if not path.is_file():  # read once only: a device or pipe gives other text
            return None
        with path.open("rb") as stream:
            raw = read_at_most(stream, MAX_BYTES)
        text = decode_text(raw, name, "YAML")
    except (OSError, ValueError, ValidationFailed):
        return None
    if len(raw) > MAX_BYTES or _BLANK.search(text):
        return None
    parts = _BREAK.split(text)  # lines at the even places, their breaks between
    for number, e in enumerate(refused):
        blank = chr(_FIRST + number % (_LAST - _FIRST + 1))
        index, start = 2 * (e.location.line - 1), e.location.column - 1
        line = parts[index] if 0 <= index < len(parts) else ""
        match = _NUMBER.match(line, start)
        if match is None or line[match.end() : match.end() + 1] not in _ENDS:
            return None
        parts[index] = line[:start] + blank * (match.end() - start) + line[match.end() :]
    try:
        return load_yaml_text("".join(parts), name)
    except ValidationFailed:
        return None


def holds_blank(value: Any) -> bool:
    """Whether ``value`` is, or holds (as a key or a value, at any depth), a blanked
    value of :func:`read_tree_yaml`."""
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            if item and _BLANK.match(item) and item == item[0] * len(item):
                return True
        elif isinstance(item, dict):
            stack.extend(item)
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)
    return False


def shows_blank(message: str) -> bool:
    """Whether a message quotes a blanked value (as it is or as ``repr`` writes it):
    a check that depended on it, which should have been skipped."""
    return _SHOWN.search(message) is not None
