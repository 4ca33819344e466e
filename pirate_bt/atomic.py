"""Write a file whole or not at all: the one temporary-file-and-rename of the library.

:func:`write_atomically` lets the caller fill a temporary file beside the output and
renames it over the output only once it is complete: an existing file stays whole
until the new one replaces it, and a write that fails (a full disk, an exception in
the caller's code) removes the temporary file and raises. Pictures
(:mod:`pirate_bt.render.files`) and MCAP files (:mod:`pirate_bt.interop.mcap_writer`)
are written through it.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["cut_name", "new_folders_undone", "write_atomically"]


def cut_name(name: str, limit: int = 64) -> str:
    """``name`` cut to at most ``limit`` bytes on the file system, for a temporary file
    named after it: a file name may have 255 bytes, and ``.NAME.XXXXXXXX.part`` beside a
    file whose name has nearly that many would be refused (*File name too long*)."""
    raw = os.fsencode(name)
    return name if len(raw) <= limit else os.fsdecode(raw[:limit])


def write_atomically(
    path: str | Path, fill: Callable[[IO[bytes]], Any], *, durable: bool = False
) -> Path:
    """Call ``fill(stream)`` on a temporary file beside ``path``, then rename it over ``path``.

    Its folder is made if missing. A symbolic link is followed (its target is replaced,
    the link stays). A path that exists and is not a regular file (a device such as
    ``/dev/null``, a pipe) is written in place, never replaced; a named pipe nobody
    reads is refused at once (``ENXIO``), not waited on. The new file gets the
    old one's permissions, or what ``open()`` would have given.

    Args:
        path: The file to write.
        fill: Writes the content to the binary stream it is given.
        durable: ``fsync`` the content before the rename (a file that must survive a
            power cut once it has its name).

    Returns:
        The file written (the link's target when ``path`` is a symbolic link).

    Raises:
        OSError: the file cannot be written (``IsADirectoryError`` for a folder);
            nothing is left of the attempt. A write that failed (a full disk) names
            ``path`` as its ``filename``, not the temporary file or nothing.
    """
    out = Path(path)
    target = Path(os.path.realpath(out)) if out.is_symlink() else out
    if target.is_dir():
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(out))
    target.parent.mkdir(parents=True, exist_ok=True)
    if target.exists() and not target.is_file():
        try:
            with _opened_in_place(target, out) as stream:
                fill(stream)
        except OSError as exc:
            _name(exc, out)
            raise
        return target
    fd, temp = tempfile.mkstemp(
        prefix=f".{cut_name(target.name)}.", suffix=".part", dir=target.parent
    )
    try:
        if target.exists():
            os.chmod(temp, target.stat().st_mode & 0o777)
        else:  # what open() would have given: mkstemp makes it private
            mask = os.umask(0)
            os.umask(mask)
            os.chmod(temp, 0o666 & ~mask)
        with open(fd, "wb") as stream:
            fill(stream)
            if durable:
                stream.flush()
                os.fsync(stream.fileno())
        os.replace(temp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(temp)
        if isinstance(exc, OSError):
            _name(exc, out)
        raise
    return target


def _opened_in_place(target: Path, out: Path) -> IO[bytes]:
    """``target``, not a regular file, opened to be written in place. A named pipe is
    opened without waiting: one nobody reads is refused (``ENXIO``, naming ``out``, the
    path as given), where ``open()`` waited for a reader for ever; one that is read is
    then written as any file."""
    if not stat.S_ISFIFO(target.stat().st_mode):
        return open(target, "wb")
    try:
        fd = os.open(target, os.O_WRONLY | os.O_NONBLOCK)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise OSError(errno.ENXIO, "a named pipe nobody reads", str(out)) from None
        raise
    os.set_blocking(fd, True)
    return open(fd, "wb")


_WRITE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO})


def _name(exc: OSError, path: Path) -> None:
    """Give ``exc`` ``path`` as its file when a write failed without one (a full disk
    said only "No space left on device": ``robot header -o x.h``, onto /dev/full)."""
    if exc.filename is None and exc.errno in _WRITE_ERRORS:
        exc.filename = str(path)


@contextlib.contextmanager
def new_folders_undone(folder: str | Path) -> Iterator[None]:
    """Run the block; when it raises, take away again, innermost first, the folders on
    the way to ``folder`` (itself included) that did not exist when it began and are
    still empty: an output that failed before anything was written in it leaves no
    folder behind (a refused import, a campaign whose scheduler never answered). The
    block makes them as it needs them."""
    target = Path(folder)
    made = [p for p in (target, *target.parents) if not p.exists()]
    try:
        yield
    except BaseException:
        for path in made:  # one that holds anything stays, and so do those above it
            try:
                path.rmdir()
            except OSError:
                break
        raise
