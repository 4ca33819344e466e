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

from pirate_bt.errors import FrameError

# Re-exported here: the decoder was part of this module. decoder.py sits below this
# one (it never imports it), so the arrow runs one way.
from pirate_bt.link.decoder import FrameDecoder, encode_many
from pirate_bt.link.framing import (
    HEADER_BYTES,
    MAX_BODY_BYTES,
    MAX_PAYLOAD_BYTES,
    MAX_WIRE_BYTES,
    PROTOCOL_MINOR,
    PROTOCOL_MINOR_MAX,
    PROTOCOL_VERSION,
    byte_time_s,
    cobs_decode,
    cobs_encode,
    crc16,
    frame_time_s,
    seq_newer,
)
from pirate_bt.link.layout import WireLayout
from pirate_bt.link.messages import (
    _MODE_BY_CODE,
    MODE_CODES,
    MODE_KEEP,
    Ack,
    AckStatus,
    BoardCounters,
    BoardStatus,
    BridgeFlags,
    BridgeHeartbeat,
    BulkSetpoints,
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
    State,
)
from pirate_bt.link.payloads import (
    _ACK,
    _BOARD_COUNTERS,
    _COUNTERS_HEAD,
    _FLAGS,
    _HELLO,
    _HELLO_REPLY,
    _SETPOINT,
    BadCrc,
    OtherVersion,
    StateLengthError,
    UnknownAckStatus,
    decode_fixed,
)
from pirate_bt.robot.description import ControlMode, RobotDescription

__all__ = [
    "HEADER_BYTES",
    "MAX_BODY_BYTES",
    "MAX_PAYLOAD_BYTES",
    "MAX_WIRE_BYTES",
    "MODE_CODES",
    "MODE_KEEP",
    "PROTOCOL_MINOR",
    "PROTOCOL_MINOR_MAX",
    "PROTOCOL_VERSION",
    "Ack",
    "AckStatus",
    "BadCrc",
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
    "OtherVersion",
    "Setpoint",
    "State",
    "StateLengthError",
    "UnknownAckStatus",
    "WireLayout",
    "byte_time_s",
    "cobs_decode",
    "cobs_encode",
    "crc16",
    "encode_many",
    "frame_time_s",
    "seq_newer",
]

_HEADER = struct.Struct("<BBHB")
_CRC = struct.Struct("<H")
_U16 = struct.Struct("<H")


_TYPE_BY_CODE: dict[int, MsgType] = {int(t): t for t in MsgType}
_STATE_CODE = int(MsgType.STATE)
_STATUS_CACHE = 64
"""Distinct board-status patterns a codec remembers (bounded, for a misbehaving peer)."""
_new_object = object.__new__
_SET_STATE_SEQ = State.__dict__["seq"].__set__
_SET_STATE_FLAGS = State.__dict__["flags"].__set__
_SET_STATE_ACK_SEQ = State.__dict__["ack_seq"].__set__
_SET_STATE_FRESH_MASK = State.__dict__["fresh_mask"].__set__
_SET_STATE_BOARD_STATUS = State.__dict__["board_status"].__set__
_SET_STATE_RAW_VALUES = State.__dict__["raw_values"].__set__
_NIBBLES: tuple[tuple[int, int], ...] = tuple((b & 0xF, b >> 4) for b in range(256))

# --- codec ----------------------------------------------------------------------------------


