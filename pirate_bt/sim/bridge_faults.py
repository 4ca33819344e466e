"""Faults of the simulated bridge and its boards: stalls, sensor dropouts, board resets and
faults, link loss.

:class:`FaultsMixin` is the fault side of :class:`~pirate_bt.sim.bridge.SimBridge`:
it checks a fault's target against the robot, keeps the schedule, and starts and
ends each fault at its simulated time (a stalled motor, a sensor that drops out or
sticks, a board that resets: motors off, readings missing, setpoints refused with
``BUS_ERROR`` for ``bridge.reset_time``; a board fault, an H-bridge fault or
over-current: the board answers with ``FAULT`` in its status and its motors are off
while it lasts; link loss: nothing in, nothing out).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass

from pirate_bt.link.raw import RawFrameDecoder
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import MotorFunction, RobotDescription
from pirate_bt.sim.counters import EventKind
from pirate_bt.sim.faults import check_fault_target
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["BOARD_AWAY_S", "ActiveFault", "FaultsMixin"]

_log = logging.getLogger("pirate_bt.sim.bridge")

BOARD_AWAY_S = 0.1
"""A board the bridge has had no answer from for longer has stopped on its own, or lost
its power: the whole robot stops, once an absence, as on its ``OWN_STOP``
(docs/board-bus.md; ``BOARD_AWAY_MS`` in firmware/piratebay/poller.c)."""


@dataclass
class ActiveFault:
    """A fault that has started, and when it ends."""

    spec: FaultSpec
    end_s: float
    started: bool = False
    frozen: float | None = None


class FaultsMixin:
    """The fault side of the simulated bridge (mixed into ``SimBridge``)."""

    # set by the bridge
    model: PipeRobotModel
    robot: RobotDescription
    now_s: float
    _channel_index: dict[str, int]
    _boards: list[int]
    _decoder: RawFrameDecoder
    _pending: list[FaultSpec]
    _active: list[ActiveFault]
    _resetting: set[int]
    _held_setpoints: dict[int, list[MotorCommand]]
    _board_timeouts: dict[int, int]
    _board_retries: dict[int, int]
    _heard_s: dict[int, float]
    _all_heard_s: float
    _away: set[int]
    _bus_fault: bool
    _faulted: dict[int, dict[str, MotorCommand | None]]
    _dropout: set[int]
    _stuck: dict[int, float]
    _link_lost: bool
    _lost_partial: bool
    _status_cache: tuple[int, ...] | None
    frames_dropped: int

    def _drop(self, data: bytes) -> None:
        """Bytes lost to an injected link loss: count each host frame they end.

        A frame is a non-empty run of bytes before a delimiter, as a receiver sees it:
        lone delimiters and empty frames are none, and a frame whose first bytes came
        before the loss (or in an earlier read) counts once, where its delimiter is lost.
        """
        *ended, tail = data.split(b"\x00")
        partial = self._lost_partial or self._decoder.pending_bytes > 0
        for part in ended:
            if part or partial:
                self.frames_dropped += 1
            partial = False
        if ended:
            self._decoder.reset()  # the frame it held ended unseen
        self._lost_partial = partial or bool(tail)

    def check_fault(self, fault: FaultSpec) -> None:
        """Check that a fault's target exists on this robot.

        Raises:
            FaultTargetError: unknown motor, channel or board (a ``ConfigurationError``).
        """
        check_fault_target(fault, self.robot)

    def schedule(self, faults: Iterable[FaultSpec]) -> None:
        """Add faults to inject at their simulated times.

        Raises:
            FaultTargetError: a fault names a motor, channel or board the robot lacks.
        """
        faults = list(faults)
        for fault in faults:  # all or none: a refused list schedules nothing
            self.check_fault(fault)
        self._pending.extend(faults)
        self._pending.sort(key=lambda f: f.at)

    def _update_faults(self, now_s: float) -> None:
        while self._pending and self._pending[0].at <= now_s:
            spec = self._pending.pop(0)
            duration = spec.duration
            if duration is None:
                duration = self.robot.bridge.reset_time if spec.kind == "board_reset" else math.inf
            fault = ActiveFault(spec, spec.at + duration)
            self._active.append(fault)
            self._start_fault(fault)
        for fault in [f for f in self._active if f.end_s <= now_s]:
            self._active.remove(fault)
            self._end_fault(fault)
        if self._faulted:
            self._hold_faulted()

    def _apply_stop(self) -> None:
        raise NotImplementedError

    def _poll_boards(self, now_s: float) -> None:
        """This period's poll of every board: a board that is rebooting does not answer.

        A poll that gets no answer counts as the firmware's does (docs/board-bus.md):
        a timeout, a retry, and the retry's timeout (one board away leaves the period
        the time to retry it). A board not heard for more than
        :data:`BOARD_AWAY_S` (from its last answer, or the bridge's boot) stops the whole
        robot once an absence, as the firmware bridge does: the stop category, so when it
        answers again it gets the stop setpoints (its drive braked, its clamp back), not
        the ones it had. A period in which no board answers sets ``BUS_FAULT`` until
        one answers again, as the firmware's cycle with no answer does.
        """
        # BUS_FAULT: no board answered this period's poll cycle (docs/protocol.md, bridge
        # flags; the firmware's finish_cycle): every board rebooting at once
        self._bus_fault = bool(self._resetting) and self._resetting.issuperset(self._boards)
        if not self._resetting:
            self._all_heard_s = now_s  # every board answered
            if self._away:
                self._away.clear()
            return
        for board in self._boards:
            if board not in self._resetting:
                self._heard_s[board] = now_s
                self._away.discard(board)
                continue
            self._board_timeouts[board] += 2
            self._board_retries[board] += 1
            heard_s = max(self._heard_s[board], self._all_heard_s)
            if board not in self._away and now_s - heard_s > BOARD_AWAY_S + 1e-9:
                self._away.add(board)
                self._apply_stop()
                self.model.record(
                    EventKind.BOARD_AWAY,
                    f"board {board} not heard for {BOARD_AWAY_S * 1000:.0f} ms: "
                    "drives and rotation stopped, clamps held",
                )
                _log.warning("board %d not heard since %.3f s: robot stopped", board, heard_s)

    def _hold_faulted(self) -> None:
        """Keep a faulted board's motors off before the physics steps.

        The bridge still delivers setpoints to a board in ``FAULT`` (only a board in
        ``TIMEOUT`` cannot be reached), and the board takes them, but its H-bridge is
        off: each setpoint that came since the last step is kept as the one the board
        holds, and its motor is switched off again.
        """
        model = self.model
        for held in self._faulted.values():
            off = []
            for name in held:
                command = model.setpoint(name)
                if command is not None:
                    held[name] = command
                    off.append(name)
            if off:
                model.motors_off(off)

    def _start_fault(self, fault: ActiveFault) -> None:
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
            # a second stuck fault over the first keeps the value the first froze
            self._stuck.setdefault(index, self.model.readings()[target])
        elif spec.kind == "board_reset":
            board = int(target)
            self._resetting.add(board)
            self._status_cache = None
            names = self._board_motors(board)
            # The bridge keeps its setpoints for the board's motors and hands them to
            # it at every exchange (firmware/piratebay/poller.c), so the board gets them
            # back as soon as it answers again: its clamp comes back (its drive stopped,
            # if it was away past BOARD_AWAY_S: _poll_boards). A second reset
            # while the board is still down keeps what the first held (its motors are
            # off by then: there is nothing newer to hold).
            if board not in self._held_setpoints:
                # a board in FAULT holds the setpoints it was given with its H-bridge
                # off: those, not its motors' (off), are what it gets back
                faulted = self._faulted.get(board, {})
                held = [faulted.get(name) or self.model.setpoint(name) for name in names]
                self._held_setpoints[board] = [c for c in held if c is not None]
            self.model.motors_off(names)
        elif spec.kind == "board_fault":
            board = int(target)
            self._status_cache = None
            holds = self._faulted.setdefault(board, {})
            for m in self._board_motors(board):
                holds.setdefault(m, None)
            self._hold_faulted()
        elif spec.kind == "link_loss":
            self._link_lost = True

    def _board_motors(self, board: int) -> list[str]:
        return [m.name for m in self.robot.board(board).motors]

    def _is_bend(self, motor: str) -> bool:
        return self.robot.motor(motor).function is MotorFunction.BEND

    def _end_fault(self, fault: ActiveFault) -> None:
        spec = fault.spec
        target = spec.target or ""
        self.model.record(EventKind.FAULT, f"end {spec.kind} {target}".strip())
        if any(f.spec.kind == spec.kind and f.spec.target == spec.target for f in self._active):
            # another fault of the same kind and target goes on: the first to end undoes
            # nothing (two overlapping resets left a clamp board's motors off for good)
            return
        if spec.kind == "motor_stall":
            self.model.set_stalled(target, False)
        elif spec.kind == "sensor_dropout":
            self._dropout.discard(self._channel_index[target])
        elif spec.kind == "sensor_stuck":
            self._stuck.pop(self._channel_index[target], None)
        elif spec.kind == "board_reset":
            board = int(target)
            self._resetting.discard(board)
            self._status_cache = None
            for command in self._held_setpoints.pop(board, []):
                if self.model.setpoint(command.motor) is None or self._is_bend(command.motor):
                    # what the bridge kept for it: a stop of the bridge's during the reset
                    # (the board's own absence past BOARD_AWAY_S among them) made them the
                    # stop setpoints, a bend joint's its own
                    self.model.command(command)
        elif spec.kind == "board_fault":
            board = int(target)
            self._status_cache = None
            # the H-bridge is back on: the board drives its motors to the setpoints it
            # holds (the latest it was given, a stop's included); a board still
            # rebooting drives nothing until its reset ends, which hands them back
            kept = self._faulted.pop(board, {})
            if board in self._resetting:
                held = self._held_setpoints.setdefault(board, [])
                have = {c.motor for c in held}
                held.extend(c for c in kept.values() if c is not None and c.motor not in have)
                return
            for setpoint in kept.values():
                if setpoint is not None:
                    self.model.command(setpoint)
        elif spec.kind == "link_loss":
            self._link_lost = False
            self._lost_partial = False
            self._decoder.reset()
