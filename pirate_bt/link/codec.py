"""The PIRATEbay frame codec: messages <-> bytes, both directions, no I/O.

A frame on the wire is ``COBS(header + payload + crc) + 0x00``. The 0x00
delimiter lets a receiver that lost bytes resynchronise at the next zero; COBS
(Consistent Overhead Byte Stuffing) removes every zero from the body at a cost
of one byte for frames up to 254 bytes. The body is::

    offset  size  field
    0       1     version   protocol version (PROTOCOL_VERSION); stays at offset 0 forever
    1       1     type      MsgType; bit 7 set = bridge -> host
    2       2     seq       uint16 little-endian sequence number
    4       1     arg       board id (SETPOINT) or status flags (STATE, BRIDGE_HEARTBEAT), else 0
    5       n     payload   layout per type (see docs/protocol.md)
    5+n     2     crc       CRC-16/XMODEM of bytes [0, 5+n), little-endian

All integers are little-endian. ``docs/protocol.md`` is the byte-exact
specification; ``tests/data/link_vectors.json`` holds shared test vectors.

Two payloads depend on the robot: the STATE frame (one int16 per state channel,
a fresh bitmask, a 4-bit status per board) and the BULK_SETPOINTS frame (one
mode byte and one int16 per motor). Their sizes come from a :class:`WireLayout`
built from the robot description, so a :class:`FrameCodec` is made per robot::

    codec = FrameCodec(WireLayout.from_robot(robot))
    wire = codec.encode(Heartbeat(seq=7))          # bytes ready to write
    decoder = FrameDecoder(codec)
    for item in decoder.feed(chunk):               # Message or FrameError, never raises
        ...

Both ends use this module: the host encodes the host -> bridge messages
(:class:`Hello`, :class:`Setpoint`, :class:`BulkSetpoints`, :class:`Heartbeat`,
:class:`EStop`, :class:`EStopReset`, :class:`CountersRequest`) and decodes the
bridge -> host ones (:class:`HelloReply`, :class:`State`, :class:`Ack`,
:class:`Nack`, :class:`Counters`, :class:`BridgeHeartbeat`); a simulated bridge
does the opposite with the same :meth:`FrameCodec.encode` and
:class:`FrameDecoder`. :func:`seq_newer` is the serial-number comparison both ends
use for duplicates.

Hot-path choices: precompiled :class:`struct.Struct` objects, the C CRC in
:func:`binascii.crc_hqx`, and COBS done with :meth:`bytes.split` / ``bytes.join``
rather than a byte loop.
"""

from __future__ import annotations

import binascii
import itertools
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from enum import IntEnum, IntFlag
from typing import ClassVar

from pirate_bt.errors import FrameError
from pirate_bt.robot.description import ControlMode, RobotDescription

__all__ = [
    "HEADER_BYTES",
    "MAX_BODY_BYTES",
    "MAX_PAYLOAD_BYTES",
    "MAX_WIRE_BYTES",
    "MODE_CODES",
    "MODE_KEEP",
    "PROTOCOL_VERSION",
    "Ack",
    "AckStatus",
    "BoardCounters",
    "BoardStatus",
    "BridgeFlags",
    "BridgeHeartbeat",
    "BulkSetpoints",
    "Counters",
    "CountersRequest",
    "EStop",
    "EStopReset",
    "FrameCodec",
    "FrameDecoder",
    "Heartbeat",
    "Hello",
    "HelloReply",
    "Message",
    "MsgType",
    "Nack",
    "NackCode",
    "Setpoint",
    "State",
    "WireLayout",
    "byte_time_s",
    "cobs_decode",
    "cobs_encode",
    "crc16",
    "frame_time_s",
    "seq_newer",
]

PROTOCOL_VERSION = 1
"""Protocol version carried in byte 0 of every frame."""

HEADER_BYTES = 5
MAX_BODY_BYTES = 254
"""Largest body (header + payload + CRC) before COBS; COBS then adds exactly one byte."""
MAX_PAYLOAD_BYTES = MAX_BODY_BYTES - HEADER_BYTES - 2
MAX_WIRE_BYTES = MAX_BODY_BYTES + 2
"""Largest frame on the wire: COBS overhead byte and the 0x00 delimiter included."""

_HEADER = struct.Struct("<BBHB")
_CRC = struct.Struct("<H")
_U16 = struct.Struct("<H")
_HELLO = struct.Struct("<I")
_HELLO_REPLY = struct.Struct("<IBBHH")
_SETPOINT = struct.Struct("<BBh")
_ACK = struct.Struct("<BB")
_COUNTERS_HEAD = struct.Struct("<IIIII")
_BOARD_COUNTERS = struct.Struct("<BIII")


