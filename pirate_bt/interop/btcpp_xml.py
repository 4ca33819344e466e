"""A small, hostile-input-safe XML reader and an atomic file writer.

BehaviorTree.CPP files come from other people's tools, so they are read with
expat directly, not with a general-purpose tree builder:

- a ``<!DOCTYPE>`` is refused outright: a BT.CPP file never needs one, and
  without it there are no entity declarations, so no "billion laughs"
  expansion and no external entity can be read;
- the file size, the number of elements and the nesting depth are bounded, and so
  is each name, attribute value and text (:data:`MAX_XML_VALUE` characters): the
  file is fed to expat a piece at a time, and a tag or comment that is still not
  closed :data:`MAX_XML_TOKEN` bytes after it opened is refused there, before expat
  has buffered more of it (one 13 MB attribute took minutes and hundreds of MB);
- a named pipe, a socket or a block device is refused before it is opened (a pipe
  nobody writes to would be waited on for ever);
- an encoding expat cannot read itself (a multi-byte one such as Shift_JIS, or
  UTF-32) is decoded with Python's codec, so lines and columns still count
  characters; bytes that are not what the declaration says are refused where
  they are;
- every element keeps the line and column where it starts, so that any later
  problem is reported as ``file:line:column: message``;
- an attribute value holding a tab or a line break as written (not as ``&#9;`` or
  ``&#10;``) keeps it, as BT.CPP's parser (tinyxml2) keeps it, where XML's rules (and
  expat) make each a space: a multi-line ``_description`` stays multi-line.
"""

from __future__ import annotations

import codecs
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final
from xml.parsers import expat

from pirate_bt.atomic import cut_name, write_atomically
from pirate_bt.errors import (
    ArgumentValueError,
    InputError,
    LocatedError,
    SourceLocation,
    caller_location,
    file_argument,
    output_argument,
    reduce_error,
    shown,
)
from pirate_bt.treefile.names import printable
from pirate_bt.yamlfile import read_at_most, special_kind

__all__ = [
    "MAX_DEPTH",
    "MAX_ELEMENTS",
    "MAX_XML_BYTES",
    "MAX_XML_TOKEN",
    "MAX_XML_VALUE",
    "XmlElement",
    "caller_params_origin",
    "cut_name",
    "output_file",
    "parse_xml",
    "refuse_special",
    "write_atomic",
]

MAX_XML_BYTES: Final = 16 * 1024 * 1024
"""The largest XML file read (the biggest tree a person edits is a few hundred kB)."""
MAX_ELEMENTS: Final = 200_000
"""The most elements a file may hold."""
MAX_DEPTH: Final = 256
"""The deepest nesting of elements."""
MAX_XML_VALUE: Final = 65_536
"""The longest tag or attribute name, attribute value, or text of one element, in
characters (a node's name, a description or a port's value: a person writes a line)."""
MAX_XML_TOKEN: Final = 1024 * 1024
"""The longest tag (with its attributes), comment, CDATA section or processing
instruction, in bytes: what expat holds before it calls back."""
_PIECE: Final = 64 * 1024
"""The bytes given to expat at a time."""


@dataclass
class XmlElement:
    """One element: its tag, attributes (in file order), children and place."""

    tag: str
    attrs: dict[str, str]
    location: SourceLocation
    children: list[XmlElement] = field(default_factory=list)
    text: str = ""

    def error(self, message: str) -> LocatedError:
        """A located error at this element; what a terminal would act on in it (a
        tree ID's control character) is written as its escape."""
        return LocatedError(printable(message), self.location)


class _Refused(Exception):
    """A limit the reader met at a place (parse_xml's own: said as a LocatedError)."""

    def __init__(self, message: str, line: int, column: int) -> None:
        super().__init__(message)
        self.message = message
        self.line = line
        self.column = column

    def __reduce__(self) -> tuple[Any, ...]:  # across processes (pools, Dask) intact
        return reduce_error(self)


