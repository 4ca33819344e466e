"""The STATE frames the session took, as :class:`~pirate_bt.robot.state.RobotState`
snapshots (split out of :mod:`pirate_bt.link.robot_link`).

:class:`Snapshots` builds the newest snapshot when a newer ``STATE`` is in, folding in
the ones taken since the last snapshot where the newest marks a channel not fresh, and
checks every reading against its raw range (:class:`~pirate_bt.link.ranges.ReadingRanges`).
"""

from __future__ import annotations

from pirate_bt.link.codec import State
from pirate_bt.link.ranges import ReadingRanges
from pirate_bt.link.session import Session
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState, StateBuilder

__all__ = ["Snapshots"]


class Snapshots:
    """The snapshots of one link's ``STATE`` frames, built as they are asked for."""

    def __init__(self, robot: RobotDescription) -> None:
        self._states = StateBuilder(robot)
        self.ranges = ReadingRanges(robot)  # a reading outside its raw range is refused
        self.snapshot: RobotState | None = None
        self._snapshot_seq: int | None = None
        self._snapshot_frame: State | None = None

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
        return self.snapshot

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
