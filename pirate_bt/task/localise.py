"""Where the robot believes it is: drive odometry, corrected at recognised features.

The belief is one number, the distance of the robot's front tip along the
mission's path (the same coordinate the planner and the simulator use). Between
features it is dead reckoning: the mean measured wheel speed of the drive
motors, integrated over the state frames' time stamps. Wheels that slip make
the belief run ahead of the truth; that drift is what the features correct.

Features are recognised from the robot's own sensors, never from the plan's
progress:

- **Turns** (bends and turns into a T-joint's branch) from the IMU. The IMU sits
  on the rotational module, so its pitch and yaw give the pipe's direction
  there. When that direction has swung by half the turn's angle since the last
  straight, the rotational module is at the middle of the turn: the belief
  snaps to the map's position of that middle plus the module's offset behind
  the front tip.
- **T-joints passed straight through** from the joint angles: over the branch
  opening a bend module finds no wall, so a joint pressed outward swings past
  the wall-contact angle for the local diameter. The belief snaps so that
  module is at the opening. A tee passed without clamping over it is not felt,
  and that is not an error.

Features are matched on the map's *sequence*, not on distance alone. The
*tolerance* around where the map puts a feature is ``window_m`` (0.3 m) plus
``drift_per_m`` + ``map_fraction`` (2 % + 10 %) of every metre driven since the
last fix: a map whose straights are off by up to 10 % fits it. Beyond it, out to
the matcher's *reach* (``sequence_fraction``, 33 % instead of the 10 %), a felt
feature is still accepted when it is the next one in the map's order and has the
same signature: a turn swinging in the map's direction (up, down, left or right,
within 50 degrees), an opening where the next feature is a tee. Each fix says how
well the place fitted the map (:attr:`Fix.confidence`) and the drift per metre it
corrected (:attr:`Fix.drift_per_m`).

Belief and map *disagree* when a turn (or, with ``tees_felt``, a tee's opening)
is felt where the map has none within the reach, when a turn swings in another
direction than the map's next turn (``a turn down where the map has bend 'b'
turning left``), or when the belief passes the far end of a feature's reach
without the feature being felt. A disagreement sets :attr:`Localiser.mismatch` (one line) and
:attr:`Localiser.disagreement` (where, what was expected, what was sensed, the
sensor evidence); the mission clears the ``map_ok`` blackboard key, the tree's
guard fails and the runner leaves the robot in its safe state with that reason.

Bounds the tests check on the simulator (``docs/missions.md``): right after a
fix the belief is within 0.10 m of the truth, and between fixes the error grows
by at most 2 cm per metre driven plus 0.10 m.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

from pirate_bt.pipes.network import Piece, PieceKind
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState, wheel_fresh_window_s
from pirate_bt.task.blocked_why import blocked_mismatch
from pirate_bt.task.fixes import (
    Disagreement,
    Fix,
    ShortLeg,
    Vec3,
    angle_between,
    cross,
    imu_tangent,
    roll_name,
    wrap_angle,
)
from pirate_bt.task.planner import MapFeature, MissionPlan
from pirate_bt.task.turn_angle import FixedTurn, TurnWatch, imu_evidence, unmapped_turn
from pirate_bt.task.where_believed import after_fix

__all__ = [
    "DRIFT_PER_M",
    "FIX_BOUND_M",
    "MAP_FRACTION",
    "SEQUENCE_FRACTION",
    "WINDOW_M",
    "Disagreement",
    "Fix",
    "Localiser",
    "imu_tangent",
]

_log = logging.getLogger(__name__)

FIX_BOUND_M = 0.10
"""Stated bound: belief error right after a feature fix (metres)."""

DRIFT_PER_M = 0.02
"""Stated bound: growth of the belief error per metre driven between fixes."""

WINDOW_M = 0.3
"""Stated tolerance: a feature is searched this far either side of where the map has it ..."""

MAP_FRACTION = 0.10
"""... plus this fraction (and :data:`DRIFT_PER_M`) of the distance driven since the last fix."""

SEQUENCE_FRACTION = 0.33
"""The matcher's reach: the *next* feature in the map's order, of the same kind (and,
for a turn, the same direction), is accepted this fraction (plus :data:`DRIFT_PER_M`)
of the distance since the last fix from where the map has it, beyond the tolerance."""

_DIRECTION_MARGIN_RAD = math.radians(50.0)
_OPENING_MARGIN_RAD = 0.15
_UNEXPECTED_TURN_RAD = math.radians(30.0)
_SLOPE_MATCH_RAD = math.radians(5.0)
"""How close the IMU's heading must be to a slope the map draws (away from its turns)
for a swing of 30° or more to be that slope, not an unmapped turn."""
_SLOPE_SAMPLE_M = 0.02


def _where(feature: MapFeature) -> str:
    what = {"bend": "the bend", "tee": "the T-joint", "tee_turn": "the turn into"}[feature.kind]
    return f"{what} {feature.segment!r} at {feature.start_m:.2f}-{feature.end_m:.2f} m"


class Localiser:
    """Keeps the belief of the robot's position on the mission's path.

    Feed it every new state with :meth:`update` (the mission does so after each
    tick).

    Args:
        plan: The mission plan (its path, start and features).
        robot: The robot description (module lengths, clamp contact angles).
        window_m: Base half-width of the window in which a feature is searched.
        drift_per_m: Added to the window per metre driven since the last fix.
        truth: Returns the simulator's front-tip truth, when simulated (for the
            trace and the report; never used for the belief).
        map_fraction: Added to the window per metre driven since the last fix, for
            a map whose lengths are off (0 for a map known to be exact).
        tees_felt: Tees passed straight through must be felt (the straight-through
            T-joint PAB presses the front half over the opening, so they are): a tee
            not felt within its reach is a disagreement, and so is an opening felt
            where the map has no tee.
        sequence_fraction: The matcher's reach beyond the tolerance, per metre since
            the last fix (:data:`SEQUENCE_FRACTION`; at most ``map_fraction`` counts
            when it is larger, and 0 keeps matching to the tolerance alone).
    """

    def __init__(
        self,
        plan: MissionPlan,
        robot: RobotDescription,
        *,
        window_m: float = WINDOW_M,
        drift_per_m: float = DRIFT_PER_M,
        truth: Callable[[], float | None] | None = None,
        map_fraction: float = MAP_FRACTION,
        tees_felt: bool = False,
        sequence_fraction: float = SEQUENCE_FRACTION,
    ) -> None:
        self.plan = plan
        self.map_fraction = map_fraction
        self.sequence_fraction = max(sequence_fraction, map_fraction)
        self.tees_felt = tees_felt
        self.disagreement: Disagreement | None = None
        self.last_fix_m = plan.start_m
        """Belief right after the last fix (the start before the first)."""
        self._quiet_until_m: float | None = None
        self._at_wall: dict[str, bool] = {}
        self.robot = robot
        self.window_m = window_m
        self.drift_per_m = drift_per_m
        self._truth = truth
        self.belief_m = plan.start_m
        self.fixes: list[Fix] = []
        self.fixed_before: str | None = None
        """The feature (segment id) last fixed on before this localiser started, when
        it goes on from an earlier run (a navigation's step): placed as a fix is."""
        self.mismatch: str | None = None
        self.distance_m = 0.0
        self.since_fix_m = 0.0
        self._last_stamp: float | None = None
        self._last_state: RobotState | None = None
        self._heading_ref: Vec3 | None = None
        self._settle_after_m: float | None = None
        self._turn_watch = TurnWatch(plan.path)
        self._pending = list(plan.features)
        offsets = robot.behind_front_tip_m()
        self._offset = offsets
        self._imu_offset_m = offsets[robot.rotational_module().name]
        self._bend_offsets = {m.name: offsets[m.name] for m in robot.all_bend_modules()}
        self._wheel_window_s = wheel_fresh_window_s(robot)  # odometry counts fresh wheels
        self.truth_m: float | None = None

    # -- reading

    @property
    def error_m(self) -> float | None:
        """Belief minus truth (``None`` without a simulator)."""
        return None if self.truth_m is None else self.belief_m - self.truth_m

    def window(self) -> float:
        """Half-width of the feature search window now."""
        return self.window_m + (self.drift_per_m + self.map_fraction) * self.since_fix_m

    def reach(self) -> float:
        """Half-width of the matcher's reach now (the next feature in order is accepted in it)."""
        return self.window_m + (self.drift_per_m + self.sequence_fraction) * self.since_fix_m

    def uncertainty_m(self, ahead_m: float) -> float:
        """How far a feature ``ahead_m`` past the last fix may really be from the map's place.

        What the map's lengths may be off by, plus odometry drift: the margin a leg
        keeps so that it stops before the feature even when the map is off.
        """
        return (self.drift_per_m + self.map_fraction) * max(ahead_m, 0.0)

    def values(self) -> dict[str, float]:
        """Belief, truth and error for the trace (``task.*`` keys)."""
        out = {"task.belief_m": round(self.belief_m, 4), "task.fixes": float(len(self.fixes))}
        if self.truth_m is not None:
            out["task.truth_m"] = round(self.truth_m, 4)
            out["task.error_m"] = round(self.belief_m - self.truth_m, 4)
        return out

    # -- updating

    def update(self, state: RobotState | None) -> None:
        """Take one state snapshot into the belief (a repeated snapshot is ignored)."""
        if self._truth is not None:
            self.truth_m = self._truth()
        if state is None or state is self._last_state:
            return
        self._last_state = state
        if self._last_stamp is not None:
            dt = max(0.0, state.stamp_s - self._last_stamp)
            ds = state.mean_drive_velocity_mps(state.stamp_s - self._wheel_window_s) * dt
            self.belief_m += ds
            self.distance_m += abs(ds)
            self.since_fix_m += abs(ds)
        self._last_stamp = state.stamp_s
        if self.mismatch is None:
            self._recognise(state)

    def _recognise(self, state: RobotState) -> None:
        tangent = imu_tangent(dict(state.imu_rad))
        imu_m = self.belief_m - self._imu_offset_m
        if tangent is not None:
            if self._heading_ref is None:
                self._heading_ref = tangent
            elif self._settle_after_m is not None:
                if imu_m > self._settle_after_m:
                    self._heading_ref = tangent
                    self._settle_after_m = None
            else:
                self._turns(tangent, imu_m, state)
        self._openings(state)
        self._missed(imu_m, state)

    def _next_turn(self) -> MapFeature | None:
        for feature in self._pending:
            if feature.angle_rad > 0:
                return feature
        return None

    def _turns(self, tangent: Vec3, imu_m: float, state: RobotState) -> None:
        assert self._heading_ref is not None
        swung = angle_between(tangent, self._heading_ref)
        turn = self._next_turn()
        reach = self.reach()
        near = turn is not None and turn.start_m - reach <= imu_m <= turn.end_m + reach
        imu = imu_evidence(state.imu_rad, imu_m)
        short = self._turn_watch.short(
            turn if near else None,
            swung,
            tangent,
            (imu_m, self.belief_m, self.distance_m),
            lambda: self._drawn_slope(tangent, imu_m, reach),
        )
        if short is not None:
            self.mismatch = short[0]
            self._disagree(state.stamp_s, short[2], short[1], imu, reach, None)
            return
        if turn is not None and near and swung >= turn.angle_rad / 2:
            felt = self._felt_roll(turn, self._heading_ref, tangent)
            if felt is not None and abs(wrap_angle(felt - turn.roll_rad)) > _DIRECTION_MARGIN_RAD:
                way, drawn = roll_name(felt), roll_name(turn.roll_rad)
                self.mismatch = (
                    f"belief and map disagree: the pipe turned {way} by"
                    f" {math.degrees(swung):.0f} deg at {self.belief_m:.2f} m (believed),"
                    f" where the map has {turn.segment!r} turning {drawn}"
                )
                sensed = f"a turn {way} of {math.degrees(swung):.0f} deg"
                evidence = f"{imu}; the map's turn goes {drawn}"
                self._disagree(state.stamp_s, turn, sensed, evidence, reach, None)
                return
            self._turn_watch.last = FixedTurn(turn, self._heading_ref)
            middle = (turn.start_m + turn.end_m) / 2
            self._fix(turn, "imu", middle + self._imu_offset_m, state.stamp_s)
            self._settle_after_m = turn.end_m + 0.02
            return
        if swung >= _UNEXPECTED_TURN_RAD and not near:
            if self._drawn_slope(tangent, imu_m, reach):
                # the map's straight changes slope here (a kink the network draws): the
                # pipe goes on as drawn, and the new slope is the reference from now on
                self._heading_ref = tangent
                return
            sharper = self._turn_watch.overturned(tangent, imu_m, reach, self.belief_m)
            if sharper is not None:  # the turn fixed on goes on turning: not a new one
                self.mismatch = sharper[0]
                self._disagree(state.stamp_s, sharper[2], sharper[1], imu, reach, None)
                return
            placed = after_fix(self.fixes, self.since_fix_m, self.plan.path, self.belief_m)
            self.mismatch = unmapped_turn(swung, (self.belief_m, imu_m), reach, turn, placed)
            sensed = f"a turn of {math.degrees(swung):.0f} deg"
            self._disagree(state.stamp_s, None, sensed, imu, reach, turn)

    def _drawn_slope(self, tangent: Vec3, imu_m: float, reach: float) -> bool:
        """The IMU's heading is the map's own slope somewhere within ``reach`` of the
        rotational module's believed place, in the reference heading's direction: a
        change of slope on a straight that the network draws, not a turn."""
        ref = self._heading_ref
        assert ref is not None
        if math.hypot(ref[0], ref[1]) < 1e-6:
            return False  # a vertical reference has no direction to keep
        yaw = math.atan2(ref[1], ref[0])
        path = self.plan.path
        lo, hi = max(0.0, imu_m - reach), min(path.length_m, imu_m + reach)
        steps = max(1, math.ceil((hi - lo) / _SLOPE_SAMPLE_M))
        for i in range(steps + 1):
            slope = path.slope_at(lo + (hi - lo) * i / steps)
            drawn = (
                math.cos(slope) * math.cos(yaw),
                math.cos(slope) * math.sin(yaw),
                math.sin(slope),
            )
            if angle_between(tangent, drawn) <= _SLOPE_MATCH_RAD:
                return True
        return False

    def _felt_roll(self, turn: MapFeature, before: Vec3, now: Vec3) -> float | None:
        """The roll of the turn felt (``before`` to ``now``) in the map's frame at ``turn``."""
        tangent, up = self.plan.path.frame_at(turn.start_m)
        right = cross(tangent, up)
        along = sum(a * b for a, b in zip(now, before, strict=True))
        d = tuple(a - along * b for a, b in zip(now, before, strict=True))
        if math.sqrt(sum(c * c for c in d)) < 1e-6:
            return None
        return math.atan2(
            sum(a * b for a, b in zip(d, right, strict=True)),
            sum(a * b for a, b in zip(d, up, strict=True)),
        )

    def _openings(self, state: RobotState) -> None:
        tee = next((f for f in self._pending if f.kind == "tee"), None)
        opening_m = (tee.start_m + tee.end_m) / 2 if tee is not None else None
        window = self.reach()
        clamp = self.robot.clamp
        for module, offset in self._bend_offsets.items():
            angle = state.joint_angle_rad.get(module)
            if angle is None:
                continue
            here_m = self.belief_m - offset
            at_wall_before = self._at_wall.get(module, False)
            wall_rad = clamp.contact_angle(self.plan.path.diameter_at(max(here_m, 0.0)))
            self._at_wall[module] = abs(abs(angle) - wall_rad) <= _OPENING_MARGIN_RAD
            off_wall = abs(angle) > wall_rad + _OPENING_MARGIN_RAD
            if tee is not None and opening_m is not None and abs(here_m - opening_m) <= window:
                if off_wall:
                    self._fix(tee, "joints", opening_m + offset, state.stamp_s)
                    self._quiet_until_m = tee.end_m + self.plan.robot_length_m + 0.05
                    return
                continue
            quiet = self._quiet_until_m is not None and self.belief_m <= self._quiet_until_m
            if (
                self.tees_felt
                and at_wall_before
                and off_wall
                and not quiet
                and not self._near_turn(here_m)
            ):
                mapped_mm = self.plan.path.diameter_at(max(here_m, 0.0)) * 1000
                placed = after_fix((), 0.0, self.plan.path, here_m)  # the joint's segment
                # The joint found no wall where the map has pipe: a branch's opening, or
                # a pipe wider than mapped; the joints alone cannot tell which.
                self.mismatch = (
                    f"belief and map disagree: an opening was felt at {here_m:.2f} m"
                    f" (believed, by {module}{placed}), where the map has no T-joint within"
                    f" {window:.2f} m (or the pipe is wider than the map's"
                    f" {mapped_mm:.0f} mm there)"
                )
                self._disagree(
                    state.stamp_s,
                    tee if tee is not None and opening_m is not None else None,
                    "an opening (a T-joint, or a wider pipe?)",
                    f"{module}'s joint swung from the wall to {math.degrees(abs(angle)):.0f} deg,"
                    f" past the wall-contact angle {math.degrees(wall_rad):.0f} deg",
                    window,
                    None,
                    sensed_at_m=here_m,
                    sensed_by=module,
                )
                return

    def blocked(self, time_s: float, cut: ShortLeg | None = None) -> None:
        """A forward leg stopped *blocked* (every wheel at stall current, no progress),
        the front tip at the belief: the map must have a feature or the line's end
        within the reach of some part of the robot. If not, the pipe turns (or ends)
        where the map has it go on: a disagreement, named before any turn is tried
        (a tee whose main and branch are swapped in the ground leads into the other
        pipe, which turns where the map has none).

        ``cut``: the leg stopped short of its distance (see :meth:`_cut_short`)."""
        if self.mismatch is not None:
            return
        reach = self.reach()
        front, rear = self.belief_m, self.belief_m - self.plan.robot_length_m
        placed = self.window_m + self.drift_per_m * self.since_fix_m
        # A leg cut short is explained by a turn (an end) where the map has it, to the
        # belief's own error (``placed``); further on, only as :meth:`_cut_short` says.
        end_m = self.plan.path.length_m
        at_end = front >= end_m - reach
        if at_end and (cut is None or cut.to_end or end_m - front <= placed):
            return
        # A feature up to the last one fixed on is placed by that fix: only odometry
        # since then separates it from the robot, not the map's lengths (a turn already
        # passed, more than the robot's length behind, explains no block ahead).
        last = self.fixes[-1].feature if self.fixes else self.fixed_before
        fixed_end_m = max(
            (p.end_m for p in self.plan.path.pieces if p.segment == last), default=-math.inf
        )
        near: list[Piece] = []
        for piece in self.plan.path.pieces:
            slack = placed if piece.end_m <= fixed_end_m else reach
            if piece.angle_rad > 0 and (  # a tee passed straight through blocks nothing
                piece.start_m - slack <= front and rear <= piece.end_m + slack
            ):
                if cut is None or piece.segment == cut.takes or piece.start_m - front <= placed:
                    return
                near.append(piece)
        if cut is not None and (near or at_end):
            self._cut_short(time_s, cut, near[0] if near else None, reach)
            return
        after = after_fix(self.fixes, self.since_fix_m, self.plan.path, self.belief_m)
        last = self.fixes[-1].feature if self.fixes else None
        kinds = {p.kind for p in self.plan.path.pieces if p.segment == last}
        through = last if kinds == {PieceKind.TEE} else None  # a tee passed straight through
        turn = self._next_turn()
        self.mismatch = blocked_mismatch(front, after, reach, through, (turn, end_m))
        self._disagree(
            time_s,
            turn,
            "the pipe blocking the way (a turn or an end)",
            "every drive at stall current with no progress, ending a forward leg",
            reach,
            None,
        )

    def _cut_short(self, time_s: float, cut: ShortLeg, piece: Piece | None, reach: float) -> None:
        """A leg blocked short of its distance near a turn (or the end) the map has further
        on, not the turn the route takes next (whose PAB senses and crosses it), nor the
        end of a leg to the end: the pipe turns or ends nearer than drawn."""
        after = after_fix(self.fixes, self.since_fix_m, self.plan.path, self.belief_m)
        there = (
            f"the turn {piece.segment!r} at {piece.start_m:.2f}-{piece.end_m:.2f} m"
            if piece is not None
            else f"the line's end at {self.plan.path.length_m:.2f} m"
        )
        self.mismatch = (
            f"belief and map disagree: the pipe blocked the robot at {self.belief_m:.2f} m"
            f" (believed{after}) after {cut.travelled_m:.2f} m of the {cut.asked_m:.2f} m"
            f" that {cut.leg!r} was to drive, where the map has no turn there that the route"
            f" takes next (the nearest is {there}): the pipe turns or ends nearer than drawn"
        )
        self.disagreement = Disagreement(
            time_s,
            self.belief_m,
            there,
            "the pipe blocking the way (a turn or an end) before the leg's distance",
            f"every drive at stall current with no progress after {cut.travelled_m:.2f} m"
            f" of {cut.asked_m:.2f} m",
            reach,
            piece.segment if piece is not None else None,
        )
        _log.warning("%s", self.mismatch)

    def _near_turn(self, at_m: float) -> bool:
        """Whether ``at_m`` is within a turn of the path (or the reach around one)."""
        window = self.reach()
        for piece in self.plan.path.pieces:
            if piece.angle_rad > 0 and piece.start_m - window <= at_m <= piece.end_m + window:
                return True
        return False

    def _missed(self, imu_m: float, state: RobotState) -> None:
        if self.mismatch is not None:
            return
        # Tees passed straight through are silent unless clamped over: drop them once
        # passed (when they must be felt, an unfelt one is a disagreement).
        while self._pending and self._pending[0].angle_rad == 0:
            tee = self._pending[0]
            opening_m = (tee.start_m + tee.end_m) / 2
            first_joint_m = self.belief_m - min(self._bend_offsets.values())
            if self.tees_felt and first_joint_m > opening_m + self.reach():
                self.mismatch = (
                    f"belief and map disagree: the map has {tee.segment!r} at"
                    f" {tee.start_m:.2f}-{tee.end_m:.2f} m, but no opening was felt by"
                    f" {self.belief_m:.2f} m (believed)"
                )
                joints = ", ".join(
                    f"{m} {math.degrees(abs(state.joint_angle_rad.get(m, 0.0))):.0f} deg"
                    for m in self._bend_offsets
                )
                self._disagree(
                    state.stamp_s,
                    tee,
                    None,
                    f"no bend joint swung off the wall; joints {joints}",
                    self.reach(),
                    None,
                )
                return
            if self.belief_m - self.plan.robot_length_m > tee.end_m + self.reach():
                self._pending.pop(0)
            else:
                break
        turn = self._next_turn()
        if turn is None:
            return
        if imu_m > turn.end_m + self.reach():
            self.mismatch = (
                f"belief and map disagree: the map has {turn.segment!r} at"
                f" {turn.start_m:.2f}-{turn.end_m:.2f} m, but no turn was felt by"
                f" {self.belief_m:.2f} m (believed)"
            )
            swung = (
                angle_between(
                    imu_tangent(dict(state.imu_rad)) or self._heading_ref, self._heading_ref
                )
                if self._heading_ref is not None
                else 0.0
            )
            self._disagree(
                state.stamp_s,
                turn,
                None,
                f"the IMU swung {math.degrees(swung):.0f} deg of the"
                f" {math.degrees(turn.angle_rad):.0f} deg turn, the rotational module at"
                f" {imu_m:.2f} m",
                self.reach(),
                None,
            )

    def _disagree(
        self,
        time_s: float,
        expected: MapFeature | None,
        sensed: str | None,
        evidence: str,
        window_m: float,
        near: MapFeature | None,
        *,
        sensed_at_m: float | None = None,
        sensed_by: str | None = None,
    ) -> None:
        feature = expected or near
        self.disagreement = Disagreement(
            time_s,
            self.belief_m,
            _where(expected) if expected is not None else None,
            sensed,
            evidence,
            window_m,
            feature.segment if feature is not None else None,
            sensed_at_m,
            sensed_by,
        )
        _log.warning("%s", self.mismatch)

    def _fix(self, feature: MapFeature, how: str, after_m: float, time_s: float) -> None:
        z = (after_m - self.belief_m) / (self.window() / 2)
        fix = Fix(
            time_s,
            feature.segment,
            how,
            self.belief_m,
            after_m,
            self.truth_m,
            since_fix_m=self.since_fix_m,
            confidence=math.exp(-z * z / 2),
        )
        self.fixes.append(fix)
        _log.info(
            "fix at %s (%s): belief %.3f -> %.3f m", feature.segment, how, fix.before_m, after_m
        )
        self.belief_m = after_m
        self.last_fix_m = after_m
        self.since_fix_m = 0.0
        self._pending = [f for f in self._pending if f is not feature]