class MsgType(IntEnum):
    """Message type codes; bit 7 set means the bridge sent it."""

    HELLO = 0x01
    SETPOINT = 0x02
    BULK_SETPOINTS = 0x03
    HEARTBEAT = 0x04
    ESTOP = 0x05
    ESTOP_RESET = 0x06
    COUNTERS_REQUEST = 0x07
    HELLO_REPLY = 0x81
    STATE = 0x82
    ACK = 0x83
    NACK = 0x84
    COUNTERS = 0x85
    BRIDGE_HEARTBEAT = 0x86


class AckStatus(IntEnum):
    """What the bridge did with an acknowledged request."""

    APPLIED = 0
    """First copy: the request took effect."""
    DUPLICATE = 1
    """Same sequence number as the last applied request: not applied again."""
    STALE = 2
    """Older than the last applied request: not applied (a newer one overtook it)."""


class NackCode(IntEnum):
    """Why the bridge refused a request."""

    UNKNOWN_TYPE = 1
    BAD_LENGTH = 2
    BAD_LAYOUT = 3
    BAD_BOARD = 4
    BAD_SLOT = 5
    BAD_MODE = 6
    OUT_OF_RANGE = 7
    ESTOP_LATCHED = 8
    BUS_ERROR = 9
    NOT_READY = 10


class BridgeFlags(IntFlag):
    """Bridge status bits in the ``arg`` byte of STATE and BRIDGE_HEARTBEAT frames."""

    NONE = 0
    ESTOP = 0x01
    """The e-stop is latched: all motors off until ESTOP_RESET."""
    WATCHDOG = 0x02
    """The host was silent for the watchdog period: drives stopped, clamps held."""
    BUS_FAULT = 0x04
    """The RS485 bus failed a whole poll cycle."""


class BoardStatus(IntFlag):
    """Per-board status nibble in the STATE frame."""

    NONE = 0
    ONLINE = 0x1
    """The board answered its last poll."""
    FAULT = 0x2
    """The board reports an H-bridge fault or over-current."""
    TIMEOUT = 0x4
    """The board missed its last poll (its readings are not fresh)."""
    MOTORS_OFF = 0x8
    """The board's motors are switched off (e-stop or watchdog)."""


MODE_CODES: dict[ControlMode, int] = {
    ControlMode.PWM: 0,
    ControlMode.TORQUE: 1,
    ControlMode.POSITION: 2,
    ControlMode.VELOCITY: 3,
}
"""Wire code of each control mode."""
MODE_KEEP = 0xFF
"""BULK_SETPOINTS mode code meaning "leave this motor as it is" (``None`` in Python)."""
_MODE_BY_CODE: dict[int, ControlMode] = {v: k for k, v in MODE_CODES.items()}


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
    if len(data) < 254:
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


# --- messages -------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Hello:
    """Host -> bridge: start a session; the bridge answers with :class:`HelloReply`.

    The bridge resets its duplicate filter to ``seq`` and counters stay as they are.
    """

    TYPE: ClassVar[MsgType] = MsgType.HELLO
    seq: int
    layout_digest: int


@dataclass(frozen=True, slots=True)
class Setpoint:
    """Host -> bridge: one motor's setpoint. ``mode`` is never ``None`` here."""

    TYPE: ClassVar[MsgType] = MsgType.SETPOINT
    seq: int
    board: int
    slot: int
    mode: ControlMode
    raw_value: int


@dataclass(frozen=True, slots=True)
class BulkSetpoints:
    """Host -> bridge: every motor in layout order; ``None`` mode = keep that motor as it is.

    Acknowledged by the ``ack_seq`` field of the next :class:`State` frame (or a
    :class:`Nack`), not by an :class:`Ack` frame, to keep the 100 Hz cycle small.
    """

    TYPE: ClassVar[MsgType] = MsgType.BULK_SETPOINTS
    seq: int
    modes: tuple[ControlMode | None, ...]
    raw_values: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class Heartbeat:
    """Host -> bridge: "I am alive"; feeds the watchdog; answered with an :class:`Ack`."""

    TYPE: ClassVar[MsgType] = MsgType.HEARTBEAT
    seq: int


