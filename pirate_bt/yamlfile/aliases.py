"""Where each ``*alias`` is used, so that an error in an aliased value names that place.

YAML composes an alias as the very node its anchor names: the node graph keeps
only the anchor's marks. A tree file that writes a node once (``- &grab {type:
clamp, ...}``) and uses it again (``- *grab``) then had every problem of the second
use placed in the first (``duplicate node name 'grab' among siblings`` at the line
it is first written, twice). :func:`use_alias_places` reads the file's events again
(only when its text may hold an alias), finds the path of every alias in the data,
and places that path, and everything under it, where the alias is written.

A merge key's alias (``<<: *defaults``) is left as it is: a merged value is placed
in the anchor that writes it (:meth:`pirate_bt.yamlfile.Locator.locate`).
"""

from __future__ import annotations

import re
from typing import Any

import yaml

__all__ = ["alias_places", "use_alias_places"]

PathKey = tuple[Any, ...]

# an alias starts a node: after a space, a flow indicator or the start of a line
# (a unit such as "N*m" is no alias); a text that merely looks like one costs a parse
_MAY_HOLD_ALIAS = re.compile(r"(?:^|[\s\[{,])\*[^\s,\[\]{}]")
_MERGE = "<<"


def alias_places(text: str, loader: type[Any]) -> dict[PathKey, tuple[int, int, bool]]:
    """Every alias's path in the data, with its ``(line, column)`` (from 1) and whether
    the path itself is placed there: a list item is; a mapping's value is placed at
    its key, written where the alias is used, and keeps that place.

    Args:
        text: The YAML text (already composed once without error).
        loader: The loader class that composed it (its marks count as the node's do).
    """
    if _MAY_HOLD_ALIAS.search(text) is None:
        return {}
    places: dict[PathKey, tuple[int, int, bool]] = {}
    # each open collection: [path or None (a key that is no scalar), index or key, at key]
    frames: list[list[Any]] = []
    for event in yaml.parse(text, Loader=loader):
        if isinstance(event, yaml.CollectionEndEvent):
            frames.pop()
            continue
        if not isinstance(event, yaml.NodeEvent):
            continue  # stream and document starts and ends
        path: PathKey | None = ()
        in_list = False
        if frames:
            frame = frames[-1]
            parent: PathKey | None = frame[0]
            if frame[2] is None:  # a list: the next index
                in_list = True
                path = None if parent is None else (*parent, frame[1])
                frame[1] += 1
            elif frame[2]:  # a mapping's key: its text names the value after it
                frame[1] = event.value if isinstance(event, yaml.ScalarEvent) else None
                frame[2] = False
                path = None
            else:  # a mapping's value
                key = frame[1]
                path = None if parent is None or key is None else (*parent, key)
                frame[2] = True
        if isinstance(event, yaml.AliasEvent):
            mark = event.start_mark
            if path is not None and _MERGE not in path and mark is not None:
                places[path] = (mark.line + 1, mark.column + 1, in_list)
        elif isinstance(event, yaml.SequenceStartEvent):
            frames.append([path, 0, None])
        elif isinstance(event, yaml.MappingStartEvent):
            frames.append([path, None, True])
    return places


_KEPT: dict[tuple[str, int], dict[PathKey, tuple[int, int, bool]]] = {}
_MOST_KEPT = 16
_LARGEST_KEPT = 256 * 1024  # characters: a file people write; at most 4 MiB kept


def _alias_places(text: str, loader: type[Any]) -> dict[PathKey, tuple[int, int, bool]]:
    """:func:`alias_places`, kept for the texts read again and again (a robot
    description with anchors is loaded by every tree's validation); read only."""
    if len(text) > _LARGEST_KEPT:
        return alias_places(text, loader)
    key = (text, id(loader))
    places = _KEPT.get(key)
    if places is None:
        places = alias_places(text, loader)
        if len(_KEPT) >= _MOST_KEPT:
            _KEPT.clear()
        _KEPT[key] = places
    return places


def use_alias_places(text: str, loader: type[Any], marks: dict[PathKey, tuple[int, int]]) -> None:
    """Place every path at or under an alias (``marks``, a :class:`Locator`'s) where
    the alias is written; under nested aliases, the outermost."""
    places = _alias_places(text, loader)
    if not places:
        return
    for path in marks:
        for end in range(len(path) + 1):
            place = places.get(path[:end])
            if place is not None:
                if end < len(path) or place[2]:
                    marks[path] = place[:2]
                break
