"""The PICO boards on the RS485 board bus, for the bridge firmware running in simavr.

In board-bus mode the bridge is not simulated in Python: the real PIRATEbay
firmware runs in an AVR simulator (``firmware/simavr/``, the *harness*), and only
the boards behind it are Python. :class:`BoardBus` answers the firmware's bus
requests (``docs/board-bus.md``, version 2) with the same pipe physics as the
Python simulator, :class:`~pirate_bt.sim.model.PipeRobotModel`: an ``EXCHANGE``
applies the board's setpoints (raw -> SI with the robot's own
:class:`~pirate_bt.robot.commands.CommandCodec`) and returns its status and its slice
of the readings (SI -> raw with :class:`~pirate_bt.robot.state.StateBuilder`); a
``STOP`` applies its setpoints silently and ends a board's own stop. A board that
hears nothing from the master for :data:`BOARD_SILENCE_S` stops itself (drives
braked, joints holding) and holds that stop until a ``STOP``, reporting
``OWN_STOP`` meanwhile, as the reference PICO firmware (``firmware/pico/``) does:
both pass the same byte-level vectors (``tests/data/board_bus_vectors.json``,
:mod:`pirate_bt.sim.board_vectors`).

Time comes from the AVR: every bus frame carries the MCU cycle at which its last
byte left, and the physics steps one state period at a time up to that instant,
so the pipe moves in step with the firmware's clock even when the host machine
cannot keep simavr in real time.

:class:`~pirate_bt.sim.firmware_bridge.FirmwareBridge` runs the harness as a child
process with these boards on its bus.
"""

from __future__ import annotations

import logging
import struct
from collections import Counter
from collections.abc import Iterable

from pirate_bt.errors import FrameError, InputError
from pirate_bt.link.codec import MODE_CODES, MODE_KEEP, cobs_decode, cobs_encode, crc16
from pirate_bt.link.layout import StopRole, stop_role
from pirate_bt.robot.commands import CommandCodec, RawSetpoint
from pirate_bt.robot.description import ControlMode, Motor
from pirate_bt.robot.state import StateBuilder
from pirate_bt.sim.model import PipeRobotModel

__all__ = [
    "BOARD_SILENCE_S",
    "BUS_CLOCK_HZ",
    "CMD_EXCHANGE",
    "CMD_STOP",
    "STATUS_FAULT",
    "STATUS_MOTORS_OFF",
    "STATUS_OWN_STOP",
    "STATUS_STALE",
    "BoardBus",
]

_log = logging.getLogger(__name__)

BUS_CLOCK_HZ = 16_000_000
"""The ATmega2560's clock: bus frames are stamped in its cycles."""

CMD_EXCHANGE = 0x01
CMD_STOP = 0x02
STATUS_FAULT = 0x01
STATUS_MOTORS_OFF = 0x02
"""A motor of the board was never commanded since its boot (it coasts)."""
STATUS_OWN_STOP = 0x04
"""The board stopped itself (the master fell silent) and holds that stop until a STOP."""
STATUS_STALE = 0x08
"""A sensor of the board has not been read within its time: the reply carries its last
good values, and the bridge leaves the board's sensor channels not fresh."""
BOARD_SILENCE_S = 0.1
"""A board that hears no frame addressed to it for this long stops itself."""
_REPLY = 0x80
_MAX_BODY = 32
_MODE_BY_CODE = {code: mode for mode, code in MODE_CODES.items()}


