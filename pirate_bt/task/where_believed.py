"""Where a disagreement was found, as a user reads it on the map: after the last
feature fixed on, or, before any fix, into the map's segment the belief is in.

A stop before the first fix named only a distance (*the pipe blocked the robot at
1.50 m (believed), where the map has no turn ...*), no segment: a user had to count
the map's lengths to find where belief and map parted.
"""

from __future__ import annotations

from collections.abc import Sequence

from pirate_bt.pipes.network import Path as PipePath
from pirate_bt.task.fixes import Fix

__all__ = ["after_fix"]


def after_fix(fixes: Sequence[Fix], since_fix_m: float, path: PipePath, belief_m: float) -> str:
    """``", 0.81 m after 'bend-a'"`` after a fix, else ``", 0.98 m into 'entry'"`` (the
    map's segment at the belief, the front tip), to follow *(believed*."""
    if fixes:
        return f", {since_fix_m:.2f} m after {fixes[-1].feature!r}"
    if not path.pieces:
        return ""
    piece = path.piece_at(belief_m)
    into_m = min(max(belief_m - piece.start_m, 0.0), piece.end_m - piece.start_m)
    return f", {into_m:.2f} m into {piece.segment!r}"


def ended_short(
    fixes: Sequence[Fix], since_fix_m: float, path: PipePath, belief_m: float, margin_m: float
) -> str | None:
    """The note of a leg blocked short of the map's end of the line and taken for the
    end (a block within the localiser's reach of it is accepted there, a success), or
    ``None`` when it stopped within ``margin_m`` (+ 0.10 m) of where the leg was to
    stop. The mission said nothing of it: *mission completed*, with the map's line a
    metre longer than the pipe."""
    end_m = path.length_m
    short_m = end_m - margin_m - belief_m
    if short_m <= 0.10:
        return None
    return (
        f"the line ended (blocked) at {belief_m:.2f} m (believed"
        f"{after_fix(fixes, since_fix_m, path, belief_m)}), {end_m - belief_m:.2f} m before"
        f" the map's end of it at {end_m:.2f} m: taken for its end (the pipe ends nearer"
        " than drawn, or turns where the map does not have it?)"
    )
