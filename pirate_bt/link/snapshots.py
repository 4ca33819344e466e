"""The STATE frames the session took, as :class:`~pirate_bt.robot.state.RobotState`
snapshots (split out of :mod:`pirate_bt.link.robot_link`).

:class:`Snapshots` builds the newest snapshot when a newer ``STATE`` is in, folding in
the ones taken since the last snapshot where the newest marks a channel not fresh, and
checks every reading against its raw range (:class:`~pirate_bt.link.ranges.ReadingRanges`).
:meth:`Snapshots.between` builds, when asked, the snapshots of the STATEs taken between
two newest ones (the host ticks at 20 Hz, STATEs come at 100 Hz): the supervisor's
protective hold reads each of them, so that a slide in a riser is seen in the STATE it
shows in, not one or two ticks later.
:class:`AppliedSetpoints` keeps the ``BULK_SETPOINTS`` sent and tells, from the newest
``STATE``'s ``ack_seq``, which setpoint each motor's board holds: the stalled-joint
watch waits for a joint only once its board has the setpoint (a setpoint lost or late
on a lossy link is no stall).
"""

from __future__ import annotations

import collections

from pirate_bt.link.codec import BulkSetpoints, State
from pirate_bt.link.ranges import ReadingRanges
from pirate_bt.link.session import Session
from pirate_bt.robot.commands import CommandCodec, MotorCommand, RawSetpoint
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.robot.state import RobotState, StateBuilder

__all__ = ["BUILT_KEPT", "SENT_KEPT", "AppliedSetpoints", "Snapshots"]

BUILT_KEPT = 16
"""Newest snapshots :meth:`Snapshots.current` built that :meth:`Snapshots.between` can
start from (a tick asks for a few; a reader thread may take several STATEs in one)."""


class Snapshots:
    """The snapshots of one link's ``STATE`` frames, built as they are asked for."""

    def __init__(self, robot: RobotDescription) -> None:
        self._states = StateBuilder(robot)
        self.ranges = ReadingRanges(robot)  # a reading outside its raw range is refused
        self.snapshot: RobotState | None = None
        self._snapshot_seq: int | None = None
        self._snapshot_frame: State | None = None
        # (frame, its snapshot) for the newest snapshots built, newest last (see between)
        self._built: collections.deque[tuple[State, RobotState]] = collections.deque(
            maxlen=BUILT_KEPT
        )

    def current(self, session: Session) -> RobotState | None:
        """The snapshot of the session's newest ``STATE``, or ``None`` before the first."""
        latest = session.latest_state()
        if latest is None:
            return None
        frame, arrived_s = latest
        if frame.seq != self._snapshot_seq:
            raw = self.ranges.readings(frame)
            if None in raw:
                self._fold_missed(session, frame)
            self.snapshot = self._states.build(raw, arrived_s, self.snapshot)
            self._snapshot_seq = frame.seq
            self._snapshot_frame = frame
            self._built.append((frame, self.snapshot))
        return self.snapshot

    def between(
        self, session: Session, after: RobotState, newest: RobotState
    ) -> tuple[RobotState, ...]:
        """Snapshots of the STATEs the session took after the one ``after`` was built
        from and before the one ``newest`` was built from (both returned by
        :meth:`current`), oldest first: each built on the one before, as
        :meth:`current` would have built it had it been asked then. Empty when either
        is not one of the last :data:`BUILT_KEPT` built, when ``newest`` is not newer,
        or when the STATEs between are no longer kept (the session keeps
        :data:`~pirate_bt.link.inbound.STATES_KEPT`: the oldest of them then). A reading
        outside its raw range is refused again, not counted or logged twice."""
        if after is newest:
            return ()
        after_frame = newest_frame = None
        for frame, snapshot in reversed(self._built):
            if snapshot is newest:
                newest_frame = frame
            elif snapshot is after:
                after_frame = frame
                break
        if after_frame is None or newest_frame is None:
            return ()
        taken = session.states_taken()
        end = start = -1
        for i in range(len(taken) - 1, -1, -1):
            frame = taken[i][0]
            if frame is newest_frame:
                end = i
            elif frame is after_frame:
                start = i
                break
        if end < 0:
            return ()
        out: list[RobotState] = []
        previous = after
        for frame, at_s in taken[start + 1 : end]:
            raw = self.ranges.readings(frame, quiet=True)
            previous = self._states.build(raw, at_s, previous)
            out.append(previous)
        return tuple(out)

    def _fold_missed(self, session: Session, newest: State) -> None:
        """Fold into the snapshot, oldest first, the STATEs taken since it was built and
        before ``newest``: a channel ``newest`` does not mark fresh keeps the reading of
        the last STATE that did, with that STATE's arrival as its stamp, not an older
        one's (a bridge whose poll cycle spans several state periods)."""
        taken = session.states_taken()
        start = 0
        for i in range(len(taken) - 1, -1, -1):
            if taken[i][0] is self._snapshot_frame:
                start = i + 1
                break
        for frame, at_s in taken[start:]:
            if frame is newest:
                break
            raw = self.ranges.readings(frame, older=True)  # checked after the newest
            self.snapshot = self._states.build(raw, at_s, self.snapshot)