class FrameCodec:
    """Encodes and decodes frames for one wire layout.

    :meth:`encode` and :meth:`encode_payload` may be called from any thread.
    :meth:`encode_state` and the decoding of a ``STATE`` frame each keep the last
    frame to reuse its bytes or fields, so each belongs to one thread at a time: one
    sender of STATE frames (a bridge) and one decoding thread (a session's reader)
    per codec.

    Args:
        layout: The robot's wire layout (sizes of STATE and BULK_SETPOINTS).
    """

    def __init__(self, layout: WireLayout) -> None:
        self.layout = layout
        n, m = layout.n_channels, layout.n_motors
        self._state = struct.Struct(f"<H{layout.mask_bytes}s{layout.status_bytes}s{n}h")
        self._bulk = struct.Struct("<" + "Bh" * m)
        # The STATE frame is most of the traffic (every 10 ms), so it has its own paths:
        # one Struct for header + payload (one pack / one unpack instead of four), the
        # masks precomputed, and the board-status bytes cached both ways, since the
        # status of the boards rarely changes from one frame to the next.
        self._state_body = struct.Struct(f"<BBHBH{layout.mask_bytes}s{layout.status_bytes}s{n}h")
        self._state_body_bytes = self._state_body.size + 2  # pragma: no mutate (a fast path)
        self._mask_all = (1 << n) - 1
        self._mask_bytes = layout.mask_bytes
        self._n_boards = layout.n_boards
        self._status_to_wire: dict[tuple[int, ...], bytes] = {}
        self._status_from_wire: dict[bytes, tuple[int, ...]] = {}
        # The caches start empty: whatever these hold first, the first frame misses them.
        self._state_key: tuple[object, ...] | None = None  # pragma: no mutate (a cache)
        self._state_rest = b""  # pragma: no mutate (a cache)
        self._state_last: State | None = None  # pragma: no mutate (a cache)
        self._state_template = bytearray()  # pragma: no mutate (a cache)

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
        # Fast paths for the frequent frames; encode_payload gives the same bytes.
        if type(msg) is State:  # pragma: no mutate (a fast path)
            body = self._state_body_of(msg)
        elif type(msg) is Heartbeat or type(msg) is Ack:  # pragma: no mutate (a fast path)
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
            template = State(
                0,  # pragma: no mutate (the seq bytes are written below, per frame)
                flags,
                ack_seq,
                fresh_mask,
                board_status,
                raw_values,
            )
            self._state_template = bytearray(self._state_body_of(template))
            self._state_key = key  # pragma: no mutate (a cache)
        body = self._state_template
        if not 0 <= seq <= 0xFFFF:
            raise ValueError(f"cannot encode state seq {seq}")
        body[2] = seq & 0xFF
        body[3] = seq >> 8
        return cobs_encode(bytes(body) + _CRC.pack(binascii.crc_hqx(body, 0))) + b"\x00"

    def _status_wire(self, board_status: tuple[int, ...]) -> bytes:
        """The board-status bytes of a STATE frame, cached (checked once per distinct tuple)."""
        wire = self._status_to_wire.get(board_status)  # pragma: no mutate (a cache)
        if wire is None:
            status = bytearray(self.layout.status_bytes)
            for i, nib in enumerate(board_status):
                if not 0 <= nib <= 0xF:
                    raise ValueError(f"board status {nib} is not a nibble")
                status[i >> 1] |= nib << (4 * (i & 1))
            wire = bytes(status)
            if len(self._status_to_wire) >= _STATUS_CACHE:
                self._status_to_wire.clear()
            self._status_to_wire[board_status] = wire  # pragma: no mutate (a cache)
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
            pairs = zip(
                msg.modes,
                msg.raw_values,
                strict=True,  # pragma: no mutate (their lengths are checked above)
            )
            for mode, raw in pairs:
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
            return 0, _HELLO.pack(msg.layout_digest, msg.minor)
        if isinstance(msg, HelloReply):
            return int(msg.flags), _HELLO_REPLY.pack(
                msg.layout_digest,
                msg.n_channels,
                msg.n_motors,
                msg.watchdog_ms,
                msg.firmware,
                msg.minor,
                msg.boot_id,
                msg.sessions,
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
            # 20 + 13 k bytes is never exactly MAX_PAYLOAD_BYTES (247)
            if len(payload) > MAX_PAYLOAD_BYTES:  # pragma: no mutate (>=: 247 is never one)
                raise ValueError(f"{len(msg.boards)} boards do not fit one counters frame")
            return 0, payload
        raise ValueError(f"not a message: {msg!r}")

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
        if body[0] != PROTOCOL_VERSION:
            raise OtherVersion(body[1], body[0], PROTOCOL_VERSION)
        # Consecutive STATE frames mostly differ only in their seq (bytes 2-3) and CRC:
        # then the fields decoded last time are reused (immutable, so shared safely)
        # and only the seq is read.
        rest = body[4:-2]
        if rest == self._state_rest:
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
        nibbles = self._status_from_wire.get(fields[6])  # pragma: no mutate (a cache)
        if nibbles is None:
            nibbles = tuple(itertools.chain.from_iterable(map(_NIBBLES.__getitem__, fields[6])))
            nibbles = nibbles[: self._n_boards]
            if len(self._status_from_wire) >= _STATUS_CACHE:
                self._status_from_wire.clear()
            self._status_from_wire[fields[6]] = nibbles  # pragma: no mutate (a cache)
        # A frozen dataclass's __init__ sets each field through object.__setattr__; the
        # slot descriptors do the same work in half the time (same class, same fields).
        msg = _new_object(State)
        _SET_STATE_SEQ(msg, fields[2])
        _SET_STATE_FLAGS(msg, _FLAGS[fields[3]])
        _SET_STATE_ACK_SEQ(msg, fields[4])
        _SET_STATE_FRESH_MASK(msg, int.from_bytes(fields[5], "little") & self._mask_all)
        _SET_STATE_BOARD_STATUS(msg, nibbles)
        _SET_STATE_RAW_VALUES(msg, fields[7:])
        self._state_rest = rest  # pragma: no mutate (a cache)
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
            raise BadCrc(body[1], crc)
        if body[1] == _STATE_CODE and n == self._state_body_bytes:
            return self._state_from_body(body)
        version, code, seq, arg = _HEADER.unpack_from(body)
        if version != PROTOCOL_VERSION:
            raise OtherVersion(code, version, PROTOCOL_VERSION)
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
                raise StateLengthError(size, lay.state_payload_bytes)
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
        msg = decode_fixed(kind, seq, arg, payload)
        if type(msg) is Counters and len(msg.boards) != self.layout.n_boards:
            # docs/protocol.md: one entry per board of the layout, in id order
            raise FrameError(
                "length",
                f"counters of {len(msg.boards)} boards, the layout has {self.layout.n_boards}",
            )
        return msg
