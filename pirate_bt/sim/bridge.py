"""The simulated PIRATEbay bridge and its PICO boards, at the byte level.

:class:`SimBridge` is what the host's link talks to. It takes bytes
(:meth:`SimBridge.receive`), decodes them with the link's own
:class:`~pirate_bt.link.codec.FrameDecoder`, applies setpoints to the
:class:`~pirate_bt.sim.model.PipeRobotModel` through the robot's
:class:`~pirate_bt.robot.commands.CommandCodec` (raw -> SI, exactly as the real
boards' conversions are described), and queues answers (ACK, NACK, HELLO_REPLY,
COUNTERS) for the host to read (:meth:`SimBridge.read`). Time moves only in
:meth:`SimBridge.advance_to`: the physics steps once per state period and a
STATE frame (SI readings -> raw with :meth:`StateBuilder.encode`) goes out at
each step.

It follows ``docs/protocol.md``: the duplicate filter on sequence numbers, the
all-or-nothing bulk setpoint acknowledged by the next STATE's ``ack_seq``, the
latched e-stop, and the watchdog (no valid frame for ``bridge.watchdog``: all
drives stop, clamps stay as they are, the WATCHDOG flag is set until the host
is heard again).

Faults are applied here too: a stalled motor, a sensor that drops out or
sticks, a board that resets (motors off, readings missing for
``bridge.reset_time``), and link loss (nothing in, nothing out).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass

from pirate_bt.errors import ConfigurationError, FrameError, InputError
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BoardCounters,
    BoardStatus,
    BridgeFlags,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
    seq_newer,
)
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot.commands import CommandCodec, MotorCommand, RawSetpoint
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import StateBuilder
from pirate_bt.sim.counters import EventKind, SimCounters
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["FIRMWARE_VERSION", "MAX_PENDING_BYTES", "SimBridge"]

_log = logging.getLogger(__name__)

MAX_PENDING_BYTES = 1 << 16
"""Bytes the bridge queues for a host that does not read before it drops state frames."""

FIRMWARE_VERSION = 0x5100
"""Firmware number the simulated bridge reports in HELLO_REPLY."""

_HOST_TYPES = (
    MsgType.HELLO,
    MsgType.SETPOINT,
    MsgType.BULK_SETPOINTS,
    MsgType.HEARTBEAT,
    MsgType.ESTOP,
    MsgType.ESTOP_RESET,
    MsgType.COUNTERS_REQUEST,
)


@dataclass
class _ActiveFault:
    spec: FaultSpec
    end_s: float
    started: bool = False
    frozen: float | None = None


class SimBridge:
    """The simulated bridge: bytes in, bytes out, physics stepped per state period.

    Args:
        model: The robot-in-pipe model it drives.
        start_s: Clock time at which the bridge starts.
    """

    def __init__(self, model: PipeRobotModel, start_s: float = 0.0) -> None:
        robot: RobotDescription = model.robot
        self.model = model
        self.robot = robot
        self.codec = FrameCodec.for_robot(robot)
        self._decoder = FrameDecoder(self.codec)
        self._commands = CommandCodec(robot)
        self._states = StateBuilder(robot)
        self._channels = [c.name for c in robot.state_channels()]
        self._channel_index = {name: i for i, name in enumerate(self._channels)}
        self._channel_board = [c.board for c in robot.state_channels()]
        self._boards = robot.board_ids()
        self._slots = robot.setpoint_slots()
        self._slot_board = [s.board for s in self._slots]
        self.period_s = robot.bridge.state_period
        self.watchdog_s = robot.bridge.watchdog
        self.now_s = start_s
        self._next_frame_s = start_s + self.period_s
        self._last_rx_s = start_s
        self._out = bytearray()
        self._last_seq: int | None = None
        self._ack_seq = 0
        self._state_seq = 0
        self._last_raw = [0] * len(self._channels)
        self._all_fresh = (1 << len(self._channels)) - 1
        self._encoded_from: list[float] = []
        self._all_online = tuple(int(BoardStatus.ONLINE) for _ in self._boards)
        self._encoded: list[int] = []
        self._raw_tuple: tuple[int, ...] | None = None
        # The robot's raw<->SI conversion of each channel, unpacked for the 100 Hz path;
        # equivalent to StateBuilder.encode (tests check it).
        self._conversions = [
            (c.conversion.zero_raw, 1.0 / c.conversion.per_raw, *c.conversion.raw)
            for c in robot.state_channels()
        ]
        self.estopped = False
        self.watchdog_tripped = False
        self._armed = False  # the watchdog runs once the host has said hello
        # counters
        self.rx_frames = 0
        self.crc_errors = 0
        self.frame_errors = 0
        self.duplicates = 0
        self.nacks = 0
        self.frames_dropped = 0
        self.commands_executed = 0
        self.state_frames_sent = 0
        self.watchdog_trips = 0
        self.state_frames_unread = 0
        # faults
        self._pending: list[FaultSpec] = []
        self._active: list[_ActiveFault] = []
        self._link_lost = False
        self._resetting: set[int] = set()
        self._dropout: set[int] = set()
        self._stuck: dict[int, float] = {}

    # -- faults ---------------------------------------------------------------------

    def check_fault(self, fault: FaultSpec) -> None:
        """Check that a fault's target exists on this robot.

        Raises:
            ConfigurationError: unknown motor, channel or board.
        """
        target = fault.target
        if fault.kind == "motor_stall":
            if target not in self.model.motor_names():
                raise ConfigurationError(f"fault {fault.kind}: unknown motor {target!r}")
        elif fault.kind in ("sensor_dropout", "sensor_stuck"):
            if target not in self._channel_index:
                raise ConfigurationError(f"fault {fault.kind}: unknown state channel {target!r}")
        elif fault.kind == "board_reset" and (
            target is None or not target.isdigit() or int(target) not in self._boards
        ):
            raise ConfigurationError(f"fault board_reset: unknown board {target!r}")

    def schedule(self, faults: Iterable[FaultSpec]) -> None:
        """Add faults to inject at their simulated times.

        Raises:
            ConfigurationError: a fault names a motor, channel or board the robot lacks.
        """
        for fault in faults:
            self.check_fault(fault)
            self._pending.append(fault)
        self._pending.sort(key=lambda f: f.at)

    def _update_faults(self, now_s: float) -> None:
        while self._pending and self._pending[0].at <= now_s:
            spec = self._pending.pop(0)
            duration = spec.duration
            if duration is None:
                duration = self.robot.bridge.reset_time if spec.kind == "board_reset" else math.inf
            fault = _ActiveFault(spec, spec.at + duration)
            self._active.append(fault)
            self._start_fault(fault)
        for fault in [f for f in self._active if f.end_s <= now_s]:
            self._active.remove(fault)
            self._end_fault(fault)

    def _start_fault(self, fault: _ActiveFault) -> None:
        spec = fault.spec
        target = spec.target or ""
        self.model.record(EventKind.FAULT, f"start {spec.kind} {target}".strip())
        _log.info("fault %s %s starts at %.3f s", spec.kind, target, self.now_s)
        if spec.kind == "motor_stall":
            self.model.set_stalled(target, True)
        elif spec.kind == "sensor_dropout":
            self._dropout.add(self._channel_index[target])
        elif spec.kind == "sensor_stuck":
            index = self._channel_index[target]
            self._stuck[index] = self.model.readings()[target]
        elif spec.kind == "board_reset":
            board = int(target)
            self._resetting.add(board)
            names = [m.name for b in self.robot.boards if b.id == board for m in b.motors]
            self.model.motors_off(names)
        elif spec.kind == "link_loss":
            self._link_lost = True

    def _end_fault(self, fault: _ActiveFault) -> None:
        spec = fault.spec
        target = spec.target or ""
        self.model.record(EventKind.FAULT, f"end {spec.kind} {target}".strip())
        if spec.kind == "motor_stall":
            self.model.set_stalled(target, False)
        elif spec.kind == "sensor_dropout":
            self._dropout.discard(self._channel_index[target])
        elif spec.kind == "sensor_stuck":
            self._stuck.pop(self._channel_index[target], None)
        elif spec.kind == "board_reset":
            self._resetting.discard(int(target))
        elif spec.kind == "link_loss":
            self._link_lost = False
            self._decoder.reset()

    # -- bytes ----------------------------------------------------------------------

    def receive(self, data: bytes) -> None:
        """Bytes from the host, processed at once (answers are queued for :meth:`read`)."""
        if not data:
            return
        if self._link_lost:
            self.frames_dropped += data.count(0)
            return
        for item in self._decoder.iter_feed(data):
            if isinstance(item, FrameError):
                if item.reason == "crc":
                    self.crc_errors += 1
                else:
                    self.frame_errors += 1
                continue
            self.rx_frames += 1
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

    # -- messages -------------------------------------------------------------------

    def _handle(self, msg: Message) -> None:
        if msg.TYPE not in _HOST_TYPES:
            self._nack(msg.seq, msg.TYPE, NackCode.UNKNOWN_TYPE)
            return
        self._last_rx_s = self.now_s
        if self.watchdog_tripped:
            self.watchdog_tripped = False
            _log.info("host heard again at %.3f s; watchdog released", self.now_s)
        if isinstance(msg, Hello):
            self._armed = True
            self._last_seq = msg.seq
            self._send(
                HelloReply(
                    msg.seq,
                    self.codec.layout.digest,
                    self.codec.layout.n_channels,
                    self.codec.layout.n_motors,
                    round(self.watchdog_s * 1000),
                    FIRMWARE_VERSION,
                )
            )
        elif isinstance(msg, Heartbeat):
            self._send(Ack(msg.seq, MsgType.HEARTBEAT))
        elif isinstance(msg, EStop):
            self.estopped = True
            self.model.motors_off()
            self._send(Ack(msg.seq, MsgType.ESTOP))
        elif isinstance(msg, EStopReset):
            self.estopped = False
            self._send(Ack(msg.seq, MsgType.ESTOP_RESET))
        elif isinstance(msg, CountersRequest):
            self._send(
                Counters(
                    msg.seq,
                    self.rx_frames,
                    self.crc_errors,
                    self.frame_errors,
                    self.duplicates,
                    self.watchdog_trips,
                    tuple(BoardCounters(b) for b in self._boards),
                )
            )
        elif isinstance(msg, Setpoint):
            self._setpoint(msg)
        elif isinstance(msg, BulkSetpoints):
            self._bulk(msg)

    def _nack(self, seq: int, kind: int, code: NackCode) -> None:
        self.nacks += 1
        self._send(Nack(seq, kind, code))

    def _dedupe(self, seq: int, kind: MsgType) -> bool:
        """True when the request is new; answers duplicates and stale requests itself."""
        last = self._last_seq
        if last is None or seq_newer(seq, last):
            return True
        self.duplicates += 1
        status = AckStatus.DUPLICATE if seq == last else AckStatus.STALE
        if kind is MsgType.SETPOINT:
            self._send(Ack(seq, kind, status))
        return False

    def _convert(self, raw: RawSetpoint) -> MotorCommand | NackCode:
        try:
            command = self._commands.to_si(raw)
        except InputError:
            if raw.board not in self._boards:
                return NackCode.BAD_BOARD
            if not any(s.board == raw.board and s.slot == raw.slot for s in self._slots):
                return NackCode.BAD_SLOT
            return NackCode.BAD_MODE
        conversion = self.robot.motor(command.motor).modes.get(raw.mode)
        assert conversion is not None
        lo, hi = conversion.raw
        if not lo <= raw.raw_value <= hi:
            return NackCode.OUT_OF_RANGE
        return command

    def _setpoint(self, msg: Setpoint) -> None:
        if self.estopped:
            self._nack(msg.seq, MsgType.SETPOINT, NackCode.ESTOP_LATCHED)
            return
        result = self._convert(RawSetpoint(msg.board, msg.slot, msg.mode, msg.raw_value))
        if isinstance(result, NackCode):
            self._nack(msg.seq, MsgType.SETPOINT, result)
            return
        if not self._dedupe(msg.seq, MsgType.SETPOINT):
            return
        self._last_seq = msg.seq
        self._apply(result, msg.board)
        self._send(Ack(msg.seq, MsgType.SETPOINT))

    def _bulk(self, msg: BulkSetpoints) -> None:
        if self.estopped:
            self._nack(msg.seq, MsgType.BULK_SETPOINTS, NackCode.ESTOP_LATCHED)
            return
        commands: list[tuple[MotorCommand, int]] = []
        for slot, mode, raw_value in zip(self._slots, msg.modes, msg.raw_values, strict=True):
            if mode is None:
                continue
            result = self._convert(RawSetpoint(slot.board, slot.slot, mode, raw_value))
            if isinstance(result, NackCode):
                self._nack(msg.seq, MsgType.BULK_SETPOINTS, result)
                return
            commands.append((result, slot.board))
        if not self._dedupe(msg.seq, MsgType.BULK_SETPOINTS):
            return
        self._last_seq = msg.seq
        self._ack_seq = msg.seq
        for command, board in commands:
            self._apply(command, board)

    def _apply(self, command: MotorCommand, board: int) -> None:
        if board in self._resetting:
            self.frames_dropped += 1  # the board is rebooting and misses it
            return
        self.model.command(command)
        self.commands_executed += 1

    # -- time -----------------------------------------------------------------------

    def advance_to(self, now_s: float) -> None:
        """Run the world up to clock time ``now_s``: physics, faults, watchdog, STATE frames."""
        while self._next_frame_s <= now_s + 1e-12:
            t = self._next_frame_s
            self.now_s = t
            self._update_faults(t)
            self._watchdog(t)
            self.model.step(self.period_s)
            self._send_state()
            self._next_frame_s = t + self.period_s
        self.now_s = max(self.now_s, now_s)

    def _watchdog(self, now_s: float) -> None:
        if not self._armed or self.watchdog_tripped:
            return
        if now_s - self._last_rx_s > self.watchdog_s:
            self.watchdog_tripped = True
            self.watchdog_trips += 1
            self.model.stop_drives()
            self.model.record(EventKind.WATCHDOG, "host silent: drives stopped, clamps held")
            _log.warning("watchdog: host silent for %.3f s", now_s - self._last_rx_s)

    def _send_state(self) -> None:
        if self._link_lost:
            return
        if len(self._out) > MAX_PENDING_BYTES:
            # nobody reads: like a full serial buffer, newer frames are lost
            self.state_frames_unread += 1
            return
        values = self.model.reading_values()
        for index, frozen in self._stuck.items():
            values[index] = frozen
        if self._resetting or self._dropout:
            last = self._last_raw
            mask = 0
            resetting = self._resetting
            dropout = self._dropout
            for i, raw_value in enumerate(self._encode(values)):
                if i in dropout or self._channel_board[i] in resetting:
                    continue
                last[i] = raw_value
                mask |= 1 << i
            raw = tuple(last)
            self._raw_tuple = None  # the next unfaulted frame encodes afresh
        elif values == self._encoded_from and self._raw_tuple is not None:
            # Nothing changed since the last frame (the common case when the robot waits
            # or drives through a plain piece): the raw values are the same tuple, which
            # lets the codec reuse the packed frame.
            raw = self._raw_tuple
            mask = self._all_fresh
        else:
            self._last_raw = last = self._encode(values)
            raw = self._raw_tuple = tuple(last)
            mask = self._all_fresh
        if self._resetting or self.estopped:
            status: tuple[int, ...] = tuple(
                int(
                    (BoardStatus.TIMEOUT if board in self._resetting else BoardStatus.ONLINE)
                    | (BoardStatus.MOTORS_OFF if self.estopped else BoardStatus.NONE)
                )
                for board in self._boards
            )
        else:
            status = self._all_online
        flags = BridgeFlags.NONE
        if self.estopped:
            flags |= BridgeFlags.ESTOP
        if self.watchdog_tripped:
            flags |= BridgeFlags.WATCHDOG
        self._state_seq = (self._state_seq + 1) & 0xFFFF
        self._out += self.codec.encode_state(
            self._state_seq, flags, self._ack_seq, mask, status, raw
        )
        self.state_frames_sent += 1

    def _encode(self, values: list[float]) -> list[int]:
        """SI readings -> raw int16 values with the robot's conversions (saturating)."""
        previous = self._encoded_from
        if len(previous) != len(values):
            previous = [math.nan] * len(values)
        out = self._encoded or [0] * len(values)
        out = list(out)
        for i, value in enumerate(values):
            if value == previous[i]:
                continue  # unchanged channel: same raw value as last frame
            zero, inv, lo, hi = self._conversions[i]
            raw = round(value * inv + zero)
            out[i] = lo if raw < lo else hi if raw > hi else raw
        self._encoded_from = values
        self._encoded = out
        return list(out)

    def encode_readings(self, readings: dict[str, float]) -> list[int | None]:
        """The robot's :meth:`StateBuilder.encode` of SI readings by channel name."""
        return self._states.encode(readings)

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