@dataclass(frozen=True, slots=True)
class EStop:
    """Host -> bridge: latch the e-stop (all motors off). Always applied, whatever ``seq``."""

    TYPE: ClassVar[MsgType] = MsgType.ESTOP
    seq: int


@dataclass(frozen=True, slots=True)
class EStopReset:
    """Host -> bridge: release a latched e-stop (operator action)."""

    TYPE: ClassVar[MsgType] = MsgType.ESTOP_RESET
    seq: int


@dataclass(frozen=True, slots=True)
class CountersRequest:
    """Host -> bridge: ask for :class:`Counters` (sent back with the same ``seq``)."""

    TYPE: ClassVar[MsgType] = MsgType.COUNTERS_REQUEST
    seq: int


@dataclass(frozen=True, slots=True)
class HelloReply:
    """Bridge -> host: answer to :class:`Hello` (same ``seq``), with the bridge's layout."""

    TYPE: ClassVar[MsgType] = MsgType.HELLO_REPLY
    seq: int
    layout_digest: int
    n_channels: int
    n_motors: int
    watchdog_ms: int
    firmware: int = 0


@dataclass(frozen=True, slots=True)
class State:
    """Bridge -> host: every state channel in one frame, sent every state period.

    Attributes:
        seq: The bridge's own frame counter (out-of-date frames are detected with it).
        flags: :class:`BridgeFlags`.
        ack_seq: ``seq`` of the last BULK_SETPOINTS the bridge accepted (0 before any).
        fresh_mask: Bit ``i`` set = channel ``i`` holds a fresh reading.
        board_status: One :class:`BoardStatus` nibble per board, in board-id order.
        raw_values: One int16 per channel in layout order (meaningless where not fresh).
    """

    TYPE: ClassVar[MsgType] = MsgType.STATE
    seq: int
    flags: BridgeFlags
    ack_seq: int
    fresh_mask: int
    board_status: tuple[int, ...]
    raw_values: tuple[int, ...]

    def readings(self) -> list[int | None]:
        """The raw values with ``None`` where the channel is not fresh."""
        mask = self.fresh_mask
        return [v if (mask >> i) & 1 else None for i, v in enumerate(self.raw_values)]


@dataclass(frozen=True, slots=True)
class Ack:
    """Bridge -> host: request ``seq`` (of type ``acked_type``) was received intact."""

    TYPE: ClassVar[MsgType] = MsgType.ACK
    seq: int
    acked_type: int
    status: AckStatus = AckStatus.APPLIED


@dataclass(frozen=True, slots=True)
class Nack:
    """Bridge -> host: request ``seq`` was refused with ``error``; it had no effect."""

    TYPE: ClassVar[MsgType] = MsgType.NACK
    seq: int
    acked_type: int
    error: NackCode


@dataclass(frozen=True, slots=True)
class BoardCounters:
    """RS485 figures for one PICO board, since the bridge started."""

    board: int
    timeouts: int = 0
    crc_errors: int = 0
    retries: int = 0


@dataclass(frozen=True, slots=True)
class Counters:
    """Bridge -> host: the bridge's error counters, answer to :class:`CountersRequest`."""

    TYPE: ClassVar[MsgType] = MsgType.COUNTERS
    seq: int
    rx_frames: int = 0
    crc_errors: int = 0
    frame_errors: int = 0
    duplicates: int = 0
    watchdog_trips: int = 0
    boards: tuple[BoardCounters, ...] = field(default=())


@dataclass(frozen=True, slots=True)
class BridgeHeartbeat:
    """Bridge -> host: sent when the bridge has sent nothing for a heartbeat period."""

    TYPE: ClassVar[MsgType] = MsgType.BRIDGE_HEARTBEAT
    seq: int
    flags: BridgeFlags = BridgeFlags.NONE


Message = (
    Hello
    | Setpoint
    | BulkSetpoints
    | Heartbeat
    | EStop
    | EStopReset
    | CountersRequest
    | HelloReply
    | State
    | Ack
    | Nack
    | Counters
    | BridgeHeartbeat
)
"""Any decoded frame."""


