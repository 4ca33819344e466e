"""The text of a ``.jsonl.gz`` trace, read so that a crash loses as little as it can.

:func:`gzip.open` decompresses a file in pieces of many kilobytes: damage in one
piece lost the lines before it in the same piece (a trace damaged at its 69th
line said *not readable as gzip after 10 lines*). And a file whose end the
system never wrote, but filled with NUL bytes (a crash of the machine, not of the
run: the file's size was saved, its last blocks were not), was *damaged*, where the
same file cut off before the NULs read as a run cut off, every tick up to the cut.

:func:`open_gzip_text` reads the compressed bytes 1 kB at a time, so damage costs at
most the lines of that kilobyte, and reads NUL bytes that run to the end of the file
as where the file was cut off. The rest is :mod:`gzip`'s reading: members one after
the other, NULs between or after them ignored, the CRC and length of each member
checked; a stream that ends early raises :class:`EOFError`, damage
:class:`zlib.error` or :class:`gzip.BadGzipFile`.
"""

from __future__ import annotations

import gzip
import io
import os
import stat
import sys
import zlib
from typing import IO, Any, Final

__all__ = ["open_gzip_text"]

_CHUNK: Final = 1024
"""Compressed bytes fed to the decompressor at a time."""

_OUT: Final = 256 * 1024
"""The most bytes one step decompresses (a few compressed bytes can be megabytes)."""

_MAGIC: Final = b"\x1f\x8b"

_FILL: Final = 64
"""The fewest NUL bytes at the end of a file read as a crash's fill (a system fills
whole blocks of 512 bytes or more; deflate data seldom holds a run of 64 NULs)."""


def open_gzip_text(path: str | os.PathLike[str]) -> IO[bytes]:
    """The decompressed bytes of the gzip file ``path``, as a buffered stream.

    Raises:
        OSError: the file cannot be opened.
    """
    return io.BufferedReader(_GzipRaw(open(path, "rb")))


def _nul_tail(file: IO[bytes], size: int) -> int:
    """The offset where the NUL bytes that end ``file`` begin (``size`` if none, or
    fewer than :data:`_FILL`: compressed data of a file cut off may end in a few)."""
    end = size
    while end > 0:
        start = max(0, end - 65536)
        file.seek(start)
        block = file.read(end - start).rstrip(b"\0")
        if block:
            end = start + len(block)
            break
        end = start
    file.seek(0)
    return end if size - end >= _FILL else size


class _GzipRaw(io.RawIOBase):
    def __init__(self, file: IO[bytes]) -> None:
        self._file = file
        status = os.fstat(file.fileno())
        self._size = status.st_size if stat.S_ISREG(status.st_mode) else sys.maxsize
        self._nul_from = (  # the NULs from there on are never fed
            _nul_tail(file, self._size) if self._size < sys.maxsize else self._size
        )
        self._members = 0  # members begun: NULs before the first are no padding
        self._decompressor = zlib.decompressobj(wbits=31)
        self._member = False  # inside a member: its end not reached yet
        self._input = b""  # compressed bytes not fed yet
        self._read = 0  # the bytes of the file read so far
        self._output = b""
        self._end: BaseException | None = None  # raised once the lines before it are read

    def readable(self) -> bool:
        return True

    def close(self) -> None:
        self._file.close()
        super().close()

    def readinto(self, buffer: Any) -> int:
        while not self._output:
            if self._end is not None:
                raise self._end
            if not self._step():
                return 0
        view = memoryview(buffer).cast("B")
        size = min(len(view), len(self._output))
        view[:size] = self._output[:size]
        self._output = self._output[size:]
        return size

    def _step(self) -> bool:
        """Decompress some more into ``_output``; False at the end of the stream."""
        if not self._input:
            self._input = self._file.read(min(_CHUNK, self._nul_from - self._read))
            self._read += len(self._input)
            if not self._input:
                if not self._member:
                    return False
                self._end_of_member()
                return True
        if not self._member:  # NULs between members are padding (as gzip reads them)
            self._input = self._input.lstrip(b"\0") if self._members else self._input
            if len(self._input) < len(_MAGIC) and self._read < self._nul_from:
                more = self._file.read(min(_CHUNK, self._nul_from - self._read))
                self._input, self._read = self._input + more, self._read + len(more)
            if not self._input:
                return True
            if not self._input.startswith(_MAGIC):
                raise gzip.BadGzipFile(f"Not a gzipped file ({self._input[:2]!r})")
            self._decompressor = zlib.decompressobj(wbits=31)
            self._member, self._members = True, self._members + 1
        data, before = self._input, self._decompressor.copy()
        try:
            self._output = self._decompressor.decompress(data, _OUT)
        except zlib.error as exc:  # again, a byte at a time, up to the damage
            self._decompressor, self._input = before, b""
            self._output, self._end = self._salvage(data), exc
            return True
        d = self._decompressor
        self._input = d.unused_data if d.eof else d.unconsumed_tail
        self._member = not d.eof
        return True

    def _end_of_member(self) -> None:
        """The file's bytes before its NULs end inside a member: a cut, unless the
        member's last bytes (its length) are NULs."""
        ending = self._decompressor.copy()
        try:
            out = ending.decompress(b"\0" * min(8, self._size - self._nul_from))
        except zlib.error:
            out = b""
        if ending.eof:
            self._output, self._member = out, False
        elif self._size > self._nul_from:
            self._member = False
            self._end = EOFError("the file ends in NUL bytes, in the middle of its stream")
        else:
            raise EOFError("Compressed file ended before the end-of-stream marker was reached")

    def _salvage(self, data: bytes) -> bytes:
        """What ``data`` decompresses to before the damage in it."""
        out = []
        for at in range(len(data)):
            try:
                out.append(self._decompressor.decompress(data[at : at + 1]))
            except zlib.error:
                break
        return b"".join(out)
