"""The words of a forward leg blocked where the map has no turn and no end.

The why said only *the pipe blocked the robot at 2.10 m (believed, 2.10 m into 'a'),
where the map has no turn and no end within 0.86 m*: on a straight built 30 % shorter
than drawn, with the route's next command *at the bend turn right*, the user read that
the map had no turn, though its bend 'b' was drawn 0.90 m further on. A turn felt where
the map has none already named the map's next turn (:func:`~pirate_bt.task.turn_angle.
unmapped_turn`); a block now names it too, or the map's end of the line when no turn is
ahead, with how far on each is drawn.
"""

from __future__ import annotations

from pirate_bt.task.plan import MapFeature

__all__ = ["blocked_mismatch"]


def blocked_mismatch(
    front_m: float,
    placed: str,
    reach_m: float,
    passed_through: str | None,
    ahead: tuple[MapFeature | None, float],
) -> str:
    """The mismatch of a forward leg blocked where the map has no turn and no end
    within ``reach_m`` of the robot.

    Args:
        front_m: The belief (the front tip) where the leg was blocked.
        placed: Where the belief is on the map, after *(believed*
            (:func:`~pirate_bt.task.where_believed.after_fix`).
        reach_m: The matcher's reach there.
        passed_through: The last feature fixed on when it is a tee passed straight
            through (its main and branch may be swapped in the ground), else ``None``.
        ahead: The map's next turn (``None``: none ahead) and the map's end of the line.
    """
    text = (
        f"belief and map disagree: the pipe blocked the robot at {front_m:.2f} m"
        f" (believed{placed}), where the map has no turn and no end within {reach_m:.2f} m"
    )
    if passed_through is not None:
        return text + (
            f"; {passed_through!r} was passed straight through: are its main and branch"
            " swapped in the ground (the way on leading into the branch)?"
        )
    turn, end_m = ahead
    if turn is not None and turn.start_m > front_m:
        return text + (
            f"; the map's next turn, {turn.segment!r}, is drawn {turn.start_m - front_m:.2f} m"
            f" further on (at {turn.start_m:.2f} m): is the pipe before it shorter than"
            " drawn, or does it turn or end where the map does not have it?"
        )
    if turn is None and end_m > front_m:
        return text + (
            f"; the map's line ends {end_m - front_m:.2f} m further on (at {end_m:.2f} m):"
            " does the pipe end nearer than drawn, or turn where the map does not have it?"
        )
    return text
