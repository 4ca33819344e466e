"""Node names: what a name may be, siblings' names made unique, names in messages.

Used by the tree reader (:mod:`pirate_bt.treefile.reader`) for every node it reads.
"""

from __future__ import annotations

import unicodedata
from typing import Any

from pirate_bt.errors import LocatedError
from pirate_bt.treefile.spec import NodeSpec, PathKey
from pirate_bt.yamlfile.alike import alike_among, alike_note, odd_character, skeleton
from pirate_bt.yamlvalidate import close_matches, key_not_text

__all__ = [
    "alike_among",
    "alike_note",
    "dedupe",
    "name_problem",
    "node_label",
    "non_text_keys",
    "odd_character",
    "printable",
    "shown_name",
    "skeleton",
    "unknown_key",
]


def shown_name(text: str) -> str:
    """``text`` quoted for a message, cut short when it is long (a hostile file's)."""
    return repr(text) if len(text) <= 60 else repr(text[:57] + "...")


def printable(text: str) -> str:
    """``text`` for a one-line message: a character a terminal acts on or does not show
    (a control character such as ESC or CR, a line break, U+202E) written as its escape
    (``\\x1b``, ``\\r``, ``\\u202e``). A subtree's name or a file's path shown as written (a
    recursion's chain) could clear the screen or rewrite the line. Text without them is
    returned as it is."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def name_problem(name: object) -> str | None:
    """What is wrong with a node's (or a tree's) name, if anything."""
    if not (isinstance(name, str) and name.strip()):
        return "name: must be non-empty text"
    if "/" in name:
        return "name: must not contain '/' (used in node paths)"
    # each character asked about once: a hostile file's name may have millions
    distinct = set(name)
    if any(unicodedata.category(c) in ("Cc", "Cs") for c in distinct):
        return "name: must not contain control characters"
    if name != name.strip():  # 'grip' and 'grip ' are shown alike
        return "name: must not begin or end with a space (two names would look alike)"
    odd = _first(name, {c for c in distinct if unicodedata.category(c) in _SPACES} - {" "})
    if odd is not None:  # a no-break space looks like a space; U+2028 breaks the line
        return (
            f"name: must not contain U+{ord(odd):04X} {unicodedata.name(odd, '')}"
            " (a space other than ' ', or a line break: two names would look alike)"
        )
    hidden = _first(name, distinct & _INVISIBLE)
    if hidden is not None:  # 'grip' and 'grip\u200b' would be two names shown alike
        return (
            f"name: must not contain U+{ord(hidden):04X} {unicodedata.name(hidden, '')}"
            " (an invisible or text-direction character: two names would look alike)"
        )
    return None


def _first(text: str, found: set[str]) -> str | None:
    """Which of ``found`` (characters of ``text``) comes first in ``text``."""
    return min(found, key=text.index) if found else None


_SPACES = frozenset({"Zs", "Zl", "Zp"})
"""Unicode's spaces and line and paragraph separators: in a name, only U+0020."""

_INVISIBLE = frozenset(
    "\u00ad\u061c\u180e\u200b\u200e\u200f\u202a\u202b\u202c\u202d\u202e"
    "\u2060\u2061\u2062\u2063\u2064\u2066\u2067\u2068\u2069\ufeff"
)
"""Format characters a name may not hold: zero-width, soft hyphen and the bidirectional
controls (a name with U+202E shows its text reversed). Joiners (U+200C, U+200D) stay:
emoji sequences and some scripts need them."""


def unknown_key(key: object, allowed: frozenset[str] | set[str]) -> str:
    """A key a node (or a tree) does not take, with the nearest one or those allowed; a
    key that is not text (a mapping's from Python) is said to be so (``key 5 must be
    text; allowed: children, memory``)."""
    if not isinstance(key, str):
        return f"{key_not_text(key)}; allowed: {', '.join(sorted(allowed))}"
    close = close_matches(str(key), sorted(allowed), n=1)
    hint = (
        f"; did you mean {close[0]!r}?{alike_note(key, close[0])}"
        if close
        else f"; allowed: {', '.join(sorted(allowed))}"
    )
    return f"unknown key {shown_name(key)}{hint}"


def node_label(kind: str, name: object, path: PathKey, in_mapping: bool) -> str:
    """A node as a message names it: its type and name (``wait 'w'``); an unnamed node of
    a tree given as a mapping, whose problems are all at the planner's one line, by its
    place in the mapping as well (``wait at root.children[0]``); else by its type (the
    file's line and column say which)."""
    if isinstance(name, str) and name_problem(name) is None:
        return f"{kind} {shown_name(name)}"
    if not in_mapping:
        return kind
    place = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")
    return f"{kind} at {place}" if place else kind


def non_text_keys(value: Any, path: PathKey = ()) -> tuple[Any, list[tuple[PathKey, object]]]:
    """``value`` without the keys that are not text, at any depth (only a mapping given
    from Python has them), and the path and key of each one left out."""
    found: list[tuple[PathKey, object]] = []
    if isinstance(value, dict):
        kept: dict[Any, Any] = {}
        for key, item in value.items():
            if not isinstance(key, str):
                found.append((path, key))
                continue
            kept[key], inner = non_text_keys(item, (*path, key))
            found += inner
        return kept, found
    if isinstance(value, list):
        items = []
        for i, item in enumerate(value):
            clean, inner = non_text_keys(item, (*path, i))
            items.append(clean)
            found += inner
        return items, found
    return value, found


def dedupe(children: list[NodeSpec], errors: list[LocatedError]) -> None:
    """Sibling names must be unique (node paths name nodes); number unnamed duplicates."""
    explicit: dict[str, NodeSpec] = {}
    for child in children:
        if child.explicit_name:
            first = explicit.get(skeleton(child.name))
            if first is not None:  # a subtree's root: the mistake is the call's
                errors.append(
                    LocatedError(
                        f"duplicate node name {shown_name(child.name)} among siblings"
                        f" (first at {first.called_at or first.location})"
                        f"{_how_alike(first.name, child.name)}",
                        child.called_at or child.location,
                    )
                )
            explicit.setdefault(skeleton(child.name), child)  # "first at": the first
    used = {child.name for child in explicit.values()}
    counts: dict[str, int] = {}
    for child in children:
        if child.explicit_name:
            continue
        base = child.name
        n = counts.get(base, 0)
        name = base
        while name in used:
            n += 1
            name = f"{base} {n + 1 if n else ''}".strip() if n else base
        counts[base] = n
        child.name = name
        used.add(name)


_JOINERS = str.maketrans("", "", "\u200c\u200d")


def _alike(name: str) -> str:
    """``name`` as it is shown: 'café' composed (U+00E9) and decomposed (e + U+0301)
    alike, and without the zero-width joiners a name may hold (``grip`` + U+200D is
    shown as ``grip``)."""
    return unicodedata.normalize("NFC", name).translate(_JOINERS)


def _how_alike(first: str, second: str) -> str:
    """Why two names that are not the same text are a duplicate, if they are not."""
    if first == second:
        return ""
    if unicodedata.normalize("NFC", first) == unicodedata.normalize("NFC", second):
        return " (the same text, in another Unicode form)"
    if _alike(first) == _alike(second):
        return " (the same text but for a zero-width joiner, U+200C or U+200D)"
    return f" (shown alike: {odd_character(first, second)})"
