"""Boards the bridge cannot reach (``TIMEOUT`` in its ``STATE``): when the link stops
waiting for one and refuses a command for it (docs/protocol.md, Bridge flags).

The bridge marks a board ``TIMEOUT`` after one missed exchange and its retry
(firmware/piratebay/poller.c), so one lost reply on the RS485 bus shows as a
``STATE`` period or two of ``TIMEOUT``; a rebooting board shows it for its whole reset.
The bridge refuses a bulk with an entry for such a board (``BUS_ERROR``), so the link
sends the board's entries as keep. A command for it is **deferred**, not refused: the
link keeps it in its table and sends the table again as soon as a ``STATE`` shows the
board back. A command for a board away for good is refused (``LinkError``): one whose
every reading is stale (``safety.stale_after_periods`` times its period, at the
arrival of the newest ``STATE``) in the ``RobotState`` the link last gave, if that
one was made while the board was away, or else for longer than the freshness limit
of its slowest reading since the last ``STATE`` that showed it answering (no reading
can be fresher than that ``STATE``). Either way a supervisor that checks the
freshness of the link's ``RobotState`` at its tick's time (no earlier) before its tree
sends has stopped on *stale data* by then: a board that stays away ends a run the same
way whenever the tree sends, and one lost reply ends none.
"""

from __future__ import annotations

import math

from pirate_bt.link.codec import BoardStatus
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState

__all__ = ["BoardsAway", "away_since", "not_answering", "stale_because_away"]

_TIMEOUT = int(BoardStatus.TIMEOUT)


def away_since(
    away: tuple[tuple[int, float], ...],
    status: tuple[int, ...],
    last: tuple[int, ...] | None,
    last_s: float,
    now: float,
) -> tuple[tuple[int, float], ...]:
    """The session's ``boards_away`` for a ``STATE`` of board ``status`` arriving at
    ``now``, after one of board status ``last`` (``None``: none) that arrived at
    ``last_s``, with ``away`` the boards away before it: for each board in ``TIMEOUT``,
    its position in the frame's board order and the arrival of the last ``STATE`` that
    showed it answering (or of this one, when none did)."""
    since = dict(away)
    out: list[tuple[int, float]] = []
    for i, s in enumerate(status):
        if s & _TIMEOUT:
            if i not in since:
                # newly away: last seen answering in the STATE before this one
                seen = last is not None and not last[i] & _TIMEOUT
                since[i] = last_s if seen else now
            out.append((i, since[i]))
    return tuple(out)


class BoardsAway:
    """The freshness limits of each board's readings, and the boards with a deferred command.

    Args:
        robot: The robot description (board order, channel periods, freshness factor).

    Attributes:
        owed: Boards with a command deferred while they were away: the table goes out
            again when one is back.
        longest_grace_s: The longest a board can be away before a command for it is
            refused (the slowest reading's freshness limit).
    """

    def __init__(self, robot: RobotDescription) -> None:
        self._ids = robot.board_ids()  # the STATE frame's board order
        factor = robot.safety.stale_after_periods
        self._frame_limit_s = factor * robot.bridge.state_period
        periods = robot.channel_periods_s()
        limits: dict[int, list[tuple[str, float]]] = {b: [] for b in self._ids}
        for channel in robot.state_channels():
            period = periods.get(channel.name, robot.bridge.state_period)
            limits[channel.board].append((channel.name, factor * period))
        self._limits = limits
        # the slowest reading's limit (at least a state period's): since the board last
        # answered, every reading of it is stale after that
        self._grace_s = {
            b: max([self._frame_limit_s, *(limit for _, limit in limits[b])]) for b in self._ids
        }
        self.owed: set[int] = set()
        self.longest_grace_s = max(self._grace_s.values(), default=self._frame_limit_s)

    def by_id(self, away: tuple[tuple[int, float], ...]) -> dict[int, float]:
        """The session's ``boards_away()`` (positions) by board id."""
        ids = self._ids
        return {ids[i]: since for i, since in away if i < len(ids)}

    def overdue(
        self,
        away: dict[int, float],
        boards: set[int],
        state: RobotState | None,
        at_s: float,
    ) -> list[tuple[int, float, bool]]:
        """``(board, seconds, fresh)`` for each of ``boards`` away for good (see the
        module): the seconds since a ``STATE`` last showed it answering, or the age of its
        freshest reading; ``fresh`` when its readings still came fresh all the while (a
        bridge that marks it ``TIMEOUT`` yet passes its readings on), so that the
        seconds are no readings' age.

        Args:
            away: The boards away (:meth:`by_id`), with the last time each answered.
            boards: The boards to judge.
            state: The ``RobotState`` the link last gave (``None``: none yet).
            at_s: The arrival time of the newest ``STATE``.
        """
        out: list[tuple[int, float, bool]] = []
        for board in sorted(boards & away.keys()):
            since = away[board]
            gone = at_s - since
            limits = self._limits[board]
            ages = [(state.age_s(n, at_s), limit) for n, limit in limits] if state else []
            if gone > self._grace_s[board]:
                out.append((board, gone, any(age <= limit for age, limit in ages)))
                continue
            if (
                ages
                and state is not None
                and state.stamp_s > since
                and all(age > limit for age, limit in ages)
            ):
                out.append((board, min(age for age, _ in ages), False))
        return out


def not_answering(late: list[tuple[int, float, bool]], what: str) -> str:
    """The link's refusal of a command for boards away for good (:meth:`BoardsAway.overdue`),
    for people: *board 22 is not answering the bridge (TIMEOUT, readings 0.110 s old:
    rebooting?): its setpoints cannot be delivered*."""
    age = max(t for _, t, _ in late)
    boards = ", ".join(str(b) for b, _, _ in late)
    if any(fresh for _, _, fresh in late):
        # before 2026-11-30 said "readings 5.100 s old" of readings fresh in every frame
        return (
            f"board {boards} is not answering the bridge (TIMEOUT in every STATE for"
            f" {age:.3f} s, though the readings came fresh in them): its setpoints {what}"
        )
    old = f"readings {age:.3f} s old" if math.isfinite(age) else "no fresh reading"
    return (
        f"board {boards} is not answering the bridge (TIMEOUT, {old}: rebooting?): its"
        f" setpoints {what}"
    )


def stale_because_away(
    robot: RobotDescription, away: tuple[int, ...], stale: list[tuple[str, float]]
) -> str:
    """Why ``stale`` readings (name, age) went stale when the bridge reports boards
    ``away`` in ``TIMEOUT``, for people, to go after their names: *: boards 22, 26 are
    not answering the bridge (TIMEOUT: rebooting?)*; empty when no stale reading is of
    a board away (a sensor dropping out)."""
    names = {n for n, _ in stale}
    boards = [
        b for b in away if any(c.board == b and c.name in names for c in robot.state_channels())
    ]
    if not boards:
        return ""
    shown = ", ".join(str(b) for b in boards)
    verb = "board {} is" if len(boards) == 1 else "boards {} are"
    return f": {verb.format(shown)} not answering the bridge (TIMEOUT: rebooting?)"
