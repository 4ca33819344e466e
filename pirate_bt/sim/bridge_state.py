"""The simulated bridge's STATE frames: readings encoded, fresh mask, board status, flags.

:class:`StateFramesMixin` is the 100 Hz side of :class:`~pirate_bt.sim.bridge.SimBridge`:
once per state period it takes the model's readings (SI), applies the faults that act
on readings (a channel stuck, dropped out, or on a board that is resetting), encodes
them with the robot's conversions exactly as :meth:`StateBuilder.encode` does, and
queues the STATE frame for the host.
"""

from __future__ import annotations

import math

from pirate_bt.link.codec import BoardStatus, BridgeFlags, FrameCodec
from pirate_bt.link.messages import BridgeHeartbeat
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.state import StateBuilder
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["BRIDGE_HEARTBEAT_S", "MAX_PENDING_BYTES", "StateFramesMixin"]

MAX_PENDING_BYTES = 1 << 16
"""Bytes the bridge queues for a host that does not read before it drops state frames."""
BRIDGE_HEARTBEAT_S = 0.05
"""A bridge that has sent no frame for this long sends a BRIDGE_HEARTBEAT (docs/protocol.md;
the firmware's ``BRIDGE_HEARTBEAT_MS``): only with a state period over 50 ms."""


class StateFramesMixin:
    """The STATE frame side of the simulated bridge (mixed into ``SimBridge``)."""

    # set by the bridge
    model: PipeRobotModel
    codec: FrameCodec
    _states: StateBuilder
    _boards: list[int]
    _channel_board: list[int]
    _conversions: list[tuple[int, float, int, int]]
    _out: bytearray
    _last_raw: list[int]
    _all_fresh: int
    _encoded_from: list[float]
    _encoded: list[int]
    _raw_tuple: tuple[int, ...] | None
    _status_cache: tuple[int, ...] | None
    _resetting: set[int]
    _faulted: dict[int, dict[str, MotorCommand | None]]
    _motors_off: set[int]
    _dropout: set[int]
    _stuck: dict[int, float]
    _link_lost: bool
    _state_seq: int
    _ack_seq: int
    _beat_due_s: float
    now_s: float
    state_frames_sent: int
    state_frames_unread: int

    def _flags(self) -> BridgeFlags:
        raise NotImplementedError

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
        status = self._status_cache
        if status is None:
            status = self._status_cache = tuple(
                int(
                    (BoardStatus.TIMEOUT if board in self._resetting else BoardStatus.ONLINE)
                    | (BoardStatus.MOTORS_OFF if board in self._motors_off else BoardStatus.NONE)
                    | (BoardStatus.FAULT if board in self._faulted else BoardStatus.NONE)
                )
                for board in self._boards
            )
        flags = self._flags()
        self._state_seq = (self._state_seq + 1) & 0xFFFF
        self._out += self.codec.encode_state(
            self._state_seq, flags, self._ack_seq, mask, status, raw
        )
        self.state_frames_sent += 1
        self._beat_due_s = self.now_s + BRIDGE_HEARTBEAT_S

    def _send_heartbeat(self) -> None:
        """BRIDGE_HEARTBEAT, on the STATE frames' counter: nothing sent for 50 ms."""
        self._beat_due_s = self.now_s + BRIDGE_HEARTBEAT_S
        if self._link_lost or len(self._out) > MAX_PENDING_BYTES:
            return
        self._state_seq = (self._state_seq + 1) & 0xFFFF
        self._out += self.codec.encode(BridgeHeartbeat(self._state_seq, self._flags()))

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
