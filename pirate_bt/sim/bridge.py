"""The simulated PIRATEbay bridge and its PICO boards, at the byte level: the reference bridge.

:class:`SimBridge` is what the host's link talks to. It takes bytes
(:meth:`SimBridge.receive`), checks each frame in the order ``docs/protocol.md``
gives (framing, CRC, version with the link's
:class:`~pirate_bt.link.raw.RawFrameDecoder`; then type, length, and the
rules of each type), applies setpoints to the
:class:`~pirate_bt.sim.model.PipeRobotModel` through the robot's
:class:`~pirate_bt.robot.commands.CommandCodec` (raw -> SI, exactly as the real
boards' conversions are described), and queues answers (ACK, NACK, HELLO_REPLY,
COUNTERS) for the host to read (:meth:`SimBridge.read`). Time moves only in
:meth:`SimBridge.advance_to`: the physics steps once per state period and a
STATE frame (SI readings -> raw with :meth:`StateBuilder.encode`) goes out at
each step. :meth:`SimBridge.reset` is a bridge reset (the DTR reset of a port
opening).

It follows the protocol page to the letter, and the conformance suite
(``tests/conformance/``) checks it through its bytes: sessions, the duplicate
filter on the ordered sequence numbers with replayed answers, the all-or-nothing
bulk setpoint acknowledged by the next STATE's ``ack_seq``, the latched e-stop
(also from boot), the watchdog armed from boot, and the stop category on every
stop: drives velocity 0, rotation and other motors PWM 0 (brake), bend joints
unchanged so the clamps keep holding.

Faults are applied here too: a stalled motor, a sensor that drops out or
sticks, a board that resets (motors off, readings missing for
``bridge.reset_time``), and link loss (nothing in, nothing out).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable

from pirate_bt.errors import FrameError
from pirate_bt.link.codec import (
    MODE_KEEP,
    PROTOCOL_MINOR,
    PROTOCOL_MINOR_MAX,
    Ack,
    AckStatus,
    BoardCounters,
    BridgeFlags,
    Counters,
    FrameCodec,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    seq_newer,
)
from pirate_bt.link.layout import StopRole, stop_role
from pirate_bt.link.messages import MODE_BY_CODE
from pirate_bt.link.raw import HOST_TYPES, HostPayloads, RawFrame, RawFrameDecoder
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot.commands import CommandCodec, MotorCommand, RawSetpoint
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.robot.state import StateBuilder
from pirate_bt.sim.bridge_faults import ActiveFault, FaultsMixin
from pirate_bt.sim.bridge_state import BRIDGE_HEARTBEAT_S, MAX_PENDING_BYTES, StateFramesMixin
from pirate_bt.sim.counters import EventKind, SimCounters
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["FIRMWARE_VERSION", "MAX_PENDING_BYTES", "SimBridge"]

_log = logging.getLogger(__name__)

FIRMWARE_VERSION = 0x5101
"""Firmware number the simulated bridge reports in HELLO_REPLY (0x5000-0x5FFF: simulated)."""


def _stop_commands(robot: RobotDescription) -> list[MotorCommand]:
    """The stop category's setpoints (docs/protocol.md): bend joints are not commanded."""
    out = []
    for slot in robot.setpoint_slots():
        motor = slot.motor
        role = stop_role(motor)
        if role is StopRole.DRIVE and motor.modes.velocity is not None:
            out.append(MotorCommand(motor.name, ControlMode.VELOCITY, 0.0))
        elif role in (StopRole.ROTATE, StopRole.OTHER) and motor.modes.pwm is not None:
            out.append(MotorCommand(motor.name, ControlMode.PWM, 0.0))
    return out


