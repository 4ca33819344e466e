"""What the ``explore`` navigator found, and the network file it writes: the part of
:class:`~pirate_bt.task.explore.ExploreNavigator` that keeps the record (split out of
:mod:`pirate_bt.task.explore`, the driving), and the words of a stop at a feature it
found. Its attributes are set by the navigator.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pirate_bt.behaviours.drive import DIAMETER_CHANGE_M
from pirate_bt.task.explore_extend import Extension
from pirate_bt.task.explore_frame import write_in_frame
from pirate_bt.task.explore_parts import (
    PendingTee,
    SurveyIncomplete,
    ends_note,
    left_by_a_stop,
    slipped_over,
    tee_start,
    write_survey,
)
from pirate_bt.task.navigation import Observation

__all__ = ["EXTEND", "SLOPE_WRITTEN_DEG", "SurveyRecord"]

EXTEND = "a second insertion (extend=, pirate-bt survey --extend) surveys it"
"""What leaves a stub to a further insertion, as the notes say it."""

SLOPE_WRITTEN_DEG = 0.25
"""A straight's slope is written when it differs from what the line carries by more."""


class SurveyRecord:
    """The surveyed lines so far, what was not surveyed, and writing them."""

    output: Path | None
    name: str
    radius_m: float
    segments: list[dict[str, Any]]
    network: Any
    unexplored: list[str]
    ends: list[str]
    invalid: str | None
    _line: list[dict[str, Any]]
    _line_name: str
    _in_line: bool
    _stop_noted: bool
    _counts: dict[str, int]
    _from_m: float | None
    _blocked_m: float | None
    _opening_m: float | None
    _diameter_m: float | None
    _diameter_now: float
    _slope_deg: float
    _pending: list[PendingTee]
    _target: PendingTee | None
    _crossing: PendingTee | None
    _bend: tuple[dict[str, Any], float | None, float | None] | None
    _extension: Extension | None
    _way: list[int] | None

    def _id(self, kind: str) -> str:
        self._counts[kind] = self._counts.get(kind, 0) + 1
        return f"{'run' if kind == 'straight' else kind}-{self._counts[kind]}"

    def _incomplete(self, why: str, *, cut: bool = True) -> SurveyIncomplete:
        """End the survey with ``why``: write what was surveyed, and say where (only if
        it was written). ``cut``: it ends inside a line (not at a line's end)."""
        if cut:
            self._note_stop()
        where = ""
        if self._write(why):
            where = f"; the survey so far is written to {self.output}"
        elif self.invalid is not None:
            where = f"; {self.invalid}"
        elif self.output is not None:
            where = "; nothing was surveyed: no file is written"
        return SurveyIncomplete(why + where)

    def _close_straight(
        self,
        obs: Observation,
        end_m: float,
        *,
        pitch_rad: float | None = None,
        diameter_m: float | None = None,
    ) -> None:
        """Write the straight from :attr:`_from_m` to ``end_m``, with the diameter and
        the slope read (``pitch_rad``, ``diameter_m``: what it had, read before a change)."""
        assert self._from_m is not None
        length = end_m - self._from_m
        if length < 0.005:  # a feature right after a feature: no straight between
            return
        segment: dict[str, Any] = {
            "id": self._id("straight"),
            "type": "straight",
            "length": f"{length:.3f} m",
        }
        # read where the straight ends, the rear half holding in it; the first one
        # read is the network's, a straight that differs by over 2 mm says so
        read = obs.diameter_m if diameter_m is None else diameter_m
        if read is not None and self._diameter_m is None:
            self._diameter_m = self._diameter_now = read
        elif read is not None and abs(read - self._diameter_now) > DIAMETER_CHANGE_M:
            segment["diameter"] = f"{read * 1000:.1f} mm"
            self._diameter_now = read
        pitch_rad = obs.pitch_rad if pitch_rad is None else pitch_rad
        if pitch_rad is not None:
            pitch = math.degrees(pitch_rad)
            # the slope carried in as the IMU reads it (a bend down from -2.8 deg carries
            # -92.8, past plumb, read -87.2): a plumb drop there is written plumb
            carried = math.degrees(math.asin(math.sin(math.radians(self._slope_deg))))
            if abs(pitch - carried) > SLOPE_WRITTEN_DEG:  # not as carried in
                segment["slope"] = f"{pitch:.1f} deg"
                self._slope_deg = pitch
        self._line.append(segment)

    def save(self, stopped: str, failed: Any = None) -> None:
        """Write what was surveyed so far, saying why the survey stopped.

        A failed step ends the navigation before the navigator is asked again, so the
        caller saves (:func:`pirate_bt.survey`), with the decision whose step failed
        (``failed``): the straight the robot was in is left out, unless a probe failed
        at its end (then written up to it). What the stop left unsurveyed is added to
        :attr:`unexplored` (and to the file): the line it was in, every branch not entered.
        """
        if self.invalid is None:  # else it ended on that, with every line to its end
            pab = getattr(getattr(failed, "step", None), "pab", None)
            if pab in ("probe-tee", "probe-turn") and self._way is None:  # a line's end felt
                seen = failed.observation.diameter_m or self._diameter_m or 0.063
                end = tee_start(self._opening_m or 0.0, seen) if pab == "probe-tee" else None
                self._close_straight(failed.observation, end or self._blocked_m or 0.0)
            self._note_stop()
            self._write(stopped)

    def _note_stop(self) -> None:
        if not self._stop_noted:  # once
            self._stop_noted = True
            self.unexplored.extend(self._left_by_a_stop())

    def _after(self) -> str:
        """Where the line being surveyed is up to: ``after run-2``, ``from its start``."""
        last = next((str(s["id"]) for s in reversed(self._line) if "id" in s), None)
        return f"after {last}" if last else "from its start"

    def ends_note(self) -> str:
        """What the lines' ends found may be (``""``: none found)."""
        return ends_note(self.ends)

    def _left_by_a_stop(self) -> list[str]:
        """What a survey that stops here leaves unsurveyed, each named with why."""
        in_it = self._in_line and self._target is None
        line = f"{self._line_name} {self._after()}" if in_it else None
        tees = [t for t in (self._target, *reversed(self._pending)) if t is not None]
        return left_by_a_stop(line, tees, self._way is not None, self._extension)

    def _write(self, stopped: str | None) -> bool:
        """Build the network of what was surveyed, and write it if asked to: written?"""
        if not any(s["type"] == "straight" for s in self.segments):
            return False  # nothing surveyed: no network to write
        ext = self._extension
        self.network, invalid, written = write_survey(
            name=self.name,
            segments=self.segments,
            diameter_m=self._diameter_m,
            stopped=stopped,
            insertion="" if ext is None else f" ({ext.stub_name}'s branch by a second insertion)",
            earlier_stop=None if ext is None else ext.stopped,
            ends_note=self.ends_note() if self.ends else "",
            unexplored=self.unexplored,
            radius_m=self.radius_m,
            output=self.output,
        )
        if invalid is not None:
            self.invalid = invalid
        return written

    def ended_at_tee(self, failing_node: str | None, why: str, openings: Any = ()) -> str | None:
        """Stopped going straight on through a tee just found: the released front half
        blocked past the opening (the line ends there: a cap, or a turn right after the
        tee, not tried), or the front half over a second opening as the rear half crossed
        the first, so that no half held (a tee close after it). The branch is left to a
        further insertion. ``openings``: the failed step's (``OffWall``). The why, or
        ``None``."""
        tee, self._crossing = self._crossing, None
        node = f"{failing_node}"
        if tee is None or self._from_m is None:
            return None
        slipped = slipped_over(why, openings, self._from_m) if "/rear across" in node else None
        if slipped is not None:
            crossed, slip = slipped
            self._pending.remove(tee)
            self._in_line = False  # surveyed to the tee, not beyond
            name = tee.segment["id"]
            where = f"{crossed.where_m - self._from_m:.2f} m after {name}"
            self.unexplored.append(
                f"{self._line_name} after {name}: not surveyed past an opening {where},"
                f" which the front half was over as the rear half crossed {name}'s opening"
                " (two tees this close are not passed straight on): its tee and the line"
                " beyond it are left to a survey by hand"
            )
            self.unexplored.append(f"{tee}: not entered, the robot stopped at the tee, {EXTEND}")
            return (
                f"the robot stopped going straight through {name}: as its rear half crossed"
                f" {name}'s opening, the front half, which must hold the robot then, was over"
                f" a second opening {where} (a tee this close after a tee), and no half held"
                f" ({node.rsplit('/', 1)[-1]}: {slip}); the survey cannot pass two tees this"
                f" close straight on, so the line after {name} is left to a survey by hand,"
                f" and {tee} is not entered, {EXTEND}"
            )
        if not node.endswith("/front across") or not why.startswith("blocked"):
            return None
        self._pending.remove(tee)
        self._in_line = False  # surveyed to where it ends, at the tee
        self.ends.append(f"{self._line_name} {self._after()}, blocked just past it, no turn tried")
        self.unexplored.append(f"{tee}: not entered, the robot stopped at the tee, {EXTEND}")
        return (
            f"the way straight on through {tee.segment['id']} is blocked just past it"
            f" (front across: {why.split(' (')[0]}), and the robot stopped there: {tee}"
            f" is not entered, {EXTEND}"
        )

    def ended_in_bend(
        self, failing_node: str | None, why: str, front_m: float, openings: Any = ()
    ) -> str | None:
        """Stopped passing a bend just found: its front half through, the front tip (at
        ``front_m``) was blocked before the rear half was through, by a second bend (or the
        pipe's end) closer after it than the bend PAB passes, or the front half, which
        holds the robot while the rear half turns, crossed a tee's opening there and no
        half held (``openings``: the failed step's). The why, or ``None``."""
        rear = f"{failing_node}".endswith("/rear through turn")
        if self._bend is None or self._from_m is None or not rear:
            return None
        slipped = slipped_over(why, openings, self._from_m)
        if slipped is None and not why.startswith("blocked"):
            return None
        bend = str(self._bend[0]["id"])
        write_in_frame(self.segments, self._diameter_m, bend, self._bend[0])
        self._bend, self._in_line = None, False  # surveyed to the bend, not beyond
        if slipped is not None:
            crossed, slip = slipped
            where = f"{crossed.where_m - self._from_m:.2f} m after {bend}"
            self.unexplored.append(
                f"{self._line_name} after {bend}: not surveyed past an opening {where}, which"
                f" the front half crossed as the rear half turned through {bend} (a tee this"
                " close after a bend is not passed): its tee and the line beyond it are left"
                " to a survey by hand"
            )
            return (
                f"the robot stopped in {bend}: as its rear half turned through {bend}, the"
                f" front half, which must hold the robot then, crossed an opening {where} (a"
                f" tee this close after a bend), and no half held (rear through turn: {slip});"
                f" the survey cannot pass a tee this close after a bend, so the line after"
                f" {bend} and that tee are left to a survey by hand"
            )
        where = f"{max(front_m - self._from_m, 0.0):.2f} m after {bend}"
        self.unexplored.append(
            f"{self._line_name} after {bend}: not surveyed past {where}, where the front"
            f" half was blocked as the rear half turned through {bend}: left to a survey by hand"
        )
        return (
            f"the robot stopped in {bend}: its front half was blocked {where} (a second bend,"
            f" or the pipe's end) before the rear half was through (rear through turn:"
            f" {why.split(' (')[0]}); the survey cannot pass a bend this close after a bend,"
            f" so the line after {bend} is left to a survey by hand"
        )