# --- layout ---------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class WireLayout:
    """The robot-dependent sizes of the STATE and BULK_SETPOINTS payloads.

    Attributes:
        n_channels: int16 channels in the state frame.
        n_motors: Motors in the bulk setpoint frame.
        n_boards: Boards (one status nibble each).
        digest: 32-bit layout digest both ends compare at hello time.
    """

    n_channels: int
    n_motors: int
    n_boards: int
    digest: int

    @classmethod
    def from_robot(cls, robot: RobotDescription) -> WireLayout:
        """The layout of ``robot``'s wire frames.

        Args:
            robot: A validated robot description.

        Returns:
            Its wire layout.

        Raises:
            ValueError: the state or bulk frame would exceed the maximum frame size.
        """
        return cls(
            n_channels=len(robot.state_channels()),
            n_motors=len(robot.setpoint_slots()),
            n_boards=len(robot.board_ids()),
            digest=robot.layout_digest(),
        )

    def __post_init__(self) -> None:
        if self.state_payload_bytes > MAX_PAYLOAD_BYTES:
            raise ValueError(
                f"{self.n_channels} channels and {self.n_boards} boards need a "
                f"{self.state_payload_bytes}-byte state payload (max {MAX_PAYLOAD_BYTES})"
            )
        if self.bulk_payload_bytes > MAX_PAYLOAD_BYTES:
            raise ValueError(f"{self.n_motors} motors do not fit one bulk setpoint frame")

    @property
    def mask_bytes(self) -> int:
        """Bytes of the fresh bitmask: ceil(n_channels / 8)."""
        return (self.n_channels + 7) // 8

    @property
    def status_bytes(self) -> int:
        """Bytes of board status: ceil(n_boards / 2), two nibbles per byte."""
        return (self.n_boards + 1) // 2

    @property
    def state_payload_bytes(self) -> int:
        """STATE payload: ack_seq, fresh mask, board status, channels."""
        return 2 + self.mask_bytes + self.status_bytes + 2 * self.n_channels

    @property
    def bulk_payload_bytes(self) -> int:
        """BULK_SETPOINTS payload: one mode byte and one int16 per motor."""
        return 3 * self.n_motors

    def wire_bytes(self, payload_bytes: int) -> int:
        """Worst-case wire size of a frame with ``payload_bytes`` of payload.

        Args:
            payload_bytes: Payload size.

        Returns:
            Header + payload + CRC + COBS overhead + delimiter.
        """
        body = HEADER_BYTES + payload_bytes + 2
        return body + (body + 253) // 254 + 1


_TYPE_BY_CODE: dict[int, MsgType] = {int(t): t for t in MsgType}
_STATE_CODE = int(MsgType.STATE)
_ACK_STATUS: dict[int, AckStatus] = {int(s): s for s in AckStatus}
_STATUS_CACHE = 64
"""Distinct board-status patterns a codec remembers (bounded, for a misbehaving peer)."""
_new_object = object.__new__
_SET_STATE_SEQ = State.__dict__["seq"].__set__
_SET_STATE_FLAGS = State.__dict__["flags"].__set__
_SET_STATE_ACK_SEQ = State.__dict__["ack_seq"].__set__
_SET_STATE_FRESH_MASK = State.__dict__["fresh_mask"].__set__
_SET_STATE_BOARD_STATUS = State.__dict__["board_status"].__set__
_SET_STATE_RAW_VALUES = State.__dict__["raw_values"].__set__
_FLAGS: tuple[BridgeFlags, ...] = tuple(BridgeFlags(i) for i in range(256))
_NIBBLES: tuple[tuple[int, int], ...] = tuple((b & 0xF, b >> 4) for b in range(256))

# --- codec ----------------------------------------------------------------------------------

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