class BoardBus:
    """The robot's PICO boards: bus requests in, bus replies out, physics in step.

    Args:
        model: The robot-in-pipe model the boards drive and read.
        silent: Board ids that never answer (a disconnected board).
        board_timeout: Boards stop themselves after :data:`BOARD_SILENCE_S` without a
            frame addressed to them. Off behind the real-time simavr harness, which
            answers a repeated exchange itself and does not pass it on.
    """

    def __init__(
        self, model: PipeRobotModel, *, silent: Iterable[int] = (), board_timeout: bool = True
    ) -> None:
        robot = model.robot
        self.model = model
        self.robot = robot
        self.period_s = robot.bridge.state_period
        self._commands = CommandCodec(robot)
        self._states = StateBuilder(robot)
        channels = robot.state_channels()
        self._slots: dict[int, list[int]] = {b: [] for b in robot.board_ids()}
        self._motors: dict[tuple[int, int], Motor] = {}
        for slot in robot.setpoint_slots():
            self._slots[slot.board].append(slot.slot)
            self._motors[(slot.board, slot.slot)] = slot.motor
        self._channel_range: dict[int, tuple[int, int]] = {}
        for i, channel in enumerate(channels):
            lo, _ = self._channel_range.get(channel.board, (i, i))
            self._channel_range[channel.board] = (lo, i + 1)
        self.silent: set[int] = set(silent)
        self.now_s = model.time_s
        self.board_timeout = board_timeout
        self.own_stop: set[int] = set()
        """Boards holding their own stop (the master fell silent), until a STOP."""
        self.own_stops = 0
        self.stale: dict[int, dict[int, int]] = {}
        """Boards whose IMU is not being read (:meth:`set_stale`): the IMU channels'
        values (by index in the board's reply) their replies carry meanwhile."""
        imu = robot.imu()
        imu_names = {f"{imu.name}.{axis}" for axis in imu.axes} if imu else set()
        self._imu_channels = {c.index for c in channels if c.name in imu_names}
        self._heard_s = dict.fromkeys(self._slots, self.now_s)
        self._state: dict[tuple[int, int], tuple[int, int]] = {}
        self._pinned: dict[int, list[int]] = {}
        self._next_step_s = self.now_s + self.period_s
        self._raw: list[int] | None = None
        self.steps = 0
        # figures: the frames this object handled. Behind the simavr harness that is
        # not every frame on the bus (a frame repeating the last one to its board is
        # not forwarded); the harness's own figures (bus_replies, bus_stops) count all.
        self.exchanges = 0
        self.stops = 0
        self.bad_frames = 0
        self.unanswered = 0
        self.setpoints_applied = 0
        self.applied: Counter[tuple[int, int, int, int]] = Counter()
        """(board, slot, mode code, raw value) of every setpoint applied, with counts."""

    def advance_to(self, now_s: float) -> None:
        """Step the physics, one state period at a time, up to ``now_s``; boards that
        heard no master for :data:`BOARD_SILENCE_S` stop themselves on the way."""
        while self._next_step_s <= now_s + 1e-12:
            self._check_silence(self._next_step_s)
            self.model.step(self.period_s)
            self._next_step_s += self.period_s
            self._raw = None
            self.steps += 1
        self.now_s = max(self.now_s, now_s)
        self._check_silence(self.now_s)

    def _check_silence(self, now_s: float) -> None:
        if not self.board_timeout:
            return
        for board, heard in self._heard_s.items():
            if board not in self.own_stop and now_s - heard > BOARD_SILENCE_S + 1e-9:
                self.own_stop.add(board)
                self.own_stops += 1
                self._raw = None
                self._stop_board(board)
                _log.info("board %d heard no master for %.3f s: own stop", board, now_s - heard)

    def _stop_board(self, board: int) -> None:
        """The stop category in the board's own modes: brake, joints hold."""
        for slot in self._slots[board]:
            motor = self._motors[(board, slot)]
            role = stop_role(motor)
            if role is StopRole.BEND:
                continue
            if motor.modes.pwm is not None:
                self._command(board, slot, MODE_CODES[ControlMode.PWM], 0)
            elif role is StopRole.DRIVE:
                self._command(board, slot, MODE_CODES[ControlMode.VELOCITY], 0)

    def handle(self, now_s: float, encoded: bytes) -> bytes:
        """One frame from the bridge (COBS, no delimiter) at ``now_s``; the wire reply or b"".

        A frame that does not decode, fails its CRC, is addressed to no board or
        carries a payload of the wrong length is ignored, as a board would.
        """
        self.advance_to(now_s)
        try:
            body = cobs_decode(encoded)
        except FrameError:
            self.bad_frames += 1
            return b""
        if (
            len(body) < 4
            or len(body) > _MAX_BODY
            or crc16(body[:-2]) != int.from_bytes(body[-2:], "little")
        ):
            self.bad_frames += 1
            return b""
        addr, cmd, payload = body[0], body[1], body[2:-2]
        slots = self._slots.get(addr)
        if slots is None or cmd not in (CMD_EXCHANGE, CMD_STOP) or len(payload) != 3 * len(slots):
            self.bad_frames += 1
            return b""
        if addr in self.silent:
            self.unanswered += 1
            return b""
        self._heard_s[addr] = now_s
        if cmd == CMD_STOP:
            self.own_stop.discard(addr)  # the master took over the stop
            self._apply(addr, slots, payload)
            self.stops += 1
            return b""
        if addr not in self.own_stop:
            self._apply(addr, slots, payload)
        self.exchanges += 1
        return self._reply(addr)

    def _apply(self, board: int, slots: list[int], payload: bytes) -> None:
        for slot, (code, raw_value) in zip(slots, struct.iter_unpack("<Bh", payload), strict=True):
            if code != MODE_KEEP:
                self._command(board, slot, code, raw_value)

    def _command(self, board: int, slot: int, code: int, raw_value: int) -> None:
        mode = _MODE_BY_CODE.get(code)
        conversion = None if mode is None else self._motors[(board, slot)].modes.get(mode)
        if mode is None or conversion is None:
            _log.warning("board %d slot %d: mode code %d refused", board, slot, code)
            return
        lo, hi = conversion.raw
        if not lo <= raw_value <= hi:
            _log.warning(
                "board %d slot %d: %d outside %d..%d refused", board, slot, raw_value, lo, hi
            )
            return
        try:
            command = self._commands.to_si(RawSetpoint(board, slot, mode, raw_value))
        except InputError as exc:
            _log.warning("board %d: %s", board, exc)
            return
        self.model.command(command)
        self._state[(board, slot)] = (code, raw_value)
        self.setpoints_applied += 1
        self.applied[(board, slot, code, raw_value)] += 1

    def motor_state(self, board: int, slot: int) -> tuple[int, int] | None:
        """(mode code, raw value) motor ``slot`` of ``board`` executes; None: never commanded."""
        return self._state.get((board, slot))

    def status(self, board: int) -> int:
        """The status byte of ``board``'s reply (``STATUS_*`` bits)."""
        status = 0
        if any((board, slot) not in self._state for slot in self._slots[board]):
            status |= STATUS_MOTORS_OFF
        if board in self.own_stop:
            status |= STATUS_OWN_STOP
        if board in self.stale:
            status |= STATUS_STALE
        return status

    def set_readings(self, board: int, raw: Iterable[int] | None) -> None:
        """Pin ``board``'s replies to these raw channel values (None: the physics again).

        For the shared vectors, where a reply's bytes are given.
        """
        if raw is None:
            self._pinned.pop(board, None)
        else:
            self._pinned[board] = list(raw)

    def set_stale(self, board: int, stale: bool = True) -> None:
        """``board``'s IMU stops answering (True) or answers again (False): meanwhile its
        replies say ``STALE`` and carry the IMU's values of the moment it stopped (its
        other channels go on), as the PICO firmware's do."""
        if not stale:
            self.stale.pop(board, None)
        elif board not in self.stale:
            lo, hi = self._channel_range.get(board, (0, 0))
            now = self._readings(board, lo, hi)
            self.stale[board] = {i - lo: now[i - lo] for i in self._imu_channels if lo <= i < hi}

    def raw_readings(self) -> list[int]:
        """Every state channel's raw value now, in layout order (computed once per period)."""
        if self._raw is None:
            encoded = self._states.encode(self.model.readings())
            self._raw = [0 if v is None else v for v in encoded]
        return self._raw

    def replies(self) -> dict[int, bytes]:
        """Every board's reply to an EXCHANGE now (wire bytes; b"" for a silent board)."""
        return {b: b"" if b in self.silent else self._reply(b) for b in self._slots}

    def _readings(self, board: int, lo: int, hi: int) -> list[int]:
        return list(self._pinned.get(board) or self.raw_readings()[lo:hi])

    def _reply(self, board: int) -> bytes:
        lo, hi = self._channel_range.get(board, (0, 0))
        readings = self._readings(board, lo, hi)
        for i, value in self.stale.get(board, {}).items():
            readings[i] = value
        body = bytes((board, CMD_EXCHANGE | _REPLY, self.status(board))) + struct.pack(
            f"<{len(readings)}h", *readings
        )
        body += crc16(body).to_bytes(2, "little")
        return cobs_encode(body) + b"\x00"
