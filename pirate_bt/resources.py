"""Where the bundled data lives: robot descriptions, trees and scenarios.

In a wheel the data is packaged under ``pirate_bt/_data/``; in a source checkout
(editable install) it is the repository's ``hardware/``, ``trees/`` and
``scenarios/`` folders. Both are found the same way, so an installed library
works outside the repository.
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["DATA_KINDS", "bundled", "data_dir", "default_robot_path"]

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


def bundled(kind: str, name: str) -> Path:
    """A bundled file; ``name`` may omit the ``.yaml`` suffix."""
    folder = data_dir(kind)
    path = folder / name
    if not path.exists() and not path.suffix:
        path = folder / f"{name}.yaml"
    return path


def default_robot_path() -> Path:
    """The default robot description (the 2018 robot)."""
    return bundled("hardware", "pirate.yaml")
