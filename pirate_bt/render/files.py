"""Write a picture so that a failure never leaves half of one behind.

:func:`write_file` writes the bytes through :func:`pirate_bt.atomic.write_atomically`
(a temporary file renamed over the output once all of it is written): an existing
picture stays whole until the new one replaces it, and a write that fails (a full
disk) removes the temporary file and raises. :func:`write_diagram` writes a diagram's
``dot`` source and, with Graphviz, its picture that way.
"""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
from pathlib import Path

from pirate_bt.atomic import write_atomically

__all__ = ["DIAGRAM_SUFFIXES", "MAX_DRAWN_NODES", "write_diagram", "write_file"]

DIAGRAM_SUFFIXES = (".dot", ".svg", ".png")
"""What :func:`write_diagram` draws to."""

MAX_DRAWN_NODES = 5000
"""The most nodes a picture is drawn with: Graphviz lays out 4,000 nodes of a deep tree
in 2 s, 8,000 in 7 s and 48,000 in minutes (a tree file may have 100,000). A larger
one gets its ``.dot`` source only."""


def write_file(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole or not at all (its folder is made if missing).

    A symbolic link is followed (its target is replaced). A path that exists and is
    not a regular file (a device such as ``/dev/stdout``, a pipe) is written in place;
    a named pipe nobody reads is refused at once (``ENXIO``), never waited on.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        OSError: the file cannot be written (``IsADirectoryError`` for a folder);
            nothing is left of the attempt.
    """
    out = Path(path)
    try:
        write_atomically(out, lambda stream: stream.write(data))
    except OSError as exc:  # named by the output, not by a temporary file
        if exc.errno is None:
            raise
        raise OSError(exc.errno, exc.strerror, str(out)) from exc
    return out


def write_diagram(source: str, out: str | Path) -> Path:
    """Write ``source`` to ``out`` (``.dot``, ``.svg`` or ``.png`` by suffix).

    The ``.dot`` file is always written beside the picture, so nothing is lost
    when Graphviz is missing. Each file is written whole or not at all
    (:func:`write_file`).

    Returns:
        The path of the ``.dot`` file, or of the picture when one was drawn.

    Raises:
        FileNotFoundError: ``dot`` is not installed and a picture was asked for
            (the ``.dot`` file has been written all the same); its ``filename``
            is ``None``, unlike that of a file that cannot be written.
        ValueError: an unsupported suffix.
        InputError: too many nodes to draw, or Graphviz failed (the ``.dot`` file
            has been written).
        OSError: a file cannot be written.
    """
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in DIAGRAM_SUFFIXES:
        raise ValueError(f"cannot draw to {out.name!r}: use .dot, .svg or .png")
    if out.is_dir():
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(out))
    dot_path = out if suffix == ".dot" else out.with_suffix(".dot")
    write_file(dot_path, source.encode("utf-8"))
    if suffix == ".dot":
        return dot_path
    nodes = sum(1 for line in source.splitlines() if line.startswith('  "') and " -> " not in line)
    if nodes > MAX_DRAWN_NODES:
        from pirate_bt.errors import InputError

        raise InputError(
            f"{out}: {nodes:,} nodes are too many to draw (at most {MAX_DRAWN_NODES:,}; beyond,"
            f" Graphviz takes seconds to minutes); {dot_path} was written for dot to draw"
        )
    if shutil.which("dot") is None:
        raise FileNotFoundError(
            f"Graphviz 'dot' is not installed, so {out} was not drawn; {dot_path} was written"
            " (install it with: apt-get install graphviz)"
        )
    # Graphviz's complaints are said here, in one line, not on standard error. dot is
    # fed by subprocess.run, which gives its exit and words also when it stopped reading
    # half-way (graphviz.Source.pipe raised BrokenPipeError there, which the command
    # line took for its own output closed: exit 0, no picture, not a word).
    done = subprocess.run(
        ["dot", f"-T{suffix[1:]}"], input=source.encode("utf-8"), capture_output=True, check=False
    )
    if done.returncode != 0:
        from pirate_bt.errors import InputError

        said = " ".join(done.stderr.decode("utf-8", "replace").split())
        raise InputError(
            f"{out}: Graphviz could not draw it (dot exit {done.returncode}: {said[:300] or '-'});"
            f" {dot_path} was written"
        )
    write_file(out, done.stdout)
    return out
