"""The payloads of the fixed-size PIRATEbay messages: their layouts and their decoding.

Every message but ``STATE`` and ``BULK_SETPOINTS`` has a payload whose layout does
not depend on the robot (``docs/protocol.md``): :class:`~pirate_bt.link.codec.FrameCodec`
packs them with the structures here and hands their decoding to :func:`decode_fixed`.
"""

from __future__ import annotations

import struct

from pirate_bt.errors import FrameError
from pirate_bt.link.messages import (
    _MODE_BY_CODE,
    Ack,
    AckStatus,
    BoardCounters,
    BridgeFlags,
    BridgeHeartbeat,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
)

__all__ = ["BadCrc", "OtherVersion", "StateLengthError", "UnknownAckStatus", "decode_fixed"]


class StateLengthError(FrameError):
    """A ``STATE`` frame (good CRC and version) whose payload is not the layout's length.

    A :class:`~pirate_bt.errors.FrameError` (reason ``length``) like any bad frame; it
    also carries both lengths, so that the session can tell a bridge of another layout
    (several in a row) from line noise that passed the CRC (one).
    """

    def __init__(self, received: int, expected: int) -> None:
        self.received = received
        self.expected = expected
        super().__init__("length", f"state payload {received} bytes, layout needs {expected}")

    def __reduce__(self) -> tuple[object, ...]:
        return (type(self), (self.received, self.expected))


class BadCrc(FrameError):
    """A frame whose CRC does not match (reason ``crc``), with the type byte it claims
    (``claimed_type``: unchecked, since the CRC failed), so that the session can tell
    a run of damaged ``STATE`` frames from silence."""

    def __init__(self, claimed_type: int, crc: int) -> None:
        self.claimed_type = claimed_type
        self.crc = crc
        super().__init__("crc", f"CRC mismatch (frame says {crc:#06x})")

    def __reduce__(self) -> tuple[object, ...]:
        return (type(self), (self.claimed_type, self.crc))


class OtherVersion(FrameError):
    """A frame (good CRC) of another protocol major version (reason ``version``), with
    the type byte it claims (``claimed_type``), so that the session can tell a run of
    ``STATE`` frames it refused from silence."""

    def __init__(self, claimed_type: int, version: int, expected: int) -> None:
        self.claimed_type = claimed_type
        self.version = version
        self.expected = expected
        super().__init__("version", f"protocol version {version}, expected {expected}")

    def __reduce__(self) -> tuple[object, ...]:
        return (type(self), (self.claimed_type, self.version, self.expected))


class UnknownAckStatus(FrameError):
    """An ``ACK`` (good CRC and version) whose status is not in the protocol's table, or
    a ``NACK`` (``answer="NACK"``) whose error code is not (reason ``value``), with the
    request it names, so that the session can tell a bridge answering a request in
    flight with it (a protocol mismatch) from noise."""

    def __init__(self, seq: int, acked_type: int, status: int, answer: str = "ACK") -> None:
        self.seq = seq
        self.acked_type = acked_type
        self.status = status
        self.answer = answer
        what = "ack status" if answer == "ACK" else "nack code"
        super().__init__("value", f"unknown {what} {status}")

    def __reduce__(self) -> tuple[object, ...]:
        return (type(self), (self.seq, self.acked_type, self.status, self.answer))


_HELLO = struct.Struct("<IB")
_HELLO_REPLY = struct.Struct("<IBBHHBHB")
_SETPOINT = struct.Struct("<BBh")
_ACK = struct.Struct("<BB")
_COUNTERS_HEAD = struct.Struct("<IIIII")
_BOARD_COUNTERS = struct.Struct("<BIII")
_ACK_STATUS: dict[int, AckStatus] = {int(s): s for s in AckStatus}
_FLAGS: tuple[BridgeFlags, ...] = tuple(BridgeFlags(i) for i in range(256))

_FIXED_PAYLOAD: dict[int, int] = {
    MsgType.HELLO: _HELLO.size,
    MsgType.SETPOINT: _SETPOINT.size,
    MsgType.HEARTBEAT: 0,
    MsgType.ESTOP: 0,
    MsgType.ESTOP_RESET: 0,
    MsgType.COUNTERS_REQUEST: 0,
    MsgType.HELLO_REPLY: _HELLO_REPLY.size,
    MsgType.ACK: _ACK.size,
    MsgType.NACK: _ACK.size,
    MsgType.BRIDGE_HEARTBEAT: 0,
}


def decode_fixed(kind: MsgType, seq: int, arg: int, payload: bytes) -> Message:
    """The message of a fixed-layout ``kind`` (anything but STATE and BULK_SETPOINTS).

    Raises:
        FrameError: ``length`` (the payload's size is not the type's) or ``value``
            (an unknown mode, ack status or nack code).
    """
    size = len(payload)
    if kind is MsgType.COUNTERS:
        head = _COUNTERS_HEAD.size
        if size < head or (size - head) % _BOARD_COUNTERS.size:
            raise FrameError("length", f"counters payload of {size} bytes")
        boards = tuple(BoardCounters(*vals) for vals in _BOARD_COUNTERS.iter_unpack(payload[head:]))
        rx, crc, framing, dups, trips = _COUNTERS_HEAD.unpack_from(payload)
        return Counters(seq, rx, crc, framing, dups, trips, boards)
    want = _FIXED_PAYLOAD[kind]
    if size != want:
        raise FrameError("length", f"{kind.name} payload {size} bytes, expected {want}")
    if kind is MsgType.HEARTBEAT:
        return Heartbeat(seq)
    if kind is MsgType.SETPOINT:
        slot, code, raw = _SETPOINT.unpack(payload)
        mode = _MODE_BY_CODE.get(code)
        if mode is None:
            raise FrameError("value", f"unknown mode code {code}")
        return Setpoint(seq, arg, slot, mode, raw)
    if kind is MsgType.ACK or kind is MsgType.NACK:
        acked, status = _ACK.unpack(payload)
        if kind is MsgType.ACK:
            ack_status = _ACK_STATUS.get(status)
            if ack_status is None:
                raise UnknownAckStatus(seq, acked, status)
            return Ack(seq, acked, ack_status)
        try:
            return Nack(seq, acked, NackCode(status))
        except ValueError:
            raise UnknownAckStatus(seq, acked, status, "NACK") from None
    if kind is MsgType.HELLO:
        return Hello(seq, *_HELLO.unpack(payload))
    if kind is MsgType.HELLO_REPLY:
        digest, n_ch, n_mo, wd_ms, firmware, minor, boot_id, sessions = _HELLO_REPLY.unpack(payload)
        return HelloReply(
            seq, digest, n_ch, n_mo, wd_ms, firmware, minor, boot_id, sessions, _FLAGS[arg]
        )
    if kind is MsgType.ESTOP:
        return EStop(seq)
    if kind is MsgType.ESTOP_RESET:
        return EStopReset(seq)
    if kind is MsgType.COUNTERS_REQUEST:
        return CountersRequest(seq)
    return BridgeHeartbeat(seq, _FLAGS[arg])
