"""Framing primitives of the PIRATEbay protocol: sizes, CRC, COBS, sequence arithmetic.

These are the parts of ``docs/protocol.md`` that do not depend on the message
types or the robot's layout: the CRC-16/XMODEM of every body, the COBS byte
stuffing that keeps 0x00 free for the delimiter, the RFC 1982 comparison of
sequence numbers, and the time a frame takes on the line.
"""

from __future__ import annotations

import binascii

from pirate_bt.errors import FrameError

__all__ = [
    "HEADER_BYTES",
    "MAX_BODY_BYTES",
    "MAX_PAYLOAD_BYTES",
    "MAX_WIRE_BYTES",
    "PROTOCOL_MINOR",
    "PROTOCOL_MINOR_MAX",
    "PROTOCOL_VERSION",
    "byte_time_s",
    "cobs_decode",
    "cobs_encode",
    "crc16",
    "frame_time_s",
    "seq_newer",
]

PROTOCOL_VERSION = 1
"""Protocol major version, carried in byte 0 of every frame."""
PROTOCOL_MINOR = 1
"""Lowest protocol minor version spoken here (1.1), carried in HELLO and HELLO_REPLY
(docs/protocol.md, Versions). Not what the host asks for by default: the session asks
for :data:`PROTOCOL_MINOR_MAX` (``SessionConfig.protocol_minor``) and falls back to
this one when a 1.1 bridge refuses that HELLO. It is the default of
:func:`~pirate_bt.link.transport.handshake`'s ``minor`` and of the messages' ``minor``
fields, the simulated bridge's minor before any HELLO, and the vector file's
``protocol_minor``. A session speaks the minor of its HELLO."""
PROTOCOL_MINOR_MAX = 2
"""Highest minor version known here (1.2, which adds the bridge flag ``ESTOP_INPUT``,
the hardware e-stop input), and the one the host asks for by default
(``SessionConfig.protocol_minor``); ``SessionConfig(protocol_minor=1)`` asks for 1.1
only."""

HEADER_BYTES = 5
MAX_BODY_BYTES = 254
"""Largest body (header + payload + CRC) before COBS; COBS then adds exactly one byte."""
MAX_PAYLOAD_BYTES = MAX_BODY_BYTES - HEADER_BYTES - 2
MAX_WIRE_BYTES = MAX_BODY_BYTES + 2
"""Largest frame on the wire: COBS overhead byte and the 0x00 delimiter included."""


def crc16(data: bytes) -> int:
    """CRC-16/XMODEM: poly 0x1021, init 0x0000, no reflection, xorout 0; check 0x31C3.

    Args:
        data: The bytes to checksum.

    Returns:
        The 16-bit CRC.
    """
    return binascii.crc_hqx(data, 0)


def seq_newer(a: int, b: int) -> bool:
    """True when sequence number ``a`` is newer than ``b`` (RFC 1982 serial arithmetic, 16 bit).

    Args:
        a: A sequence number (0..65535).
        b: Another one.

    Returns:
        ``True`` if ``a`` follows ``b`` by 1..32767 steps modulo 65536.
    """
    return 0 < ((a - b) & 0xFFFF) < 0x8000


def byte_time_s(baud: int) -> float:
    """Seconds one byte takes on an 8N1 line (10 bit times).

    Args:
        baud: Line rate in bit/s.

    Returns:
        The duration of one byte in seconds.
    """
    return 10.0 / baud


def frame_time_s(n_bytes: int, baud: int) -> float:
    """Seconds ``n_bytes`` of wire frame take on an 8N1 line.

    Args:
        n_bytes: Wire bytes, COBS overhead and delimiter included.
        baud: Line rate in bit/s.

    Returns:
        The transmission time in seconds.
    """
    return n_bytes * 10.0 / baud


# One-byte COBS code for each block length, so encoding does not build a bytes per block.
_COBS_CODE: tuple[bytes, ...] = tuple(bytes((i,)) for i in range(256))


def cobs_encode(data: bytes) -> bytes:
    """COBS-encode ``data``: the result has no zero byte and is 1 + len//254 bytes longer.

    Args:
        data: Any bytes.

    Returns:
        The encoded bytes, without the 0x00 delimiter.
    """
    if len(data) < 254:  # pragma: no mutate (254 bytes take either path to the same bytes)
        # Every frame body is at most 254 bytes, so no block reaches the 0xFF code and
        # each zero-free run becomes (length + 1) + run: one C split, one loop turn per run.
        out: list[bytes] = []
        for chunk in data.split(b"\x00"):
            out += (_COBS_CODE[len(chunk) + 1], chunk)
        return b"".join(out)
    out = []
    chunks = data.split(b"\x00")
    last = len(chunks) - 1
    for i, chunk in enumerate(chunks):
        while len(chunk) >= 254:
            out.append(b"\xff")
            out.append(chunk[:254])
            chunk = chunk[254:]
            if not chunk and i == last:
                return b"".join(out)
        out.append(_COBS_CODE[len(chunk) + 1])
        out.append(chunk)
    return b"".join(out)


def cobs_decode(data: bytes) -> bytes:
    """Decode one COBS block sequence (delimiter already removed).

    Args:
        data: Encoded bytes.

    Returns:
        The decoded bytes.

    Raises:
        FrameError: ``cobs``, when the encoding is invalid (a zero byte, or a code
            pointing past the end).
    """
    n = len(data)
    if n == 0:
        raise FrameError("cobs", "empty frame")
    if 0 in data:
        raise FrameError("cobs", "zero byte inside frame")
    # Fast path: each code byte stands where the decoded data has a zero (the first one
    # stands before the data), so overwriting the codes with zeros in a copy and
    # dropping byte 0 decodes the frame with one loop turn per block and no joins. A
    # 0xFF code (a 254-byte run, no zero after it) breaks that rule: the block walk
    # below handles it.
    buf = bytearray(data)
    i = 0
    while i < n:
        code = buf[i]
        if code == 0xFF:
            break
        buf[i] = 0
        i += code
    else:
        if i == n:
            del buf[0]
            return bytes(buf)
    out: list[bytes] = []
    i = 0
    while i < n:
        code = data[i]
        end = i + code
        if end > n:
            raise FrameError("cobs", f"block code {code} at {i} runs past the end ({n} bytes)")
        out.append(data[i + 1 : end])
        if code != 0xFF and end < n:
            out.append(b"\x00")
        i = end
    return b"".join(out)
