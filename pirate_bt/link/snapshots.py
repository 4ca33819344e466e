"""The STATE frames the session took, as :class:`~pirate_bt.robot.state.RobotState`
snapshots (split out of :mod:`pirate_bt.link.robot_link`).

:class:`Snapshots` builds the newest snapshot when a newer ``STATE`` is in, folding in
the ones taken since the last snapshot where the newest marks a channel not fresh, and
checks every reading against its raw range (:class:`~pirate_bt.link.ranges.ReadingRanges`).
:meth:`Snapshots.between` builds, when asked, the snapshots of the STATEs taken between
two newest ones (the host ticks at 20 Hz, STATEs come at 100 Hz): the supervisor's
protective hold reads each of them, so that a slide in a riser is seen in the STATE it
shows in, not one or two ticks later.
"""

from __future__ import annotations

import collections

from pirate_bt.link.codec import State
from pirate_bt.link.ranges import ReadingRanges
from pirate_bt.link.session import Session
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState, StateBuilder

__all__ = ["BUILT_KEPT", "Snapshots"]

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