def parse_xml(path: Path) -> XmlElement:
    """Read ``path`` into :class:`XmlElement` objects.

    Raises:
        LocatedError: the file cannot be read or is too large (at ``file:1:1``),
            malformed XML, a DOCTYPE or entity, or limits exceeded.
    """
    where = SourceLocation(str(path))
    try:
        info = path.stat()
        kind = special_kind(info.st_mode)
        if kind is not None:  # opening a pipe nobody writes to waits for ever
            raise LocatedError(f"is {kind}, not an XML file", where)
        size = info.st_size
        if size > MAX_XML_BYTES:
            raise LocatedError(
                f"{size} bytes is larger than the {MAX_XML_BYTES} bytes a tree file may be", where
            )
        with path.open("rb") as stream:  # a device (/dev/zero) has no size and no end
            data = read_at_most(stream, MAX_XML_BYTES)
        if len(data) > MAX_XML_BYTES:
            raise LocatedError(f"larger than the {MAX_XML_BYTES} bytes a tree file may be", where)
    except IsADirectoryError:
        raise LocatedError("is a directory, not an XML file", where) from None
    except FileNotFoundError:
        raise LocatedError("no such file", where) from None
    except OSError as exc:
        raise LocatedError(f"cannot read: {exc.strerror or exc}", where) from None
    return parse_xml_bytes(data, str(path))


_DECLARED: Final = re.compile(
    rb"""(?:\xef\xbb\xbf)?<\?xml\s+version\s*=\s*(["'])[^"']*\1\s+encoding\s*=\s*(["'])([A-Za-z][\w.-]*)\2""",
    re.ASCII,
)
"""An XML declaration that names its encoding, written in ASCII at the file's start."""
_EXPAT_READS: Final = frozenset(
    {"UTF-8", "UTF-16", "UTF-16LE", "UTF-16BE", "ISO-8859-1", "US-ASCII"}
)
"""The encodings expat reads itself, by the names it knows them by (in any case). Any
other name a declaration gives is decoded here with Python's codec: pyexpat would read
a single-byte one that way too, but refuses every multi-byte one, and so every other
name of UTF-8 (``UTF8``, ``utf_8``: "not well-formed (invalid token)" at the first
character that is not ASCII)."""
_UTF32: Final = {
    b"\x00\x00\xfe\xff": "UTF-32",  # the byte-order marks (the codec reads them)
    b"\xff\xfe\x00\x00": "UTF-32",
    b"\x00\x00\x00<": "UTF-32-BE",  # '<' as the first character, no mark
    b"<\x00\x00\x00": "UTF-32-LE",
}
_SURROGATE: Final = re.compile("[\ud800-\udfff]")


def _at(text: str, end: int, file: str) -> SourceLocation:
    """The line and column (in characters, as expat counts them) of ``text[end]``; a
    line ends at LF, CR LF or a lone CR, as XML's line ends are."""
    before = text[:end].replace("\r\n", "\n").replace("\r", "\n")
    line_start = before.rfind("\n") + 1
    return SourceLocation(file, before.count("\n") + 1, len(before) - line_start + 1)


def _decoded(data: bytes, file: str) -> str | None:
    """The text of ``data`` when expat cannot read its encoding itself (UTF-32, or a
    multi-byte encoding its XML declaration names, such as Shift_JIS), decoded with
    Python's codec; None when expat reads the bytes.

    Raises:
        LocatedError: the bytes are not in that encoding (at the first one that is
            not, in characters), or the declaration names an encoding Python does not
            know or a codec that is not a text encoding (``rot13``), at 1:1.
    """
    name = _UTF32.get(data[:4])
    said = "its first four bytes say"
    if name is None:
        said = "its XML declaration says"
        match = _DECLARED.match(data)
        if match is None:
            return None
        name = match[3].decode("ascii")
        if name.upper() in _EXPAT_READS:
            return None
        try:
            # after a UTF-8 byte-order mark, only another name of UTF-8 is decoded here;
            # expat says what is wrong with any other name (it contradicts the mark)
            if data.startswith(codecs.BOM_UTF8) and codecs.lookup(name).name != "utf-8":
                return None
            codecs.lookup(name)
        except LookupError:
            cut = name if len(name) <= 40 else f"{name[:40]}... ({len(name)} characters)"
            raise LocatedError(
                f"XML declaration: unknown encoding: {cut}", SourceLocation(file)
            ) from None
    why = f"not {name} text, as {said}"
    try:
        text = data.decode(name)
    except LookupError:  # a codec of bytes or of text, not an encoding
        raise LocatedError(
            f"XML declaration: {shown(name)} is not a text encoding", SourceLocation(file)
        ) from None
    except UnicodeDecodeError as exc:
        try:
            before = data[: exc.start].decode(name, "replace")
        except UnicodeError:  # a codec without error handlers (idna): place it at 1:1
            raise LocatedError(f"{why} ({exc.reason})", SourceLocation(file)) from None
        raise LocatedError(
            f"{why} (byte 0x{data[exc.start]:02x})", _at(before, len(before), file)
        ) from None
    except UnicodeError as exc:  # a codec that fails without a place (punycode, undefined)
        raise LocatedError(f"{why} ({exc})", SourceLocation(file)) from None
    bad = _SURROGATE.search(text)  # UTF-7 can spell half a surrogate pair
    if bad is not None:
        raise LocatedError(f"{why} (U+{ord(bad[0]):04X})", _at(text, bad.start(), file))
    # a byte-order mark the codec kept (UTF8 after EF BB BF) is no text: before it, the
    # declared name took over again and the first character not ASCII was "invalid"
    return text.removeprefix("\ufeff")


