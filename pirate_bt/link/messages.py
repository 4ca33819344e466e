"""The PIRATEbay messages: type codes, status codes and one frozen dataclass per message.

Every message of ``docs/protocol.md`` is a small immutable record with its
``TYPE``; :mod:`pirate_bt.link.codec` turns them into bytes and back.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum, IntFlag
from typing import ClassVar

from pirate_bt.link.framing import PROTOCOL_MINOR
from pirate_bt.robot.description import ControlMode

__all__ = [
    "MODE_BY_CODE",
    "MODE_CODES",
    "MODE_KEEP",
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
    "Heartbeat",
    "Hello",
    "HelloReply",
    "Message",
    "MsgType",
    "Nack",
    "NackCode",
    "Setpoint",
    "State",
]


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
    """Same seq as the last ordered request, which was applied: not applied again."""
    STALE = 2
    """Older than the last ordered request: **not applied** (the host reports a failure)."""


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
    """The e-stop is latched (from boot, or by ESTOP): setpoints refused until ESTOP_RESET."""
    WATCHDOG = 0x02
    """The host was silent for the watchdog period: the stop category applied, clamps held."""
    BUS_FAULT = 0x04
    """The RS485 bus failed a whole poll cycle."""
    NO_SESSION = 0x08
    """No HELLO was accepted since the bridge booted (it was reset)."""
    ESTOP_INPUT = 0x10
    """Protocol 1.2 sessions only: the bridge's hardware e-stop input is pressed, or it
    latched the e-stop and no ESTOP_RESET released it since (a 1.1 bridge never sets it)."""


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
    """The board's motors are held by a stop and no setpoint for it was applied since."""


MODE_CODES: dict[ControlMode, int] = {
    ControlMode.PWM: 0,
    ControlMode.TORQUE: 1,
    ControlMode.POSITION: 2,
    ControlMode.VELOCITY: 3,
}
"""Wire code of each control mode."""
MODE_KEEP = 0xFF
"""BULK_SETPOINTS mode code meaning "leave this motor as it is" (``None`` in Python)."""
MODE_BY_CODE: dict[int, ControlMode] = {v: k for k, v in MODE_CODES.items()}
"""Control mode of each wire code (``keep`` and unknown codes absent)."""
_MODE_BY_CODE = MODE_BY_CODE


# --- messages -------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Hello:
    """Host -> bridge: start a session; the bridge answers with :class:`HelloReply`.

    A new session: the bridge's duplicate filter starts at ``seq``, ``ack_seq`` at 0,
    the setpoints at the stop category; the e-stop latch and the counters stay.
    A bridge with another digest, or a minor version it does not speak, answers
    ``NACK BAD_LAYOUT``; a 1.2 bridge speaks 1.1 and 1.2, and the session then speaks
    the minor asked for.
    """

    TYPE: ClassVar[MsgType] = MsgType.HELLO
    seq: int
    layout_digest: int
    minor: int = PROTOCOL_MINOR


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
    minor: int = PROTOCOL_MINOR
    boot_id: int = 0
    """Chosen at each boot of the bridge; a change between hellos means it was reset."""
    sessions: int = 1
    """Hellos accepted since boot, this one included (saturates at 255)."""
    flags: BridgeFlags = BridgeFlags.NONE
    """Bridge flags after the hello (the header's ``arg``)."""


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
