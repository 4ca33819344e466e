"""Names that look alike though they are other text: a name's *skeleton*, the text it
shows as (after Unicode's confusables, UTS #39, for the scripts whose letters are drawn
as Latin ones), and which character tells two such names apart, for messages.

Used by the tree loader (sibling and subtree names, its *did you mean*), the BT.CPP XML
import and :mod:`pirate_bt.yamlvalidate` (a misspelt key's *did you mean*).
"""

from __future__ import annotations

import functools
import unicodedata
from typing import Final

__all__ = ["alike_among", "alike_note", "odd_character", "skeleton"]

_SPACES: Final = frozenset({"Zs", "Zl", "Zp"})
"""Unicode's spaces and line and paragraph separators: each shown as a space."""

_LOOK_ALIKES = str.maketrans(
    # Cyrillic, Greek and Armenian letters drawn as a Latin one (after Unicode's
    # confusables.txt, UTS #39), and the dotless i
    "аеорсухѕіјԁԛԝһӏАВЕКМНОРСТХУЅІЈӀԚԜΑΒΕΖΗΙΚΜΝΟΡΤΥΧονιργօսհոı",
    "aeopcyxsijdqwhlABEKMHOPCTXYSIJlQWABEZHIKMNOPTYXovipyouhni",
)


def skeleton(name: str) -> str:
    """``name`` as it is seen: compatibility forms folded (NFKC: a full-width 'ｇ' is 'g'),
    invisible characters dropped (format characters: zero-width spaces and joiners, the
    soft hyphen, bidirectional controls; variation selectors), every space a ' ', and
    each Cyrillic, Greek or Armenian letter drawn as a Latin one read as that one. Two
    names of one skeleton look alike on a screen, in a trace and in a diagram."""
    folded = unicodedata.normalize("NFKC", name)
    shown = {ord(c): _seen(c) for c in set(folded)}  # each distinct character asked once
    return unicodedata.normalize("NFC", folded.translate(shown).translate(_LOOK_ALIKES))


def _seen(c: str) -> str:
    """What a character shows as: nothing for an invisible one, ' ' for a space."""
    category = unicodedata.category(c)
    if category == "Cf" or "\ufe00" <= c <= "\ufe0f" or c == "\u034f":
        return ""
    return " " if category in _SPACES else c


def odd_character(first: str, second: str) -> str:
    """The first character by which ``second`` differs from ``first`` although the two
    look alike, named: ``'у' is U+0443 CYRILLIC SMALL LETTER U``."""
    if unicodedata.normalize("NFC", first) == unicodedata.normalize("NFC", second):
        return "the same text in another Unicode form (an accent composed or not)"
    for text, other in ((second, set(first)), (first, set(second))):
        odd = next((c for c in text if c not in other), None)
        if odd is not None:
            return f"{odd!r} is U+{ord(odd):04X} {unicodedata.name(odd, 'a character')}"
    return "the same characters in another order"  # not reached for names of one skeleton


def alike_note(name: str, suggestion: str) -> str:
    """For a *did you mean* whose suggestion looks just like the name given (a node type
    'wаit', Cyrillic а, and 'wait'): what differs, `` ('а' is U+0430 ...)``; else ''."""
    if name == suggestion or skeleton(name) != skeleton(suggestion):
        return ""
    return f" ({odd_character(suggestion, name)})"


def alike_among(name: str, known: list[str]) -> str:
    """For a name refused as unknown beside the ``known`` ones: the known name it looks
    just like, `` ('spеed' looks like 'speed': 'е' is U+0435 ...)``; else ''. The first
    1,000 known names are compared, their skeletons made once for every name refused
    beside them (a hostile file may refuse thousands beside thousands)."""
    other = _by_skeleton(tuple(known[:1000])).get(skeleton(name))
    if other is None or other == name:
        return ""
    return f" ({name!r} looks like {other!r}: {odd_character(other, name)})"


@functools.lru_cache(maxsize=8)
def _by_skeleton(known: tuple[str, ...]) -> dict[str, str]:
    """Each skeleton of ``known`` -> the first name of it."""
    out: dict[str, str] = {}
    for other in known:
        out.setdefault(skeleton(other), other)
    return out