def parse_xml_bytes(data: bytes, file: str) -> XmlElement:
    """Parse XML bytes; ``file`` names the source in error messages (see :func:`parse_xml`)."""
    text = _decoded(data, file)
    # decoded text is given to expat as UTF-8, which overrides the declared encoding
    payload = data if text is None else text.encode("utf-8")
    parser = expat.ParserCreate(None if text is None else "utf-8")
    stack: list[XmlElement] = []
    texts: list[list[str]] = []  # each open element's text, in pieces (joined at its end)
    text_sizes: list[int] = []
    roots: list[XmlElement] = []
    seen = [False]  # a comment before the first element
    raw = _RawTags(data, text)
    count = 0

    def here() -> tuple[int, int]:
        return parser.CurrentLineNumber, parser.CurrentColumnNumber + 1

    def refuse(message: str) -> None:
        raise _Refused(message, *here())

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal count
        count += 1
        if count > MAX_ELEMENTS:
            refuse(f"more than {MAX_ELEMENTS} elements")
        if len(stack) >= MAX_DEPTH:
            refuse(f"elements nested deeper than {MAX_DEPTH} levels")
        if len(tag) > MAX_XML_VALUE:
            refuse(f"a tag name of {len(tag)} characters{_OVER}")
        for key, value in attrs.items():
            if len(key) > MAX_XML_VALUE:
                refuse(f"<{_cut(tag)}>: an attribute name of {len(key)} characters{_OVER}")
            if len(value) > MAX_XML_VALUE:
                refuse(f"<{_cut(tag)}> {_cut(key)}: a value of {len(value)} characters{_OVER}")
        line, column = here()
        values = dict(attrs)
        if any(" " in v for v in values.values()):  # maybe a tab or line break as written
            values.update(raw.kept_whitespace(line, column))
        element = XmlElement(tag, values, SourceLocation(file, line, column))
        if stack:
            stack[-1].children.append(element)
        else:
            roots.append(element)
        stack.append(element)
        texts.append([])
        text_sizes.append(0)

    def end(tag: str) -> None:
        stack.pop().text = "".join(texts.pop())
        text_sizes.pop()

    def chars(text: str) -> None:
        if stack:
            if not text_sizes[-1] and text.isspace():
                return  # the indentation between children (a text is only read stripped)
            text_sizes[-1] += len(text)
            if text_sizes[-1] > MAX_XML_VALUE:
                where = stack[-1].location
                raise _Refused(
                    f"<{_cut(stack[-1].tag)}>: more than {MAX_XML_VALUE} characters of text"
                    " (the most an XML name, value or text may have)",
                    where.line or 1,
                    where.column or 1,
                )
            texts[-1].append(text)

    def doctype(*_args: object) -> None:
        refuse("a DOCTYPE is not allowed in a BehaviorTree.CPP file (no DTDs, no entities)")

    def entity(*_args: object) -> None:
        refuse("entity declarations are not allowed")

    def instruction(target: str, _data: str) -> None:
        # tinyxml2, BT.CPP's parser, reads <?...?> as a declaration, which may only
        # come before everything else: anywhere else it refuses the file
        if stack or roots or seen[0]:
            refuse(
                f"a processing instruction (<?{_cut(target)} ...?>) is only allowed before"
                " everything else in the file (BehaviorTree.CPP refuses it here)"
            )

    def comment(_text: str) -> None:
        seen[0] = True

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = entity
    parser.ProcessingInstructionHandler = instruction
    parser.CommentHandler = comment
    parser.ExternalEntityRefHandler = lambda *_a: refuse("external entities are not allowed")  # type: ignore[assignment]
    try:
        fed = 0
        while fed < len(payload):
            piece = payload[fed : fed + _PIECE]
            parser.Parse(piece, False)
            fed += len(piece)
            # what expat holds unparsed: a tag, comment... not closed yet
            held_from = max(parser.CurrentByteIndex, 0)
            if fed - held_from > MAX_XML_TOKEN:
                what = _token_kind(payload[held_from : held_from + 18].replace(b"\x00", b""))
                raise _Refused(
                    f"{what} still not closed after {MAX_XML_TOKEN} bytes (the most one may have)",
                    parser.CurrentLineNumber,
                    parser.CurrentColumnNumber + 1,
                )
        parser.Parse(b"", True)
    except _Refused as exc:
        raise LocatedError(exc.message, SourceLocation(file, exc.line, exc.column)) from None
    except expat.ExpatError as exc:
        message = expat.ErrorString(exc.code) if exc.code is not None else str(exc)
        if exc.code == expat.errors.codes[expat.errors.XML_ERROR_INVALID_TOKEN]:
            message = _bad_byte(payload, parser.ErrorByteIndex, text is not None) or message
        raise LocatedError(
            f"not well-formed XML: {message}", SourceLocation(file, exc.lineno, exc.offset + 1)
        ) from None
    except LookupError as exc:  # <?xml encoding="..."?> names an encoding Python lacks
        raise LocatedError(f"XML declaration: {exc}", SourceLocation(file)) from None
    except ValueError as exc:  # a multi-byte encoding declared after a byte-order mark
        raise LocatedError(
            f"XML declaration: the declared encoding cannot be read here ({exc});"
            " save the file as UTF-8",
            SourceLocation(file),
        ) from None
    if not roots:
        raise LocatedError("no XML element found", SourceLocation(file))
    return roots[0]