class FrameCodec:
    """Encodes and decodes frames for one wire layout. Stateless and thread-safe.

    Args:
        layout: The robot's wire layout (sizes of STATE and BULK_SETPOINTS).
    """

    def __init__(self, layout: WireLayout) -> None:
        self.layout = layout
        n, m = layout.n_channels, layout.n_motors
        self._state = struct.Struct(f"<H{layout.mask_bytes}s{layout.status_bytes}s{n}h")
        self._bulk = struct.Struct("<" + "Bh" * m)
        self._channels = range(n)
        # The STATE frame is most of the traffic (every 10 ms), so it has its own paths:
        # one Struct for header + payload (one pack / one unpack instead of four), the
        # masks precomputed, and the board-status bytes cached both ways, since the
        # status of the boards rarely changes from one frame to the next.
        self._state_body = struct.Struct(f"<BBHBH{layout.mask_bytes}s{layout.status_bytes}s{n}h")
        self._state_body_bytes = self._state_body.size + 2
        self._mask_all = (1 << n) - 1
        self._mask_bytes = layout.mask_bytes
        self._n_boards = layout.n_boards
        self._status_to_wire: dict[tuple[int, ...], bytes] = {}
        self._status_from_wire: dict[bytes, tuple[int, ...]] = {}
        self._state_key: tuple[object, ...] | None = None
        self._state_rest = b""
        self._state_last: State | None = None
        self._state_template = bytearray()

    @classmethod
    def for_robot(cls, robot: RobotDescription) -> FrameCodec:
        """A codec for ``robot``'s layout.

        Args:
            robot: A validated robot description.

        Returns:
            The codec.
        """
        return cls(WireLayout.from_robot(robot))

    # encode ------------------------------------------------------------------------------

    def encode(self, msg: Message) -> bytes:
        """The wire bytes of ``msg``: COBS-encoded body followed by the 0x00 delimiter.

        Args:
            msg: Any message.

        Returns:
            Bytes ready to write to the line.

        Raises:
            ValueError: a field is out of range for its wire type, or a layout-dependent
                message does not match this codec's layout.
        """
        if type(msg) is State:
            body = self._state_body_of(msg)
        elif type(msg) is Heartbeat or type(msg) is Ack:
            # A heartbeat and its ack every few state periods: header (+ two bytes)
            # packed here, without the isinstance chain of encode_payload.
            try:
                body = _HEADER.pack(PROTOCOL_VERSION, msg.TYPE, msg.seq, 0)
                if type(msg) is Ack:
                    body += _ACK.pack(msg.acked_type, msg.status)
            except struct.error as exc:
                raise ValueError(f"cannot encode {msg!r}: {exc}") from None
        else:
            arg, payload = self.encode_payload(msg)
            try:
                body = _HEADER.pack(PROTOCOL_VERSION, msg.TYPE, msg.seq, arg) + payload
            except struct.error as exc:
                raise ValueError(f"cannot encode {msg!r}: {exc}") from None
        body += _CRC.pack(binascii.crc_hqx(body, 0))
        return cobs_encode(body) + b"\x00"

    def encode_state(
        self,
        seq: int,
        flags: BridgeFlags,
        ack_seq: int,
        fresh_mask: int,
        board_status: tuple[int, ...],
        raw_values: tuple[int, ...],
    ) -> bytes:
        """The wire bytes of ``State(seq, flags, ack_seq, fresh_mask, board_status, raw_values)``.

        Same bytes as :meth:`encode` of that message, without building it: a simulated
        bridge sends one every state period and most differ from the previous one only
        in ``seq``.

        Args:
            seq: Frame sequence number.
            flags: Bridge flags.
            ack_seq: Last host sequence number applied.
            fresh_mask: Bit per channel whose value is fresh.
            board_status: Status nibble per board.
            raw_values: Raw value per state channel.

        Returns:
            Bytes ready to write to the line.

        Raises:
            ValueError: see :meth:`encode`.
        """
        # The packed body without the seq is kept and reused while the other fields are
        # equal (one C-level tuple comparison, items compared by identity first), so an
        # unchanged frame costs a two-byte patch, the CRC and COBS instead of a 30-field
        # pack and a State object.
        key = (flags, ack_seq, fresh_mask, board_status, raw_values)
        if key != self._state_key:
            self._state_template = bytearray(
                self._state_body_of(State(0, flags, ack_seq, fresh_mask, board_status, raw_values))
            )
            self._state_key = key
        body = self._state_template
        if not 0 <= seq <= 0xFFFF:
            raise ValueError(f"cannot encode state seq {seq}")
        body[2] = seq & 0xFF
        body[3] = seq >> 8
        return cobs_encode(bytes(body) + _CRC.pack(binascii.crc_hqx(body, 0))) + b"\x00"

    def _status_wire(self, board_status: tuple[int, ...]) -> bytes:
        """The board-status bytes of a STATE frame, cached (checked once per distinct tuple)."""
        wire = self._status_to_wire.get(board_status)
        if wire is None:
            status = bytearray(self.layout.status_bytes)
            for i, nib in enumerate(board_status):
                if not 0 <= nib <= 0xF:
                    raise ValueError(f"board status {nib} is not a nibble")
                status[i >> 1] |= nib << (4 * (i & 1))
            wire = bytes(status)
            if len(self._status_to_wire) >= _STATUS_CACHE:
                self._status_to_wire.clear()
            self._status_to_wire[board_status] = wire
        return wire

    def _state_body_of(self, msg: State) -> bytes:
        """Header + payload of a STATE frame in one pack (the CRC is added by the caller)."""
        if len(msg.raw_values) != self.layout.n_channels or len(msg.board_status) != self._n_boards:
            raise ValueError("state frame does not match the layout")
        mask = (msg.fresh_mask & self._mask_all).to_bytes(self._mask_bytes, "little")
        try:
            return self._state_body.pack(
                PROTOCOL_VERSION,
                MsgType.STATE,
                msg.seq,
                msg.flags,
                msg.ack_seq,
                mask,
                self._status_wire(msg.board_status),
                *msg.raw_values,
            )
        except struct.error as exc:
            raise ValueError(f"cannot encode {msg!r}: {exc}") from None

    def encode_payload(self, msg: Message) -> tuple[int, bytes]:
        """The header ``arg`` byte and the payload of ``msg`` (no header, CRC or COBS).

        Args:
            msg: Any message.

        Returns:
            ``(arg, payload)``.

        Raises:
            ValueError: see :meth:`encode`.
        """
        try:
            return self._encode_payload(msg)
        except struct.error as exc:
            raise ValueError(f"cannot encode {msg!r}: {exc}") from None

    def _encode_payload(self, msg: Message) -> tuple[int, bytes]:
        if isinstance(msg, State):
            lay = self.layout
            if len(msg.raw_values) != lay.n_channels or len(msg.board_status) != lay.n_boards:
                raise ValueError("state frame does not match the layout")
            status = self._status_wire(msg.board_status)
            mask = (msg.fresh_mask & self._mask_all).to_bytes(lay.mask_bytes, "little")
            payload = self._state.pack(msg.ack_seq, mask, status, *msg.raw_values)
            return int(msg.flags), payload
        if isinstance(msg, BulkSetpoints):
            if len(msg.modes) != self.layout.n_motors or len(msg.raw_values) != len(msg.modes):
                raise ValueError("bulk setpoint frame does not match the layout")
            flat: list[int] = []
            for mode, raw in zip(msg.modes, msg.raw_values, strict=True):
                flat.append(MODE_KEEP if mode is None else MODE_CODES[mode])
                flat.append(raw)
            return 0, self._bulk.pack(*flat)
        if isinstance(msg, Setpoint):
            return msg.board, _SETPOINT.pack(msg.slot, MODE_CODES[msg.mode], msg.raw_value)
        if isinstance(msg, Heartbeat | EStop | EStopReset | CountersRequest):
            return 0, b""
        if isinstance(msg, BridgeHeartbeat):
            return int(msg.flags), b""
        if isinstance(msg, Hello):
            return 0, _HELLO.pack(msg.layout_digest)
        if isinstance(msg, HelloReply):
            return 0, _HELLO_REPLY.pack(
                msg.layout_digest, msg.n_channels, msg.n_motors, msg.watchdog_ms, msg.firmware
            )
        if isinstance(msg, Ack):
            return 0, _ACK.pack(msg.acked_type, msg.status)
        if isinstance(msg, Nack):
            return 0, _ACK.pack(msg.acked_type, msg.error)
        if isinstance(msg, Counters):
            parts = [
                _COUNTERS_HEAD.pack(
                    msg.rx_frames,
                    msg.crc_errors,
                    msg.frame_errors,
                    msg.duplicates,
                    msg.watchdog_trips,
                )
            ]
            parts += [
                _BOARD_COUNTERS.pack(b.board, b.timeouts, b.crc_errors, b.retries)
                for b in msg.boards
            ]
            payload = b"".join(parts)
            if len(payload) > MAX_PAYLOAD_BYTES:
                raise ValueError(f"{len(msg.boards)} boards do not fit one counters frame")
            return 0, payload
        raise ValueError(f"not a message: {msg!r}")  # pragma: no cover - exhaustive above

    # decode ------------------------------------------------------------------------------

    def decode(self, encoded: bytes) -> Message:
        """Decode one frame's COBS bytes (without the 0x00 delimiter).

        Args:
            encoded: The bytes between two delimiters.

        Returns:
            The message.

        Raises:
            FrameError: with ``reason`` one of ``oversize``, ``cobs``, ``short``, ``crc``,
                ``version``, ``type``, ``length``, ``value`` (see docs/protocol.md).
        """
        if len(encoded) > MAX_WIRE_BYTES - 1:
            raise FrameError("oversize", f"{len(encoded)} bytes before the delimiter")
        return self.decode_body(cobs_decode(encoded))

    def _state_from_body(self, body: bytes) -> State:
        """A STATE frame whose length and CRC are checked, from one unpack of its body."""
        # Consecutive STATE frames mostly differ only in their seq (bytes 2-3) and CRC:
        # then the fields decoded last time are reused (immutable, so shared safely)
        # and only the seq is read.
        rest = body[4:-2]
        if rest == self._state_rest and body[0] == PROTOCOL_VERSION:
            last = self._state_last
            assert last is not None  # set together with _state_rest
            msg: State = _new_object(State)
            _SET_STATE_SEQ(msg, body[2] | body[3] << 8)
            _SET_STATE_FLAGS(msg, last.flags)
            _SET_STATE_ACK_SEQ(msg, last.ack_seq)
            _SET_STATE_FRESH_MASK(msg, last.fresh_mask)
            _SET_STATE_BOARD_STATUS(msg, last.board_status)
            _SET_STATE_RAW_VALUES(msg, last.raw_values)
            return msg
        fields = self._state_body.unpack_from(body)
        if fields[0] != PROTOCOL_VERSION:
            raise FrameError(
                "version", f"protocol version {fields[0]}, expected {PROTOCOL_VERSION}"
            )
        nibbles = self._status_from_wire.get(fields[6])
        if nibbles is None:
            nibbles = tuple(itertools.chain.from_iterable(map(_NIBBLES.__getitem__, fields[6])))
            nibbles = nibbles[: self._n_boards]
            if len(self._status_from_wire) >= _STATUS_CACHE:
                self._status_from_wire.clear()
            self._status_from_wire[fields[6]] = nibbles
        # A frozen dataclass's __init__ sets each field through object.__setattr__; the
        # slot descriptors do the same work in half the time (same class, same fields).
        msg = _new_object(State)
        _SET_STATE_SEQ(msg, fields[2])
        _SET_STATE_FLAGS(msg, _FLAGS[fields[3]])
        _SET_STATE_ACK_SEQ(msg, fields[4])
        _SET_STATE_FRESH_MASK(msg, int.from_bytes(fields[5], "little") & self._mask_all)
        _SET_STATE_BOARD_STATUS(msg, nibbles)
        _SET_STATE_RAW_VALUES(msg, fields[7:])
        self._state_rest = rest
        self._state_last = msg
        return msg

    def decode_body(self, body: bytes) -> Message:
        """Decode a frame body (after COBS decoding): header, payload and CRC.

        Args:
            body: Header + payload + CRC.

        Returns:
            The message.

        Raises:
            FrameError: see :meth:`decode`.
        """
        n = len(body)
        if n < HEADER_BYTES + 2:
            raise FrameError("short", f"{n} bytes, need at least {HEADER_BYTES + 2}")
        if n > MAX_BODY_BYTES:
            raise FrameError("oversize", f"{n}-byte body (max {MAX_BODY_BYTES})")
        (crc,) = _CRC.unpack_from(body, n - 2)
        if binascii.crc_hqx(memoryview(body)[: n - 2], 0) != crc:
            raise FrameError("crc", f"CRC mismatch (frame says {crc:#06x})")
        if body[1] == _STATE_CODE and n == self._state_body_bytes:
            return self._state_from_body(body)
        version, code, seq, arg = _HEADER.unpack_from(body)
        if version != PROTOCOL_VERSION:
            raise FrameError("version", f"protocol version {version}, expected {PROTOCOL_VERSION}")
        payload = body[HEADER_BYTES : n - 2]
        kind = _TYPE_BY_CODE.get(code)
        if kind is None:
            raise FrameError("type", f"unknown message type {code:#04x}")
        return self._decode_payload(kind, seq, arg, payload)

    def _decode_payload(self, kind: MsgType, seq: int, arg: int, payload: bytes) -> Message:
        size = len(payload)
        if kind is MsgType.STATE:
            lay = self.layout
            if size != lay.state_payload_bytes:
                raise FrameError(
                    "length", f"state payload {size} bytes, layout needs {lay.state_payload_bytes}"
                )
            ack_seq, mask, status, *values = self._state.unpack(payload)
            nibbles = tuple(itertools.chain.from_iterable(map(_NIBBLES.__getitem__, status)))
            return State(
                seq,
                _FLAGS[arg],
                ack_seq,
                int.from_bytes(mask, "little") & ((1 << lay.n_channels) - 1),
                nibbles[: lay.n_boards],
                tuple(values),
            )
        if kind is MsgType.BULK_SETPOINTS:
            if size != self.layout.bulk_payload_bytes:
                raise FrameError(
                    "length",
                    f"bulk payload {size} bytes, layout needs {self.layout.bulk_payload_bytes}",
                )
            flat = self._bulk.unpack(payload)
            modes: list[ControlMode | None] = []
            for code in flat[0::2]:
                if code == MODE_KEEP:
                    modes.append(None)
                else:
                    mode = _MODE_BY_CODE.get(code)
                    if mode is None:
                        raise FrameError("value", f"unknown mode code {code}")
                    modes.append(mode)
            return BulkSetpoints(seq, tuple(modes), tuple(flat[1::2]))
        if kind is MsgType.COUNTERS:
            head = _COUNTERS_HEAD.size
            if size < head or (size - head) % _BOARD_COUNTERS.size:
                raise FrameError("length", f"counters payload of {size} bytes")
            boards = tuple(
                BoardCounters(*vals) for vals in _BOARD_COUNTERS.iter_unpack(payload[head:])
            )
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
                    raise FrameError("value", f"unknown ack status {status}")
                return Ack(seq, acked, ack_status)
            try:
                return Nack(seq, acked, NackCode(status))
            except ValueError:
                raise FrameError("value", f"unknown nack code {status}") from None
        if kind is MsgType.HELLO:
            return Hello(seq, *_HELLO.unpack(payload))
        if kind is MsgType.HELLO_REPLY:
            return HelloReply(seq, *_HELLO_REPLY.unpack(payload))
        if kind is MsgType.ESTOP:
            return EStop(seq)
        if kind is MsgType.ESTOP_RESET:
            return EStopReset(seq)
        if kind is MsgType.COUNTERS_REQUEST:
            return CountersRequest(seq)
        return BridgeHeartbeat(seq, _FLAGS[arg])


