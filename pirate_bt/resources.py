"""Where the bundled data lives: robot descriptions, trees and scenarios.

In a wheel the data is packaged under ``pirate_bt/_data/``; in a source checkout
(editable install) it is the repository's ``hardware/``, ``trees/`` and
``scenarios/`` folders. Both are found the same way, so an installed library
works outside the repository.
"""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "DATA_KINDS",
    "bundled",
    "bundled_names",
    "data_dir",
    "default_robot_path",
    "exists",
    "find_file",
    "missing",
]

DATA_KINDS = ("hardware", "trees", "scenarios")
_PACKAGE = Path(__file__).resolve().parent


def data_dir(kind: str) -> Path:
    """The folder of bundled files of ``kind`` (``hardware``, ``trees`` or ``scenarios``)."""
    if kind not in DATA_KINDS:
        raise ValueError(f"unknown data kind {kind!r}; expected one of {DATA_KINDS}")
    packaged = _PACKAGE / "_data" / kind
    if packaged.is_dir():
        return packaged
    return _PACKAGE.parent / kind


def exists(path: Path) -> bool:
    """``path.exists()``, False for a name the system refuses (a part over 255 bytes
    raises ``OSError: File name too long`` from ``Path.exists`` on Python 3.11): the
    caller's "no such file" then names what was typed."""
    try:
        return path.exists()
    except (OSError, ValueError):  # ValueError: a NUL in the name
        return False


def missing(path: Path) -> bool:
    """Whether nothing is at ``path`` (False for a name the system refuses, so a
    caller does not look for a bundled file of that name instead and its error
    names what was typed)."""
    try:
        path.stat()
    except (FileNotFoundError, NotADirectoryError):
        return True
    except (OSError, ValueError):
        return False
    return False


def bundled(kind: str, name: str) -> Path:
    """A bundled file; ``name`` may omit the ``.yaml`` suffix."""
    folder = data_dir(kind)
    path = folder / name
    if not exists(path) and not path.suffix:
        path = folder / f"{name}.yaml"
    return path


def bundled_names(kind: str, suffix: str = ".yaml") -> list[str]:
    """The names of the bundled files of ``kind`` that end in ``suffix``, sorted, without
    it (``["bend", "bend-back", ...]`` for the trees): the names a user may give instead
    of a path. Files in sub-folders (a tree's library of subtrees) are not among them."""
    return sorted(p.name[: -len(suffix)] for p in data_dir(kind).glob(f"*{suffix}"))


def default_robot_path() -> Path:
    """The default robot description (the 2018 robot)."""
    return bundled("hardware", "pirate.yaml")


def find_file(kind: str, name: str | Path) -> Path:
    """A user-named file: the path itself if it exists, else the bundled file of that name.

    ``pirate-bt run bend.yaml`` then works from any folder with an installed
    library, while a path that exists always wins. A name that is neither is
    returned unchanged, so the caller's "no such file" error names what was typed.
    """
    path = Path(name)
    if not missing(path) or path.is_absolute() or len(path.parts) > 1:
        return path
    candidate = bundled(kind, path.name)
    return candidate if exists(candidate) else path
