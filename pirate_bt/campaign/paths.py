"""Names that become paths under a campaign's output folder: checked or made safe.

A campaign writes under one folder (``OUTPUT/``): ``results.jsonl``, the report
files and ``traces/CASE_ID[.jsonl]``. Only two kinds of name are ever joined
onto it: fixed names (``results.jsonl``, ``report.md``, ``success_vs_drop.png``)
and case ids. A case id must be a *safe name* (:func:`safe_name`): one path
component of letters, digits, ``.``, ``_`` and ``-``, starting with a letter or
digit, at most :data:`MAX_SAFE_NAME` characters; anything else (``../x``, an
absolute path, a NUL byte, a 10 kB name) is refused before a case runs. Names
written by people (a campaign's name, a run's name) are never joined as they
are: :func:`slug` turns them into a safe name where one is needed, such as the
default output folder ``campaign-NAME``.

Input files a spec names (trees, routes, networks, robots) are inputs, not
outputs: they may be anywhere, and :func:`pirate_bt.campaign.cases.check_inputs`
checks that each exists and is a file.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from pirate_bt.errors import InputError

RESUME = "resume=True"
"""How a message names resuming: ``run_campaign``'s argument (``pirate-bt campaign``
says ``--resume``)."""

OUTPUT = "output="
"""How a message names the output folder: ``run_campaign``'s argument
(``pirate-bt campaign`` says ``--output``)."""

__all__ = [
    "LOCK_NAME",
    "MAX_SAFE_NAME",
    "OUTPUT",
    "RESULTS_NAME",
    "RESUME",
    "campaign_lock",
    "inside",
    "is_safe_name",
    "safe_name",
    "slug",
]

LOCK_NAME = ".campaign.lock"
"""The file a running campaign holds its folder by (:func:`campaign_lock`)."""

RESULTS_NAME = "results.jsonl"
"""The campaign's rows, one JSON line per case, in its output folder."""

MAX_SAFE_NAME = 128
"""The longest safe name (well under the 255 bytes of a file name)."""

_SAFE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_UNSAFE_RUN = re.compile(r"[^A-Za-z0-9._-]+")


def is_safe_name(name: object) -> bool:
    """Whether ``name`` is a safe name (see the module's text)."""
    return (
        isinstance(name, str)
        and 0 < len(name) <= MAX_SAFE_NAME
        and _SAFE.fullmatch(name) is not None
    )


def safe_name(name: object, what: str = "name") -> str:
    """``name`` itself if it is a safe name.

    Raises:
        InputError: it is not; the message shows the name (shortened) and the rule.
    """
    if is_safe_name(name):
        return str(name)
    shown = repr(name)
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    raise InputError(
        f"{what} {shown} is not a safe file name (letters, digits, '.', '_', '-',"
        f" starting with a letter or digit, at most {MAX_SAFE_NAME} characters)"
    )


def slug(text: str, max_length: int = 64, default: str = "campaign") -> str:
    """A safe name made from ``text``: other characters become ``-``, shortened.

    ``slug("../../etc/x")`` is ``"etc-x"``; an empty result is ``default``.
    """
    out = _UNSAFE_RUN.sub("-", text)[:max_length].strip("-._")
    return out if out and _SAFE.fullmatch(out) else default


def inside(folder: Path, name: str, what: str = "name") -> Path:
    """``folder / name`` for a safe ``name``: always a direct child of ``folder``.

    Raises:
        InputError: ``name`` is not a safe name.
    """
    path = folder / safe_name(name, what)
    if path.parent != folder:  # pragma: no cover - a safe name is one component
        raise InputError(f"{what} {name!r} leaves {folder}")
    return path


@contextmanager
def campaign_lock(folder: Path) -> Iterator[None]:
    """Hold ``folder`` for one campaign (an advisory lock on ``folder/.campaign.lock``,
    released when the campaign ends or its process dies).

    Raises:
        InputError: another campaign holds it.
    """
    import fcntl

    lock = folder / LOCK_NAME
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:  # a folder nobody may write in (/sys/kernel, a read-only disk)
            raise InputError(
                f"{folder}: cannot write a campaign there ({exc.strerror}); give another {OUTPUT}"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)  # the holder's lock file is the holder's: left as it is
            raise InputError(
                f"{folder}: another campaign is writing there now; wait for it, or give"
                f" another {OUTPUT}"
            ) from None
        # The campaign that held it may have removed the file as it ended, between our
        # open and our lock: a lock on a file no longer in the folder holds nothing.
        try:
            held = os.stat(lock)
        except FileNotFoundError:
            held = None
        mine = os.fstat(fd)
        if held is not None and (held.st_dev, held.st_ino) == (mine.st_dev, mine.st_ino):
            break
        os.close(fd)
    try:
        yield
    finally:
        if not any(p.name != LOCK_NAME for p in folder.iterdir()):
            # refused before it wrote anything (a scheduler that did not answer): leave
            # the folder as empty as it was made (removed while still held, so no
            # campaign waiting on this file takes a lock that holds nothing)
            lock.unlink(missing_ok=True)
        os.close(fd)