def _bad_byte(payload: bytes, at: int, utf8: bool) -> str | None:
    """What expat's "invalid token" at byte ``at`` of ``payload`` is, where it is a byte
    no UTF-8 text holds (a file saved as Latin-1 without saying so, a NUL): None for
    any other token, or where the file names another encoding."""
    if not 0 <= at < len(payload):
        return None
    if not utf8:  # expat reads the bytes: as UTF-8 unless a mark or declaration says not
        declared = _DECLARED.match(payload)
        if payload.startswith((b"\xff\xfe", b"\xfe\xff")) or (
            declared is not None and declared[3].decode("ascii").upper() != "UTF-8"
        ):
            return None
    if payload[at] == 0:
        return "a NUL byte (U+0000), which XML does not allow"
    try:
        payload[at : at + 4].decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start == 0:
            return (
                f"not UTF-8 text (byte 0x{payload[at]:02x}): save the file as UTF-8, or name"
                """ its encoding (<?xml version="1.0" encoding="ISO-8859-1"?>)"""
            )
    return None


_START_TAG: Final = re.compile(r"<[^\s/>]+((?:\s+[^\s=]+\s*=\s*(?:\"[^\"]*\"|'[^']*'))*)\s*/?>")
_ATTRIBUTE: Final = re.compile(r"([^\s=]+)\s*=\s*(?:\"([^\"]*)\"|'([^']*)')")
_REFERENCE: Final = re.compile(r"&(#x[0-9a-fA-F]+|#[0-9]+|lt|gt|amp|quot|apos);")
_NAMED: Final = {"lt": "<", "gt": ">", "amp": "&", "quot": '"', "apos": "'"}
_BREAK: Final = re.compile(r"\r\n|\r|\n")


def _referenced(match: re.Match[str]) -> str:
    name = match[1]
    if name.startswith("#x"):
        return chr(int(name[2:], 16))
    if name.startswith("#"):
        return chr(int(name[1:]))
    return _NAMED[name]