class FrameDecoder:
    """Streaming decoder: feed it bytes as they arrive, get messages and frame errors back.

    Bytes are collected up to each 0x00 delimiter. A frame longer than the maximum
    is reported once as ``oversize`` and skipped up to the next delimiter, so a
    lost delimiter costs at most two frames. Empty frames (two delimiters in a row,
    which a sender may use to flush the line) are ignored silently.

    Args:
        codec: The codec for the robot's layout.
    """

    def __init__(self, codec: FrameCodec) -> None:
        self.codec = codec
        self._buf = bytearray()
        self._overflow = False

    def reset(self) -> None:
        """Forget any partial frame (after draining stale bytes)."""
        self._buf.clear()
        self._overflow = False

    @property
    def pending_bytes(self) -> int:
        """Bytes of an unfinished frame held."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[Message | FrameError]:
        """Add received bytes; return every frame they complete, in order.

        Never raises for any input: a bad frame comes back as a :class:`FrameError`.

        Args:
            data: Bytes read from the line (any length, any content).

        Returns:
            Decoded messages and frame errors, in arrival order.
        """
        out: list[Message | FrameError] = []
        if not data:
            return out
        # A plain loop filling a list, with the codec's two steps called directly: a
        # generator and the extra decode() layer cost about a microsecond per frame.
        decode_body = self.codec.decode_body
        parts = data.split(b"\x00")
        limit = MAX_WIRE_BYTES - 1
        for part in parts[:-1]:
            if self._overflow:
                self._overflow = False
                self._buf.clear()
                continue
            if self._buf:
                self._buf += part
                frame = bytes(self._buf)
                self._buf.clear()
            else:
                frame = part
            if not frame:
                continue
            if len(frame) > limit:
                out.append(FrameError("oversize", f"{len(frame)} bytes before the delimiter"))
                continue
            try:
                out.append(decode_body(cobs_decode(frame)))
            except FrameError as exc:
                out.append(exc)
            except Exception as exc:  # defensive: the decoder contract is FrameError only
                out.append(FrameError("internal", f"{type(exc).__name__}: {exc}"))
        tail = parts[-1]
        if self._overflow:
            return out
        self._buf += tail
        if len(self._buf) > limit:
            self._buf.clear()
            self._overflow = True
            out.append(FrameError("oversize", f"more than {limit} bytes without a delimiter"))
        return out

    def iter_feed(self, data: bytes) -> Iterator[Message | FrameError]:
        """Like :meth:`feed`, as an iterator (the bytes are all decoded at the first step)."""
        return iter(self.feed(data))


def encode_many(codec: FrameCodec, msgs: Sequence[Message]) -> bytes:
    """Concatenate the wire bytes of several messages (tests and simulators)."""
    return b"".join(codec.encode(m) for m in msgs)