SENT_KEPT = 64
"""Newest ``BULK_SETPOINTS`` :class:`AppliedSetpoints` keeps to match an ``ack_seq``
with (a tick sends one or a few; a STATE acknowledges one a few ticks old at most)."""


class AppliedSetpoints:
    """Which setpoint each motor's board holds, as the newest ``STATE`` tells.

    A ``STATE``'s ``ack_seq`` names the last ``BULK_SETPOINTS`` the bridge applied
    (docs/protocol.md), a superseded one too: the host matches only the newest bulk
    with it for its outcome, but the bridge applied each bulk it names, whole (its
    keep entries left as they were). ``0`` (a new session) is none: the bridge holds its
    stop. A bulk not among the :data:`SENT_KEPT` newest sent leaves the table as it was.
    """

    def __init__(self, robot: RobotDescription) -> None:
        self._codec = CommandCodec(robot)
        slots = robot.setpoint_slots()
        self._slots = [(s.board, s.slot) for s in slots]
        self._index = {s.motor.name: i for i, s in enumerate(slots)}
        self._sent: dict[int, BulkSetpoints] = {}  # by seq, oldest first
        self._ack: int | None = None  # the ack_seq the table below is of
        self._modes: list[ControlMode | None] = [None] * len(slots)
        self._raw: list[int] = [0] * len(slots)
        self._si: dict[tuple[int, ControlMode, int], MotorCommand] = {}

    def sent(self, bulk: BulkSetpoints) -> None:
        """Keep ``bulk``, just sent, to be matched with a later ``ack_seq``."""
        sent = self._sent
        sent.pop(bulk.seq, None)  # a seq come round again: the newest is the one
        sent[bulk.seq] = bulk
        if len(sent) > SENT_KEPT:
            del sent[next(iter(sent))]

    def applied(self, session: Session, motor: str) -> MotorCommand | None:
        """The setpoint ``motor``'s board holds by the session's newest ``STATE``, in SI;
        ``None`` when none is known (nothing applied in this session, or only keep)."""
        latest = session.latest_state()
        ack = 0 if latest is None else latest[0].ack_seq
        if ack != self._ack:
            self._take(ack)
        i = self._index[motor]
        mode = self._modes[i]
        if mode is None:
            return None
        key = (i, mode, self._raw[i])
        command = self._si.get(key)
        if command is None:
            board, slot = self._slots[i]
            command = self._codec.to_si(RawSetpoint(board, slot, mode, self._raw[i]))
            if len(self._si) > 4 * SENT_KEPT:
                self._si.clear()
            self._si[key] = command
        return command

    def _take(self, ack: int) -> None:
        self._ack = ack
        if ack == 0:
            self._modes = [None] * len(self._modes)
            return
        bulk = self._sent.get(ack)
        if bulk is None:
            return
        modes, raw = self._modes, self._raw
        for i, mode in enumerate(bulk.modes):
            if mode is not None:
                modes[i] = mode
                raw[i] = bulk.raw_values[i]