class _RawTags:
    """The start tags as written, for the attribute values expat normalised: XML makes
    a tab or line break written in a value a space; tinyxml2 keeps it (a CR LF or a lone
    CR as LF). Read only for an element whose values hold a space."""

    def __init__(self, data: bytes, text: str | None) -> None:
        self.data = data
        self.text = text
        self.starts: list[int] | None = None

    def document(self) -> str | None:
        if self.text is None:
            name = "utf-8-sig"
            if self.data.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
                name = "utf-16"
            else:
                match = _DECLARED.match(self.data)
                if match is not None and match[3].decode("ascii").upper() != "UTF-8":
                    name = match[3].decode("ascii")
            try:
                self.text = self.data.decode(name).removeprefix("\ufeff")
            except (LookupError, UnicodeError):
                return None
        return self.text

    def kept_whitespace(self, line: int, column: int) -> dict[str, str]:
        """The values of the start tag at ``line``:``column`` that hold a tab or line
        break as written, as tinyxml2 reads them."""
        text = self.document()
        if text is None:
            return {}
        if self.starts is None:
            self.starts = [0, *(m.end() for m in _BREAK.finditer(text))]
        if line > len(self.starts):
            return {}
        tag = _START_TAG.match(text, self.starts[line - 1] + column - 1)
        if tag is None or not any(c in tag[1] for c in "\t\n\r"):
            return {}
        kept: dict[str, str] = {}
        for attribute in _ATTRIBUTE.finditer(tag[1]):
            value = attribute[2] if attribute[2] is not None else attribute[3]
            if any(c in value for c in "\t\n\r"):
                kept[attribute[1]] = _REFERENCE.sub(_referenced, _BREAK.sub("\n", value))
        return kept


_OVER: Final = f", more than the {MAX_XML_VALUE} an XML name, value or text may have"


def _cut(name: str) -> str:
    """A tag or attribute name for a message, cut short when long."""
    return printable(name if len(name) <= 60 else name[:57] + "...")


def _token_kind(start: bytes) -> str:
    """What the markup starting with ``start`` is, for a message."""
    if start.startswith(b"<!--"):
        return "a comment"
    if start.startswith(b"<![CDATA["):
        return "a CDATA section"
    if start.startswith(b"<?"):
        return "a processing instruction"
    if start.startswith(b"<"):
        return "a tag"
    return "markup"


def refuse_special(path: Path) -> None:
    """Refuse to write ``path`` when it exists and is not a regular file.

    Writing through a temporary file and a rename would replace a device such
    as ``/dev/null``, or a named pipe, with a regular file.

    Raises:
        InputError: ``path`` is a directory, a device, a pipe or a socket.
    """
    if path.exists() and not path.is_file():
        what = "a directory" if path.is_dir() else "not a regular file"
        raise InputError(f"{path}: is {what}; nothing written")


def output_file(value: object, option: str) -> Path:
    """An output given as an argument (:func:`~pirate_bt.errors.output_argument`); a
    folder is named by the path as given, which is what the caller typed (``-o``
    on the command line, ``option`` in Python).

    Raises:
        ArgumentTypeError: not a file name (named by ``option``).
        ArgumentValueError: a folder, a bad name, or a file on the way.
    """
    path = file_argument(value, option)
    try:
        folder = path.is_dir()
    except OSError:  # a name the system refuses: output_argument words it
        folder = False
    if folder:
        raise ArgumentValueError(f"{path}: is a folder; name a file to write")
    return output_argument(path, option)


def write_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file beside it, then rename.

    A reader (or a crash) never sees a half-written file: either the old file or
    the whole new one.

    Raises:
        InputError: the file or a folder on its way cannot be written.
    """
    return write_atomic_bytes(path, text.encode("utf-8"))


def write_atomic_bytes(path: Path, data: bytes) -> Path:
    """Like :func:`write_atomic`, for bytes, through the library's one atomic writer
    (:func:`pirate_bt.atomic.write_atomically`): a missing folder is made, as every
    other output of the library makes it, and a symbolic link's target is replaced.

    Raises:
        InputError: also when ``path`` exists and is not a regular file (a
            device, a pipe): a rename would replace it.
    """
    refuse_special(path)
    try:
        return write_atomically(path, lambda stream: stream.write(data))
    except OSError as exc:
        raise InputError(f"{path}: cannot write: {exc.strerror or exc}") from None


def caller_params_origin() -> SourceLocation | str:
    """Where a caller's ``params`` were given, for their errors: the planner's file and
    line past the XML conversion, the tree loader and the API (``planner.py:7:1``, as
    :func:`pirate_bt.treefile.load_tree` says of a YAML tree's), or ``--param`` when
    pirate_bt's own command called (the loader alone saw the conversion as the caller)."""
    package = Path(__file__).resolve().parent.parent
    skip = (package / "interop", package / "treefile", package / "api")
    return caller_location(skip=skip) or "--param"