class SimBridge(StateFramesMixin, FaultsMixin):
    """The simulated bridge: bytes in, bytes out, physics stepped per state period.

    Args:
        model: The robot-in-pipe model it drives.
        start_s: Clock time at which the bridge starts.
    """

    def __init__(
        self, model: PipeRobotModel, start_s: float = 0.0, *, record_applied: bool = False
    ) -> None:
        robot: RobotDescription = model.robot
        self.model = model
        self.robot = robot
        self.codec = FrameCodec.for_robot(robot)
        self._decoder = RawFrameDecoder(self.codec)
        self._payloads = HostPayloads(self.codec.layout)
        self._commands = CommandCodec(robot)
        self._states = StateBuilder(robot)
        self._channels = [c.name for c in robot.state_channels()]
        self._channel_index = {name: i for i, name in enumerate(self._channels)}
        self._channel_board = [c.board for c in robot.state_channels()]
        self._boards = robot.board_ids()
        self._slots = robot.setpoint_slots()
        self._motor_at = {(s.board, s.slot): s.motor for s in self._slots}
        self._stop_commands = _stop_commands(robot)
        self._motor_board = {s.motor.name: s.board for s in self._slots}
        self.period_s = robot.bridge.state_period
        self.watchdog_s = robot.bridge.watchdog
        self.now_s = start_s
        self._out = bytearray()
        self._last_raw = [0] * len(self._channels)
        self._all_fresh = (1 << len(self._channels)) - 1
        self._encoded_from: list[float] = []
        self._encoded: list[int] = []
        self._raw_tuple: tuple[int, ...] | None = None
        self._status_cache: tuple[int, ...] | None = None
        # The robot's raw<->SI conversion of each channel, unpacked for the 100 Hz path;
        # equivalent to StateBuilder.encode (tests check it).
        self._conversions = [
            (c.conversion.zero_raw, 1.0 / c.conversion.per_raw, *c.conversion.raw)
            for c in robot.state_channels()
        ]
        self.rx_frames = 0
        self.crc_errors = 0
        self.frame_errors = 0
        self.duplicates = 0
        self.watchdog_trips = 0
        self.applied: list[tuple[MsgType, int]] | None = [] if record_applied else None
        """Every ordered request applied, as (type, seq), when ``record_applied``."""
        # figures of the simulator that survive a bridge reset
        self.nacks = 0
        self.frames_dropped = 0
        self.commands_executed = 0
        self.state_frames_sent = 0
        self.state_frames_unread = 0
        self.boot_id = 0
        self.estop_input = False
        """The hardware e-stop input is pressed (see :meth:`set_estop_input`)."""
        self.max_minor = PROTOCOL_MINOR_MAX
        """The newest protocol minor version this bridge speaks (1: a 1.1 bridge)."""
        self._input_tripped = False
        self._resetting: set[int] = set()
        self._held_setpoints: dict[int, list[MotorCommand]] = {}  # a board's, over its reset
        # a board in FAULT: the setpoint each of its motors holds, off while it lasts
        self._faulted: dict[int, dict[str, MotorCommand | None]] = {}
        self._link_lost = False
        self._lost_partial = False  # bytes of an unfinished frame were lost to the link loss
        self._boot()
        # faults
        self._pending: list[FaultSpec] = []
        self._active: list[ActiveFault] = []
        self._dropout: set[int] = set()
        self._stuck: dict[int, float] = {}

    # -- bytes ----------------------------------------------------------------------

    def receive(self, data: bytes) -> None:
        """Bytes from the host, processed at once (answers are queued for :meth:`read`)."""
        if not data:
            return
        if self._link_lost:
            self._drop(data)
            return
        for item in self._decoder.feed_raw(data):
            if isinstance(item, FrameError):  # steps 1-2: dropped, counted, not answered
                if item.reason == "crc":
                    self.crc_errors += 1
                else:
                    self.frame_errors += 1
                continue
            self._handle(item)

    def read(self, size: int = -1) -> bytes:
        """Take up to ``size`` queued bytes for the host (all when negative)."""
        if size < 0 or size >= len(self._out):
            data = bytes(self._out)
            self._out.clear()
            return data
        data = bytes(self._out[:size])
        del self._out[:size]
        return data

    @property
    def pending_bytes(self) -> int:
        """Bytes queued for the host."""
        return len(self._out)

    def _send(self, msg: Message) -> None:
        if not self._link_lost:
            self._out += self.codec.encode(msg)
            self._beat_due_s = self.now_s + BRIDGE_HEARTBEAT_S

    # -- boot -----------------------------------------------------------------------

    def reset(self) -> None:
        """A bridge reset (the DTR reset of a port opening, a brown-out): boot again.

        Everything the bridge held is lost: the session, the duplicate filter,
        ``ack_seq``, the counters, bytes queued either way. It boots latched, with
        ``NO_SESSION`` set, a new boot id, and the stop category applied (the physical
        robot, and the setpoints its boards hold, stay as they are).
        """
        self._out.clear()
        self._decoder.reset()
        self._boot()

    def _boot(self) -> None:
        self.boot_id = (self.boot_id + 1) & 0xFFFF
        self.sessions = 0
        self.no_session = True
        self.estopped = True
        self.watchdog_tripped = False
        self._minor = PROTOCOL_MINOR  # until a HELLO says otherwise
        self._input_tripped = self.estop_input
        self._last_seq: int | None = None
        self._last_kind: MsgType | None = None
        self._last_answer: AckStatus | NackCode | None = None
        self._ack_seq = 0
        self._state_seq = 0
        self._last_rx_s = self.now_s
        self._next_frame_s = self.now_s + self.period_s
        self._beat_due_s = self.now_s + BRIDGE_HEARTBEAT_S
        # COUNTERS count since boot; the simulator's own figures run on across resets
        self._boot_base = self._totals()
        self._board_timeouts = dict.fromkeys(self._boards, 0)
        self._board_retries = dict.fromkeys(self._boards, 0)
        # each board's last answer (boot counts as one), and the boards the robot stopped
        # for, not heard for BOARD_AWAY_S (firmware/piratebay/poller.c)
        self._heard_s = dict.fromkeys(self._boards, self.now_s)
        self._all_heard_s = self.now_s
        self._away: set[int] = set()
        self._bus_fault = False  # no board answered the last poll cycle
        self._apply_stop()

    def _apply_stop(self) -> None:
        """The stop category: drives velocity 0, rotate and other PWM 0, bend unchanged.

        A board that is rebooting gets them when it answers again (the bridge keeps them
        for it, as for every board): its motors stay off meanwhile.
        """
        for command in self._stop_commands:
            board = self._motor_board[command.motor]
            if board in self._resetting:
                held = self._held_setpoints.setdefault(board, [])
                held[:] = [c for c in held if c.motor != command.motor] + [command]
            else:
                self.model.command(command)
        self._motors_off = set(self._boards)
        self._status_cache = None

    # -- messages -------------------------------------------------------------------

    def _handle(self, frame: RawFrame) -> None:
        """Steps 3-6 of docs/protocol.md, Checks, in order."""
        # 3. accept: count, feed the watchdog, release a trip
        self.rx_frames += 1
        self._last_rx_s = self.now_s
        if self.watchdog_tripped:
            self.watchdog_tripped = False
            _log.info("host heard again at %.3f s; watchdog released", self.now_s)
        kind, seq = frame.type, frame.seq
        # 4. type
        if kind not in HOST_TYPES:
            self._nack(seq, kind, NackCode.UNKNOWN_TYPE)
            return
        # 5. length
        if len(frame.payload) != self._payloads.size(kind):
            self._nack(seq, kind, NackCode.BAD_LENGTH)
            return
        # 6. by type
        if kind == MsgType.HEARTBEAT:
            self._send(Ack(seq, MsgType.HEARTBEAT))
        elif kind == MsgType.COUNTERS_REQUEST:
            self._send_counters(seq)
        elif kind == MsgType.HELLO:
            self._hello(seq, frame.payload)
        elif kind == MsgType.ESTOP:
            self._estop(seq)
        else:
            self._ordered(MsgType(kind), seq, frame)

    def _nack(self, seq: int, kind: int, code: NackCode) -> None:
        self.nacks += 1
        self._send(Nack(seq, kind, code))

    def _totals(self) -> tuple[int, int, int, int, int]:
        return (
            self.rx_frames,
            self.crc_errors,
            self.frame_errors,
            self.duplicates,
            self.watchdog_trips,
        )

    def _send_counters(self, seq: int) -> None:
        rx, crc, framing, dups, trips = (
            (total - base) & 0xFFFFFFFF
            for total, base in zip(self._totals(), self._boot_base, strict=True)
        )
        self._send(
            Counters(
                seq,
                rx,
                crc,
                framing,
                dups,
                trips,
                tuple(
                    BoardCounters(
                        b,
                        self._board_timeouts[b] & 0xFFFFFFFF,
                        0,
                        self._board_retries[b] & 0xFFFFFFFF,
                    )
                    for b in self._boards
                ),
            )
        )

    def _hello(self, seq: int, payload: bytes) -> None:
        digest, minor = self._payloads.hello(payload)
        if digest != self.codec.layout.digest or not 1 <= minor <= self.max_minor:
            self._nack(seq, MsgType.HELLO, NackCode.BAD_LAYOUT)
            return
        # a retried HELLO (its reply was lost: the same seq, nothing handled since) is the
        # same session; any other HELLO starts a new one
        retry = not self.no_session and seq == self._last_seq and self._last_kind is None
        if not retry:
            self.sessions = min(self.sessions + 1, 255)
        # a new session: filter, ack_seq, setpoints at the stop; latch and counters kept
        self._last_seq = seq
        self._last_kind = None
        self._last_answer = None
        self._ack_seq = 0
        self.no_session = False
        self.watchdog_tripped = False
        self._minor = minor  # the session speaks what its host asked for
        self._apply_stop()
        self._send(
            HelloReply(
                seq,
                self.codec.layout.digest,
                self.codec.layout.n_channels,
                self.codec.layout.n_motors,
                round(self.watchdog_s * 1000),
                FIRMWARE_VERSION,
                minor,
                self.boot_id,
                self.sessions,
                self._flags(),
            )
        )

    def _estop(self, seq: int) -> None:
        self.estopped = True
        self._apply_stop()
        if self._last_seq is not None and seq_newer(seq, self._last_seq):
            self._last_seq = seq
            self._last_kind = MsgType.ESTOP
            self._last_answer = AckStatus.APPLIED
        self._record_applied(MsgType.ESTOP, seq)
        self._send(Ack(seq, MsgType.ESTOP))

    def _ordered(self, kind: MsgType, seq: int, frame: RawFrame) -> None:
        """SETPOINT, BULK_SETPOINTS, ESTOP_RESET: session, duplicate filter, checks."""
        if self.no_session:
            self._nack(seq, kind, NackCode.NOT_READY)
            return
        last = self._last_seq
        assert last is not None  # set by every accepted hello
        if not seq_newer(seq, last):
            self.duplicates += 1
            answer = self._last_answer
            if seq != last or kind is not self._last_kind:
                self._send(Ack(seq, kind, AckStatus.STALE))
            elif isinstance(answer, NackCode):
                self._nack(seq, kind, answer)
            else:
                self._send(Ack(seq, kind, AckStatus.DUPLICATE))
            return
        self._last_seq = seq
        self._last_kind = kind
        if kind is MsgType.SETPOINT:
            result = self._setpoint(frame)
        elif kind is MsgType.BULK_SETPOINTS:
            result = self._bulk(seq, frame.payload)
        else:
            result = self._estop_reset()
        self._last_answer = result
        if isinstance(result, NackCode):
            self._nack(seq, kind, result)
            return
        self._record_applied(kind, seq)
        if kind is not MsgType.BULK_SETPOINTS:  # a bulk is acknowledged by ack_seq
            self._send(Ack(seq, kind, AckStatus.APPLIED))

    def _record_applied(self, kind: MsgType, seq: int) -> None:
        if self.applied is not None:
            self.applied.append((kind, seq))

    def _check(self, board: int, slot: int, code: int, raw_value: int) -> MotorCommand | NackCode:
        """Mode and range of one entry (BAD_MODE, OUT_OF_RANGE); board and slot known."""
        motor = self._motor_at[(board, slot)]
        mode = MODE_BY_CODE.get(code)
        conversion = None if mode is None else motor.modes.get(mode)
        if mode is None or conversion is None:
            return NackCode.BAD_MODE
        lo, hi = conversion.raw
        if not lo <= raw_value <= hi:
            return NackCode.OUT_OF_RANGE
        return self._commands.to_si(RawSetpoint(board, slot, mode, raw_value))

    def _deliverable(self, boards: Iterable[int]) -> NackCode | None:
        if self.estopped:
            return NackCode.ESTOP_LATCHED
        if any(b in self._resetting for b in boards):
            return NackCode.BUS_ERROR  # the board is rebooting: it misses its polls
        return None

    def _setpoint(self, frame: RawFrame) -> AckStatus | NackCode:
        board = frame.arg
        slot, code, raw_value = self._payloads.setpoint(frame.payload)
        if board not in self._boards:
            return NackCode.BAD_BOARD
        if (board, slot) not in self._motor_at:
            return NackCode.BAD_SLOT
        result = self._check(board, slot, code, raw_value)
        if isinstance(result, NackCode):
            return result
        refused = self._deliverable((board,))
        if refused is not None:
            return refused
        self._apply(result, board)
        return AckStatus.APPLIED

    def _bulk(self, seq: int, payload: bytes) -> AckStatus | NackCode:
        commands: list[tuple[MotorCommand, int]] = []
        for slot, (code, raw_value) in zip(self._slots, self._payloads.bulk(payload), strict=True):
            if code == MODE_KEEP:
                continue
            result = self._check(slot.board, slot.slot, code, raw_value)
            if isinstance(result, NackCode):
                return result
            commands.append((result, slot.board))
        refused = self._deliverable({board for _, board in commands})
        if refused is not None:
            return refused
        for command, board in commands:
            self._apply(command, board)
        self._ack_seq = seq
        return AckStatus.APPLIED

    def _estop_reset(self) -> AckStatus | NackCode:
        if not self.estopped:
            return AckStatus.APPLIED
        if self._resetting or self._faulted:
            # a board in TIMEOUT or FAULT: no confirming its motors are held (the
            # firmware bridge's rule, firmware/piratebay/protocol.c)
            return NackCode.NOT_READY
        if self.estop_input:  # the button is still pressed
            return NackCode.NOT_READY
        self.estopped = False
        self._input_tripped = False
        self._status_cache = None
        _log.info("e-stop reset at %.3f s", self.now_s)
        return AckStatus.APPLIED

    def _apply(self, command: MotorCommand, board: int) -> None:
        self.model.command(command)
        self.commands_executed += 1
        if board in self._motors_off:
            self._motors_off.discard(board)
            self._status_cache = None

    def _flags(self) -> BridgeFlags:
        flags = BridgeFlags.NONE
        if self.estopped:
            flags |= BridgeFlags.ESTOP
        if self.watchdog_tripped:
            flags |= BridgeFlags.WATCHDOG
        if self._bus_fault:
            flags |= BridgeFlags.BUS_FAULT
        if self.no_session:
            flags |= BridgeFlags.NO_SESSION
        if self._minor >= 2 and (self.estop_input or self._input_tripped):
            flags |= BridgeFlags.ESTOP_INPUT  # 1.2 only: a 1.1 session keeps bits 4-7 at 0
        return flags

    def set_estop_input(self, pressed: bool) -> None:
        """Press (or release) the bridge's hardware e-stop input (docs/firmware.md).

        Pressing it latches the e-stop and applies the stop category, as ``ESTOP``
        does; ``ESTOP_RESET`` is refused (``NOT_READY``) while it stays pressed. In a
        1.2 session the bridge flag ``ESTOP_INPUT`` reports it until a reset releases
        the latch. (The firmware debounces its pin; this input is already clean.)
        """
        if pressed and not self.estop_input:
            self.estopped = True
            self._input_tripped = True
            self._apply_stop()
            _log.warning("hardware e-stop input pressed at %.3f s", self.now_s)
        self.estop_input = pressed

    # -- time -----------------------------------------------------------------------

    def advance_to(self, now_s: float) -> None:
        """Run the world up to clock time ``now_s``: physics, faults, watchdog, STATE frames
        (and a BRIDGE_HEARTBEAT where the line would be silent for 50 ms)."""
        while True:
            beat_s = self._beat_due_s
            if beat_s < self._next_frame_s - 1e-9 and beat_s <= now_s + 1e-12:
                self.now_s = beat_s
                self._send_heartbeat()
                continue
            if self._next_frame_s > now_s + 1e-12:
                break
            t = self._next_frame_s
            self.now_s = t
            self._update_faults(t)
            self._watchdog(t)
            self._poll_boards(t)
            self.model.step(self.period_s)
            self._send_state()
            self._next_frame_s = t + self.period_s
        self.now_s = max(self.now_s, now_s)

    def _watchdog(self, now_s: float) -> None:
        # armed from boot: no valid host frame for a whole period trips it
        if self.watchdog_tripped or now_s - self._last_rx_s <= self.watchdog_s:
            return
        self.watchdog_tripped = True
        self.watchdog_trips += 1
        self._apply_stop()
        self.model.record(
            EventKind.WATCHDOG, "host silent: drives and rotation stopped, clamps held"
        )
        _log.warning("watchdog: host silent for %.3f s", now_s - self._last_rx_s)

    # -- figures --------------------------------------------------------------------

    def counters(self) -> SimCounters:
        """Physics counters of the model plus this bridge's link counters."""
        physics = self.model.counters()
        return SimCounters(
            violations=physics.violations,
            damage=physics.damage,
            stuck_events=physics.stuck_events,
            slip_events=physics.slip_events,
            distance_m=physics.distance_m,
            slide_m=physics.slide_m,
            frames_received=self.rx_frames,
            frames_rejected=self.crc_errors + self.frame_errors + self.nacks,
            frames_dropped=self.frames_dropped,
            commands_executed=self.commands_executed,
            state_frames_sent=self.state_frames_sent,
            watchdog_trips=self.watchdog_trips,
        )
