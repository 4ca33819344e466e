"""The bridge side's view of a frame: checked up to its version, not yet interpreted.

A host drops any frame it cannot decode. A bridge may not: it answers an intact
request of an unknown type or a wrong length with a ``NACK`` (``docs/protocol.md``,
Checks, in order), so it needs the header of a frame whose payload is wrong.
:class:`RawFrameDecoder` stops after steps 1-2 (framing, CRC, version) and hands
over a :class:`RawFrame`; :class:`HostPayloads` knows each host request's length
in a layout and unpacks the payloads the bridge checks field by field.
"""

from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

from pirate_bt.errors import FrameError
from pirate_bt.link.decoder import FrameDecoder
from pirate_bt.link.framing import HEADER_BYTES, MAX_BODY_BYTES, PROTOCOL_VERSION
from pirate_bt.link.layout import WireLayout
from pirate_bt.link.messages import MsgType

__all__ = ["HOST_TYPES", "HostPayloads", "RawFrame", "RawFrameDecoder", "parse_raw"]

_HEADER = struct.Struct("<BBHB")
_CRC = struct.Struct("<H")
_HELLO = struct.Struct("<IB")
_SETPOINT = struct.Struct("<BBh")

HOST_TYPES: frozenset[int] = frozenset(
    int(t)
    for t in (
        MsgType.HELLO,
        MsgType.SETPOINT,
        MsgType.BULK_SETPOINTS,
        MsgType.HEARTBEAT,
        MsgType.ESTOP,
        MsgType.ESTOP_RESET,
        MsgType.COUNTERS_REQUEST,
    )
)
"""The seven host -> bridge type codes; a bridge answers any other with UNKNOWN_TYPE."""


@dataclass(frozen=True, slots=True)
class RawFrame:
    """A frame that passed the framing, CRC and version checks.

    Attributes:
        type: The type byte (any value).
        seq: The sequence number.
        arg: The ``arg`` byte.
        payload: The payload bytes.
    """

    type: int
    seq: int
    arg: int
    payload: bytes


def parse_raw(body: bytes) -> RawFrame:
    """Check a body's size, CRC and version (steps 1-2 of the bridge's checks).

    Args:
        body: Header + payload + CRC (after COBS decoding).

    Returns:
        The frame's header fields and payload.

    Raises:
        FrameError: ``short``, ``oversize``, ``crc`` or ``version``.
    """
    n = len(body)
    if n < HEADER_BYTES + 2:
        raise FrameError("short", f"{n} bytes, need at least {HEADER_BYTES + 2}")
    if n > MAX_BODY_BYTES:
        raise FrameError("oversize", f"{n}-byte body (max {MAX_BODY_BYTES})")
    (crc,) = _CRC.unpack_from(body, n - 2)
    if binascii.crc_hqx(memoryview(body)[: n - 2], 0) != crc:
        raise FrameError("crc", f"CRC mismatch (frame says {crc:#06x})")
    version, code, seq, arg = _HEADER.unpack_from(body)
    if version != PROTOCOL_VERSION:
        raise FrameError("version", f"protocol version {version}, expected {PROTOCOL_VERSION}")
    return RawFrame(code, seq, arg, bytes(body[HEADER_BYTES : n - 2]))


class RawFrameDecoder(FrameDecoder):
    """The bridge side's streaming decoder: like :class:`FrameDecoder`, but each good
    frame comes back as a :class:`RawFrame`."""

    def feed_raw(self, data: bytes) -> list[RawFrame | FrameError]:
        """Add received bytes; return every frame they complete, in order (never raises).

        Args:
            data: Bytes read from the line.

        Returns:
            Raw frames and frame errors, in arrival order.
        """
        return self._feed(data, parse_raw)


class HostPayloads:
    """Lengths and fields of the host -> bridge payloads in one layout.

    Args:
        layout: The robot's wire layout.
    """

    def __init__(self, layout: WireLayout) -> None:
        self._bulk = struct.Struct("<" + "Bh" * layout.n_motors)
        self._sizes = {
            int(MsgType.HELLO): _HELLO.size,
            int(MsgType.SETPOINT): _SETPOINT.size,
            int(MsgType.BULK_SETPOINTS): layout.bulk_payload_bytes,
            int(MsgType.HEARTBEAT): 0,
            int(MsgType.ESTOP): 0,
            int(MsgType.ESTOP_RESET): 0,
            int(MsgType.COUNTERS_REQUEST): 0,
        }

    def size(self, kind: int) -> int:
        """The payload length of host -> bridge type ``kind``.

        Raises:
            KeyError: not a host -> bridge type.
        """
        return self._sizes[kind]

    @staticmethod
    def hello(payload: bytes) -> tuple[int, int]:
        """``(layout_digest, minor)`` of a HELLO payload of the right length."""
        digest, minor = _HELLO.unpack(payload)
        return digest, minor

    @staticmethod
    def setpoint(payload: bytes) -> tuple[int, int, int]:
        """``(slot, mode_code, raw_value)`` of a SETPOINT payload of the right length."""
        slot, code, raw = _SETPOINT.unpack(payload)
        return slot, code, raw

    def bulk(self, payload: bytes) -> list[tuple[int, int]]:
        """``(mode_code, raw_value)`` per motor of a BULK_SETPOINTS payload."""
        flat = self._bulk.unpack(payload)
        return list(zip(flat[0::2], flat[1::2], strict=True))
