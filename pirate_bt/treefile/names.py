"""Node names: what a name may be, siblings' names made unique, names in messages.

Used by the tree reader (:mod:`pirate_bt.treefile.reader`) for every node it reads.
"""

from __future__ import annotations

import unicodedata

from pirate_bt.errors import LocatedError
from pirate_bt.treefile.spec import NodeSpec

__all__ = ["dedupe", "name_problem", "shown_name", "unknown_key"]


def shown_name(text: str) -> str:
    """``text`` quoted for a message, cut short when it is long (a hostile file's)."""
    return repr(text) if len(text) <= 60 else repr(text[:57] + "...")


def name_problem(name: object) -> str | None:
    """What is wrong with a node's (or a tree's) name, if anything."""
    if not (isinstance(name, str) and name.strip()):
        return "name: must be non-empty text"
    if "/" in name:
        return "name: must not contain '/' (used in node paths)"
    if any(unicodedata.category(c) in ("Cc", "Cs") for c in name):
        return "name: must not contain control characters"
    return None


def unknown_key(key: object, allowed: frozenset[str] | set[str]) -> str:
    import difflib

    close = difflib.get_close_matches(str(key), sorted(allowed), n=1)
    hint = f"; did you mean {close[0]!r}?" if close else f"; allowed: {', '.join(sorted(allowed))}"
    return f"unknown key {shown_name(key) if isinstance(key, str) else repr(key)}{hint}"


def dedupe(children: list[NodeSpec], errors: list[LocatedError]) -> None:
    """Sibling names must be unique (node paths name nodes); number unnamed duplicates."""
    explicit: dict[str, NodeSpec] = {}
    for child in children:
        if child.explicit_name:
            first = explicit.get(child.name)
            if first is not None:  # a subtree's root: the mistake is the call's
                errors.append(
                    LocatedError(
                        f"duplicate node name {shown_name(child.name)} among siblings"
                        f" (first at {first.called_at or first.location})",
                        child.called_at or child.location,
                    )
                )
            explicit[child.name] = child
    used = set(explicit)
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
