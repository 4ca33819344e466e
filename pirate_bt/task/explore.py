"""The ``explore`` navigator: survey a network with no map, and write what it found.

It drives on until something stops it, finds out what that was, and goes on,
depth-first through every branch:

1. ``Step("straight", distance=search, stop_at_feature=True)``, again and again;
2. stopped *blocked*: ``Step("probe-turn")`` (trees/probe-turn.yaml) tries each roll
   with the steered front half: a bend that way (``Step("bend", ...)`` through it,
   then on with 1), or the end of the line;
3. stopped *over an opening*: ``Step("probe-tee")`` (trees/probe-tee.yaml) finds the
   side the tee's branch leaves on; the tee is noted as *pending* and the robot goes
   straight through (``Step("t-joint", direction="straight")``), then on with 1;
4. at the end of a line it backs to the newest pending tee, through every feature
   it passed since in reverse (``Step("straight", distance=-d)``, ``bend-back``,
   ``t-joint-back``), turns into its branch and surveys that line the same way;
5. no tee pending: the survey is done; it is written as a network file (the format
   of ``scenarios/*.yaml``) that plans and runs routes as a drawing does.

**A branch the robot cannot back out of** (docs/pabs.md, "A branch is left backwards
only where the robot fits": half the diameter plus the branch turn's length,
``d/2 + pi*d/2``, at most 0.1075 m, pipe up to 51.9 mm) is entered only as the
survey's last act: when no pending tee with a branch it *can* leave is left. Every
branch that is then never entered is written as a stub (a tee branch with no
segments), named in the file's description and in :attr:`ExploreNavigator.unexplored`,
and the survey ends with :class:`SurveyIncomplete` (the run stops safe, the cause
named) once the rest is surveyed. Such a network needs a second insertion.

Lengths come from the odometry, on the pipe's centre line: a straight runs from the
end of the feature before it to where the robot was blocked (the front tip stops at
a bend's start, or at the line's end), to the start of a tee (from where the
opening was felt, :data:`OPENING_STOP`), or to a change inside the run. The search
steps also stop where the pipe changes (``stop_at_change``):

- **a slope change**: the IMU's mean pitch moved by 0.25 degrees; the straight ends where
  the rotational module is, and the next one starts there (each straight's slope
  is written when it differs from what the line carries by over 0.25 degrees);
- **a reducer**: a front joint at the wall read a diameter 2 mm off, and kept it over
  40 mm of travel; the robot drives 0.25 m on through the cone and the front half reads
  the diameter beyond it (no change then: the joint was swinging into a tee's opening).
  The cone is written as the network default, 50 mm, and its start placed from how
  much of the change the joint had read.

A bend's arc is ``radius x`` its turn (as far as the IMU says it turned; ``angle``
written, to 1 deg, when over 3 deg off 90); a branch's turn is ``diameter x 90 deg``.
Diameters come from the rear half's wall-contact angles, slopes from the IMU.

Not yet (docs/navigators.md): a reducer within 0.25 m of a tee or a bend, bends met
on a vertical run, and a tee whose way straight on is blocked just past it (an end
cap): the robot stops there (:meth:`SurveyRecord.ended_at_tee`), the line is
written as ending at the tee and its branch is left to a second insertion.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pirate_bt.behaviours.drive import DIAMETER_CHANGE_M, DIAMETER_SETTLE_M
from pirate_bt.errors import InputError
from pirate_bt.task.explore_extend import Extension, earlier_ends, load_extension
from pirate_bt.task.explore_frame import write_in_frame
from pirate_bt.task.explore_parts import (
    APPROACH_M,
    CONE_M,
    CONE_PASS_M,
    MARGIN_M,
    OPENING_STOP,
    PROBE_BEFORE_M,
    PROBE_OVER_M,
    PROBE_WIDEST_M,
    SETTLED_M,
    Passed,
    PendingTee,
    SurveyIncomplete,
    bend_angle_deg,
    branch_leavable,
    check_output,
    metres,
    rear_over_opening,
    tee_start,
    unprobed_opening,
)
from pirate_bt.task.explore_record import EXTEND, SurveyRecord
from pirate_bt.task.navigation import Felt, Observation, Step

__all__ = ["OPENING_STOP", "ExploreNavigator", "SurveyIncomplete", "branch_leavable"]

_TURN = {"up": 90.0, "down": -90.0}
"""The slope change of a bend up or down (left and right keep it)."""


class ExploreNavigator(SurveyRecord):
    """Survey a network with no map: straights, bends, tees and their branches.

    Args:
        output: Where to write the surveyed network (a ``.yaml`` file); ``None``:
            only :attr:`network` holds it.
        search: How far one straight step drives before it looks again.
        radius: The bends' centre-line radius (the robot does not measure it yet).
        name: The surveyed network's name.
        extend: A surveyed network (a file or a ``NetworkSpec``) with a tee branch
            left as a stub: a second insertion drives to the first stub, choosing at
            each tee by the survey, surveys that branch and writes the network with it
            filled in (:mod:`pirate_bt.task.explore_extend`).
    """

    def __init__(
        self,
        output: str | Path | None = None,
        search: str | float = "3 m",
        radius: str | float = "90 mm",
        name: str = "surveyed",
        extend: Any = None,
    ) -> None:
        self.output = check_output(output)
        self.search_m = metres(search, "search")
        self.radius_m = metres(radius, "radius")
        if not isinstance(name, str) or not name or any(c in name for c in "\n\r"):
            raise InputError(f"explore: a network name is one line of text, not {name!r}"[:200])
        self.name = name
        self._extend = extend
        self.segments: list[dict[str, Any]] = []
        """The main line's segments found so far, as a network file writes them."""
        self.network: Any = None
        """The surveyed :class:`~pirate_bt.pipes.NetworkSpec`, once written."""
        self.unexplored: list[str] = []
        """What was not surveyed, each named with why: tee branches never entered
        (written as stubs), and after a stop the line the robot was in (written up to
        the last feature surveyed in it)."""
        self._line = self.segments  # the line being surveyed
        self._line_name = "the main line"
        self._in_line = True  # surveying :attr:`_line` (not on a way back or to a stub)
        self._stop_noted = False  # what a stop left unsurveyed is in :attr:`unexplored`
        self.ends: list[str] = []
        """Where each line was found to end (``the main line after run-2``): a cap, or a
        bend at a roll the survey does not try (it cannot tell them apart)."""
        self.invalid: str | None = None
        """Why the network surveyed was not written: it does not validate (the survey
        then ends as a failure, and nothing is written)."""
        self._counts: dict[str, int] = {}
        self._from_m: float | None = None  # belief where the current straight began
        self._blocked_m: float | None = None
        self._opening_m: float | None = None
        self._diameter_m: float | None = None
        self._slope_deg = 0.0  # the slope the pipe carries into the current straight
        self._trail: list[Passed] = []  # features passed from the start to here
        self._pending: list[PendingTee] = []
        self._target: PendingTee | None = None  # the tee a return goes to
        self._crossing: PendingTee | None = None  # the tee being passed straight on
        self._backed: Passed | PendingTee | None = None  # what a return last drove up to
        self._pitch_before: float | None = None  # the IMU's pitch as a straight step began
        # being passed: the bend, the IMU's pitch and heading before it
        self._bend: tuple[dict[str, Any], float | None, float | None] | None = None
        # a diameter change felt, the cone being passed: where, and the IMU's pitch then
        self._cone: tuple[float, float | None] | None = None
        self._diameter_now = 0.0  # the diameter the current line carries
        self._extension: Extension | None = None
        self._way: list[int] | None = None  # a second insertion, on its way to the stub
        self._tees_met = 0  # on the line the robot is in, on that way
        if extend is not None:
            self._extension = load_extension(extend)
            self._way = list(self._extension.way)
            self.segments = self._extension.data["segments"]
            self._line = []  # what the way to the stub passes is surveyed already
            self._in_line = False
            self._diameter_m = self._diameter_now = self._extension.diameter_m
            self.ends = earlier_ends(self._extension.data.get("description") or "")

    # -- the loop

    def check_map(self, network: Any) -> None:
        """A map is refused before anything connects (exit 2): a survey has none."""
        if network is not None:
            raise ValueError("explore surveys a pipe with no map: run it without a map")

    def next_step(self, obs: Observation) -> Step | None:
        if obs.map is not None:
            raise InputError("explore surveys a pipe with no map: run it without map=")
        if obs.step == 0 and self._from_m is not None:  # run again: a survey of its own
            made = (self.output, self.search_m, self.radius_m, self.name, self._extend)
            vars(self).update(vars(ExploreNavigator(*made)))  # (it went on from the last)
        if obs.last is not None and obs.last.outcome != "success":
            self.save(f"stopped: {obs.last.why}")
            return None  # the navigation's result names the failed step's cause
        self._crossing = None
        if self._from_m is None:  # the start: the rear tip at the pipe's entry
            self._from_m = obs.belief.position_m - obs.robot_length_m
        if self._target is not None:
            return self._return(obs)
        felt = obs.felt[-1] if obs.felt else None
        pab = obs.history[-1][0].pab if obs.history else None
        if pab == "bend" and self._bend is not None:
            self._bend_done(obs)
        if pab == "probe-turn":
            return self._probed_turn(obs, felt)
        if pab == "probe-tee":
            return self._probed_tee(obs, felt)
        forward = pab in ("bend", "t-joint") or (  # explore's own steps: distances in m
            pab == "straight" and float(obs.history[-1][0].params.get("distance", 0)) > 0
        )
        if forward and self._in_line and self._way is None and self._from_m is not None:
            crossed = unprobed_opening(obs.off_wall, self._from_m)
            if crossed is not None:
                return self._unprobed(obs, crossed)
        if self._cone is not None:  # the leading joints are through a reducer now
            self._reducer_done(obs)
        if pab == "straight" and felt is not None and felt.kind == "feature":
            if felt.how == "opening":
                self._opening_m = felt.at_m
                return self._rear_over_tee(obs) or Step("probe-tee")
            if felt.how == "slope":
                self._slope_changed(obs, felt.at_m - obs.imu_behind_m)
                return self._search(obs)
            if felt.how == "diameter":
                return self._diameter_changed(obs, felt.at_m - obs.joint_behind_m)
            self._blocked_m = felt.at_m
            return Step("probe-turn")
        return self._search(obs)

    def _search(self, obs: Observation) -> Step:
        """On along the pipe until something stops the robot: a feature or a change."""
        self._pitch_before = obs.pitch_rad
        return Step("straight", distance=self.search_m, stop_at_feature=True, stop_at_change=True)

    def _slope_changed(self, obs: Observation, at_m: float) -> None:
        """The IMU's pitch changed with the rotational module at ``at_m``: a new straight
        starts there (unless the module was only leaving the feature before)."""
        assert self._from_m is not None
        if at_m < self._from_m + SETTLED_M:
            return
        self._close_straight(obs, at_m, pitch_rad=self._pitch_before)
        self._from_m = at_m

    def _diameter_changed(self, obs: Observation, at_m: float) -> Step:
        """The front half's first joint read another diameter at ``at_m``: a reducer?

        The robot drives on through the cone (no change stops in it), and the front
        half reads the diameter beyond it (:meth:`_reducer_done`).
        """
        assert self._from_m is not None
        if at_m < self._from_m + SETTLED_M:  # the joints were leaving the feature before
            return self._search(obs)
        if self._diameter_m is None and obs.diameter_m is not None:
            # a cone in the first straight: its diameter is the network's, read by the rear
            # half there now (nothing had read one: the file said 63 mm, whatever the pipe)
            self._diameter_m = self._diameter_now = obs.diameter_m
        self._cone = (at_m, obs.pitch_rad)
        return Step("straight", distance=CONE_PASS_M, stop_at_feature=True)

    def _reducer_done(self, obs: Observation) -> None:
        """The front half is through the cone: write the straight up to it and the
        reducer. A drive through it that a feature stopped (the joint was swinging into
        a tee's opening, not down a cone), or no change of diameter, is no reducer:
        the straight goes on."""
        assert self._cone is not None
        at_m, pitch = self._cone
        self._cone = None
        diameter = obs.front_diameter_m
        if obs.felt or diameter is None:
            return
        if abs(diameter - self._diameter_now) < DIAMETER_CHANGE_M:
            return
        # the joint had read 2 mm of the change this far into the cone (length assumed),
        # and the drive went on while the change held
        lead = CONE_M * DIAMETER_CHANGE_M / abs(diameter - self._diameter_now)
        start = at_m - DIAMETER_SETTLE_M - lead
        self._close_straight(obs, start, pitch_rad=pitch, diameter_m=self._diameter_now)
        self._line.append(
            {
                "id": self._id("reducer"),
                "type": "reducer",
                "diameter": f"{diameter * 1000:.1f} mm",
                "length": f"{CONE_M * 1000:g} mm",
            }
        )
        self._diameter_now = diameter
        self._from_m = start + CONE_M
        self._pitch_before = obs.pitch_rad

    def _probed_turn(self, obs: Observation, felt: Felt | None) -> Step | None:
        assert self._blocked_m is not None
        if felt is None:
            raise self._incomplete(
                "probe-turn ended without an answer (neither a turn nor the end)"
            )
        self._close_straight(obs, self._blocked_m)
        if felt.kind == "end":
            self.ends.append(f"{self._line_name} {self._after()}")
            return self._line_done(obs)
        wide_m = obs.diameter_m
        if wide_m is not None and self.radius_m < wide_m / 2 - 1e-9:
            # the bend could not be written (its network would not validate), and neither
            # could anything after it: the survey went on, then wrote nothing at all
            raise self._incomplete(
                f"a bend {felt.direction} {self._after()}: the radius given"
                f" ({self.radius_m * 1000:g} mm) is less than half the pipe's"
                f" {wide_m * 1000:.1f} mm, and a bend's is at least that; survey again with"
                f" a radius of {wide_m * 500:.1f} mm or more"
            )
        direction = str(felt.direction)
        segment: dict[str, Any] = {"id": self._id("bend"), "type": "bend", "direction": direction}
        if self.radius_m != 0.09:
            segment["radius"] = f"{self.radius_m * 1000:.1f} mm"
        self._line.append(segment)
        self._from_m = self._blocked_m + self.radius_m * math.pi / 2
        self._trail.append(Passed("bend-back", direction, self._from_m))
        self._slope_deg += _TURN.get(direction, 0.0)  # past +-90: the network model's too
        self._bend = (segment, obs.pitch_rad, obs.yaw_rad)
        return Step("bend", direction=direction)

    def _bend_done(self, obs: Observation) -> None:
        """Passed: a bend turned as far as the IMU says (else 90): up or down by its
        pitch, left or right by its heading and pitch."""
        assert self._bend is not None and self._from_m is not None
        (segment, before, yaw), self._bend = self._bend, None
        angle = bend_angle_deg(
            segment["direction"], before, obs.pitch_rad, yaw_rad=(yaw, obs.yaw_rad)
        )
        if angle != 90.0:
            segment["angle"] = f"{angle:g} deg"
            self._from_m = self._trail[-1].end_m = self._from_m - self.radius_m * math.radians(
                90.0 - angle
            )
            if segment["direction"] in _TURN:  # left and right keep the slope
                self._slope_deg -= math.copysign(90.0 - angle, _TURN[segment["direction"]])
        write_in_frame(self.segments, self._diameter_m, segment["id"], segment)

    def _probed_tee(self, obs: Observation, felt: Felt | None) -> Step | None:
        assert self._opening_m is not None
        diameter = obs.diameter_m or self._diameter_m or 0.063
        start = tee_start(self._opening_m, diameter)
        if felt is None or felt.kind != "tee" or felt.direction is None:
            self._close_straight(obs, start)  # surveyed up to the opening, not beyond
            if diameter > PROBE_WIDEST_M:  # a branch it cannot feel: on to the others
                self._in_line = False
                self.unexplored.append(
                    f"{self._line_name} {self._after()}: not surveyed past an opening at"
                    f" {self._opening_m:.2f} m in {diameter * 1000:.0f} mm pipe, where"
                    " probe-tee felt no branch turn on any side, and in pipe over"
                    f" {PROBE_WIDEST_M * 1000:.0f} mm it cannot: the IMU would have to turn"
                    " into the branch before bend III, which holds the robot while the"
                    " front half is free, reached the opening; its tee and the line beyond"
                    " it are left to a survey by hand"
                )
                return self._line_done(obs)
            raise self._incomplete(
                f"an opening at {self._opening_m:.2f} m with no branch the robot could steer"
                " into (probe-tee found none)"
            )
        self._close_straight(obs, start)
        if self._way is not None:
            return self._on_the_way(obs, felt.direction, start, diameter)
        segment: dict[str, Any] = {
            "id": self._id("tee"),
            "type": "tee",
            "branch": {"direction": felt.direction, "segments": []},
        }
        self._line.append(segment)
        write_in_frame(self.segments, self._diameter_m, segment["id"], segment["branch"])
        self._pending.append(
            PendingTee(segment, start, diameter, self._slope_deg, len(self._trail), felt.direction)
        )
        self._from_m = start + 3 * diameter  # the tee's straight run, 3 x D
        self._trail.append(Passed("t-joint-back", "straight", self._from_m))
        self._crossing = self._pending[-1]
        return Step("t-joint", direction="straight")

    def _rear_over_tee(self, obs: Observation) -> Step | None:
        """Over an opening just after a tee passed straight on: where ``probe-tee`` would
        hold the robot by its rear half alone, its last joint would be over that tee's
        opening, with no wall to clamp (the probe was refused, *other_half_not_clamped*).
        The survey stops there, named, with the line written up to the opening; ``None``
        when the rear half is clear of it.

        Raises:
            SurveyIncomplete: the rear half would be over the opening.
        """
        before = self._trail[-1] if self._trail else None
        if before is None or (before.pab, before.way) != ("t-joint-back", "straight"):
            return None
        if self._opening_m is None or self._from_m is None or not obs.rear_joint_behind_m:
            return None
        diameter = obs.diameter_m or self._diameter_m or 0.063
        start = tee_start(self._opening_m, diameter)
        rear = start + 1.5 * diameter - PROBE_BEFORE_M - obs.rear_joint_behind_m
        if rear > before.end_m - diameter - PROBE_OVER_M:  # onto that opening's far edge?
            return None
        self._close_straight(obs, max(start, self._from_m))
        self._in_line = False  # surveyed to the opening, not beyond
        tee = self._line[-2]["id"] if len(self._line) > 1 else "the tee"  # [tee, straight]
        where = f"the opening of a tee {max(start - before.end_m, 0.0):.2f} m after {tee}"
        self.unexplored.append(
            f"{self._line_name} {self._after()}: not surveyed past {where} (a tee this close"
            " after a tee is not probed): its tee and the line beyond it are left to a"
            " survey by hand"
        )
        self._leave_pending(f"the robot stopped over the opening after {tee}")
        raise self._incomplete(
            f"the robot stopped over {where}: probe-tee would hold the robot there by its"
            f" rear half alone, with the half's last joint over {tee}'s opening and no wall"
            " to clamp, so the tee is not probed (a tee this close after a tee); the line"
            f" is surveyed up to it, and the rest is named in the file"
        )

    def _unprobed(self, obs: Observation, crossed: Any) -> Step | None:
        """A step carried a joint across an opening it did not stop at: the line is
        surveyed up to it, and left there (its tee's branch is not known)."""
        assert self._from_m is not None
        self._cone = None
        before = self._after()
        start = tee_start(crossed.where_m + obs.joint_behind_m, obs.diameter_m or 0.063)
        self._close_straight(obs, max(start, self._from_m))
        self._in_line = False  # surveyed to the opening, not beyond
        self.unexplored.append(
            f"{self._line_name} {self._after()}: not surveyed past an opening"
            f" {max(start - self._from_m, 0.0):.2f} m {before}, which {crossed.joint}"
            " crossed with no step stopping at it (a tee this close to the feature"
            " before it is not probed): its tee and the line beyond it are left to a"
            " survey by hand"
        )
        if any(o.back_m is None and o.behind_m < obs.imu_behind_m for o in obs.off_wall):
            # the step ended with the front half over the opening: a way back (the backward
            # PABs) starts by clamping that half, and there is no wall for it there
            where = f"{max(start - self._from_m, 0.0):.2f} m {before}"
            self._leave_pending(f"the robot stopped over the opening {where}")
            raise self._incomplete(
                f"the robot stopped with its front half over an opening {where}, which the"
                " step before carried it onto with no step stopping at it (a tee this close"
                " to the feature before it is not probed): the front half has no wall to"
                " clamp there, so the survey cannot back to the branches it left; the line"
                " is surveyed up to the opening, and the rest is named in the file"
            )
        return self._line_done(obs)

    def _leave_pending(self, stopped: str) -> None:
        """Every tee branch not entered yet is left to a further insertion: ``stopped``."""
        self.unexplored.extend(
            f"{t}: not entered, {stopped}, {EXTEND}" for t in reversed(self._pending)
        )
        self._pending.clear()

    def _on_the_way(self, obs: Observation, side: str, start: float, d: float) -> Step | None:
        """A second insertion met a tee: straight on, or into the branch on the way."""
        assert self._way is not None and self._extension is not None
        ordinal, self._tees_met = self._tees_met, self._tees_met + 1
        if ordinal != self._way[0]:
            self._from_m = start + 3 * d
            self._trail.append(Passed("t-joint-back", "straight", self._from_m))
            return Step("t-joint", direction="straight")
        expected = self._extension.sides[len(self._extension.way) - len(self._way)]
        if side != expected:
            raise self._incomplete(
                f"the pipe is not as surveyed: tee {ordinal + 1} on the way to"
                f" {self._extension.stub_name}'s branch leaves {side}, the survey has {expected}"
            )
        self._way.pop(0)
        self._tees_met = 0
        if self._way:  # a branch surveyed already, on the way to the stub
            segment: dict[str, Any] = {
                "id": f"the branch on the way to {self._extension.stub_name}",
                "branch": {"direction": side, "segments": []},
            }
        else:  # the stub: what is found from here is written into it
            segment = self._extension.stub
            self._way = None
            self._counts = dict(self._extension.counts)
        # the side the IMU found: the surveyed file may hold the branch as a roll only
        self._target = PendingTee(
            segment, start, d, self._slope_deg, depth=len(self._trail), imu_side=side
        )
        return self._return(obs)

    # -- the end of a line, and the way back to a branch

    def _line_done(self, obs: Observation) -> Step | None:
        """The line ends here: back to the newest pending branch, or the survey is done."""
        if self._way is not None and self._extension is not None:
            raise self._incomplete(
                f"the pipe is not as surveyed: the line ended before the way to"
                f" {self._extension.stub_name}'s branch"
            )
        while self._pending:
            tee = self._pending[-1]
            others = any(branch_leavable(t.diameter_m) for t in self._pending[:-1])
            if branch_leavable(tee.diameter_m) or not others:
                self._pending.pop()
                self._target = tee
                return self._return(obs)
            self.unexplored.append(f"{tee}: not entered, the robot cannot back out of it")
            self._pending.pop()
        if self._extension is not None:  # stubs of the first insertion not this one's
            self.unexplored.extend(
                f"{other}: not entered, a further insertion surveys it"
                for other in self._extension.others
            )
            self.unexplored.extend(self._extension.notes)  # an earlier insertion's
        if not self._write(None) and self.invalid is not None:
            raise SurveyIncomplete(self.invalid)
        if self.unexplored:
            raise self._incomplete(
                "not every branch was surveyed: " + "; ".join(self.unexplored), cut=False
            )
        return None

    def _return(self, obs: Observation) -> Step | None:
        """The next step back to :attr:`_target`, or into its branch once there."""
        tee = self._target
        assert tee is not None
        if len(self._trail) > tee.depth:
            passed = self._trail[-1]
            rear = obs.belief.position_m - obs.robot_length_m
            gap = rear - passed.end_m - MARGIN_M
            if self._backed is not passed and gap > 0.05:
                self._backed = passed
                return Step("straight", distance=-gap)
            self._trail.pop()
            self._backed = None
            return Step(passed.pab, direction=passed.way)
        # back before the tee: the front tip where a turn PAB starts from, a
        # mission's approach before the middle of the opening; then into the branch
        approach = tee.start_m + 1.5 * tee.diameter_m - APPROACH_M
        rear = approach - obs.robot_length_m + obs.joint_behind_m
        if close := rear_over_opening(tee, self._trail[-1] if self._trail else None, rear):
            self._target = self._backed = None
            self.unexplored.append(close)  # and on to the next branch, if one is left
            return self._line_done(obs)
        if obs.belief.position_m > approach + 0.02 and self._backed is not tee:
            self._backed = tee
            return Step("straight", distance=approach - obs.belief.position_m)
        self._backed = None
        self._target = None
        if not branch_leavable(tee.diameter_m):  # the last act: nothing is left behind
            for other in self._pending:
                self.unexplored.append(
                    f"{other}: not entered, the robot went into {tee} last"
                    " and cannot back out of it"
                )
            self._pending.clear()
        self._line = tee.segment["branch"]["segments"]
        self._line_name = f"{tee.segment['id']}'s branch"
        self._in_line = True
        self._diameter_now = tee.diameter_m
        turn_end = tee.start_m + 1.5 * tee.diameter_m + math.pi * tee.diameter_m / 2
        self._from_m = turn_end
        self._slope_deg = tee.slope_deg + _TURN.get(tee.side, 0.0)
        self._trail.append(Passed("t-joint-back", tee.side, turn_end))
        return Step("t-joint", direction=tee.side)
