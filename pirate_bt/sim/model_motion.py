"""Motion of the simulated robot along the pipe: drives, traction, turns, tees.

:class:`MotionMixin` is the motion side of :class:`~pirate_bt.sim.model.PipeRobotModel`:
it ramps the drive wheels, moves the robot when the clamped halves have traction
enough for the slope and the tether (else it slips; unclamped on a steep slope it
slides), stops a half at a turn it may not use (aligned, steered, unclamped),
chooses straight or branch at each tee, and sets the wheels' measured speed and
current.
"""

from __future__ import annotations

import bisect
import logging
import math
from dataclasses import replace

from pirate_bt.pipes import Network, Path, Piece, PieceKind, TeeChoice
from pirate_bt.robot.description import ControlMode, Half, RobotDescription
from pirate_bt.sim.counters import EventKind
from pirate_bt.sim.model_events import EventsMixin
from pirate_bt.sim.model_types import _Half, _Motor, _wrap

__all__ = ["MotionMixin"]

_log = logging.getLogger("pirate_bt.sim.model")


class MotionMixin(EventsMixin):
    """The motion side of the robot model (mixed into ``PipeRobotModel``)."""

    # set by the model
    robot: RobotDescription
    network: Network
    path: Path
    s_m: float
    length_m: float
    velocity_mps: float
    slipping: bool
    sliding: bool
    held_as_put_in: bool
    _choices: dict[str, TeeChoice]
    _halves: dict[Half, _Half]
    _front: _Half
    _rear: _Half
    _drives: list[_Motor]
    _rot_offset: float
    _slope_cache: dict[int, float]
    _walls: dict[str, float | None]
    _turns_path: Path | None
    _turns: list[Piece]
    _turn_ends: list[float]
    _tees_path: Path | None
    _tees: list[Piece]
    _tees_calm: tuple[float, float]

    def _step_drives(self, dt_s: float) -> None:
        for m in self._drives:
            mode = m.mode
            if mode is ControlMode.VELOCITY:
                target = m.value
            elif mode is ControlMode.PWM:
                target = m.value * self.robot.motion.nominal_speed
            else:
                target = 0.0
            if m.stalled:
                target = 0.0
            delta = target - m.velocity_mps
            if delta == 0.0:
                continue
            step = m.accel_max * dt_s
            m.velocity_mps = (
                target
                if -step <= delta <= step
                else m.velocity_mps + (step if delta > 0 else -step)
            )

    def _step_motion(self, dt_s: float) -> None:
        motion = self.robot.motion
        front, rear = self._front, self._rear
        clamped = [h for h in (front, rear) if h.clamped]
        if clamped:
            self.held_as_put_in = False  # the operator lets go once a half holds
        v_sum = 0.0
        n_wheels = 0
        for h in clamped:
            for m in h.drives:
                if not m.stalled:
                    v_sum += m.velocity_mps
                    n_wheels += 1
        v_cmd = v_sum / n_wheels if n_wheels else 0.0
        any_cmd = False
        for m in self._drives:
            if m.velocity_mps > 1e-6 or m.velocity_mps < -1e-6:
                any_cmd = True
                break
        moved = 0.0
        was_sliding, was_slipping = self.sliding, self.slipping
        self.sliding = False
        self.slipping = False
        stuck_front = stuck_rear = False
        load_ratio = 0.0
        if not clamped:
            slope = self._slope_at(self.s_m - self._rot_offset)
            if abs(slope) > motion.max_unclamped_slope and not self.held_as_put_in:
                self.sliding = True
                direction = -1.0 if slope > 0 else 1.0
                moved = self._limit_to_path(direction * motion.slide_speed * dt_s)
                self._tally.slide_m += abs(moved)
                if not was_sliding:
                    self._violation(
                        "sliding",
                        f"unclamped on a {math.degrees(slope):.0f} deg slope"
                        f" ({self._why_unclamped(front)}; {self._why_unclamped(rear)})",
                    )
            elif any_cmd:
                self.slipping = True
        elif v_cmd > 1e-9 or v_cmd < -1e-9:
            slope = self._slope_at(self.s_m - self._rot_offset)
            traction = motion.friction_coefficient * sum(h.force_n for h in clamped)
            load = motion.weight * math.sin(slope) * (1.0 if v_cmd > 0 else -1.0)
            if v_cmd > 0:
                load += self.network.tether_drag_per_m * max(self.s_m - self.length_m, 0.0)
            load_ratio = max(load, 0.0) / traction if traction > 0 else 1.0
            if traction <= load:
                self.slipping = True
            else:
                moved, stuck_front, stuck_rear = self._gate_turns(v_cmd * dt_s)
                wanted = moved
                moved = self._limit_to_path(moved)
                if wanted > 0 and moved < wanted - 1e-12:
                    # the pipe's far end (a cap): the front half is blocked as at a turn
                    # it may not take, so the wheels stall instead of spinning in place
                    # unnoticed (the entry behind is open: backing to it just stops)
                    stuck_front = True
        self.velocity_mps = moved / dt_s
        if moved:
            self.s_m += moved
            self._tally.distance_m += abs(moved)
        if self.slipping and not was_slipping:
            self._tally.slip_events += 1
            self._event(EventKind.SLIP, f"traction too low at {self.s_m:.3f} m")
        for half, now in ((front, stuck_front), (rear, stuck_rear)):
            if now and not half.stuck:
                self._tally.stuck_events += 1
                point = self.s_m - (half.lead_offset_m if v_cmd > 0 else half.trail_offset_m)
                piece = self.path.next_turn(point - 1e-9) if v_cmd > 0 else None
                if piece is None:
                    turns = self._turns_between(point - 1e-6, point + 1e-6)
                    piece = turns[0] if turns else None
                where = piece.segment if piece is not None else "?"
                if piece is None and self.s_m >= self.path.length_m - 1e-9:
                    where = "end of the pipe"
                self._event(EventKind.STUCK, f"{half.half}:{where}")
                _log.info("%s half stuck at %s", half.half, where)
            half.stuck = now
        if (self._tees and moved) or self._tees_path is not self.path:
            self._decide_tees()
        self._drive_feedback(load_ratio, stuck_front or stuck_rear)

    def _why_unclamped(self, half: _Half) -> str:
        """Why ``half`` holds nothing, joint by joint, for a slide's violation (it said
        only *unclamped on a 90 deg slope*, not which joint let go, nor why)."""
        clamp = self.robot.clamp
        why = []
        for j in half.joints:
            wall = self._walls.get(j.name, math.inf)
            if j.mode is None:
                why.append(f"{j.name} unpowered at {math.degrees(j.angle_rad):.1f} deg")
            elif j.stalled:
                why.append(f"{j.name} stalled")
            elif wall is None:
                why.append(f"{j.name} over a tee opening")
            elif j.press_nm <= 0.0:
                why.append(f"{j.name} free of the wall at {math.degrees(j.angle_rad):.1f} deg")
            elif not clamp.holds(j.press_nm):
                why.append(
                    f"{j.name} presses {j.press_nm:.2f} N*m (a clamp needs {clamp.min_torque:g})"
                )
        if not why:  # every joint presses, but not all on one side
            why.append("its joints press on both sides")
        return f"{half.half.value}: {', '.join(why)}"

    def _slope_at(self, s_m: float) -> float:
        piece = self.path.piece_at(s_m)
        if piece.is_turn:
            return self.path.slope_at(s_m)
        slope = self._slope_cache.get(id(piece))
        if slope is None:
            slope = self._slope_cache[id(piece)] = self.path.slope_at(s_m)
        return slope

    def _limit_to_path(self, ds: float) -> float:
        lo = self.length_m
        hi = self.path.length_m
        return min(max(self.s_m + ds, lo), hi) - self.s_m

    def _gate_turns(self, ds: float) -> tuple[float, bool, bool]:
        """Limit a move so that no half enters or moves in a turn it may not use.

        Returns:
            ``(allowed move, front stuck, rear stuck)``.
        """
        stuck = [False, False]
        allowed = ds
        for i, half in enumerate((self._front, self._rear)):
            point = self.s_m - (half.lead_offset_m if ds > 0 else half.trail_offset_m)
            target = point + ds
            lo, hi = (point, target) if ds > 0 else (target, point)
            for piece in self._turns_between(lo, hi):
                if self._may_use_turn(half, piece):
                    continue
                edge = piece.start_m if ds > 0 else piece.end_m
                if (ds > 0 and point >= edge) or (ds < 0 and point <= edge):
                    # already inside and no longer allowed: stop where it is
                    limit = 0.0
                else:
                    limit = edge - point
                if abs(limit) < abs(allowed):
                    allowed = limit
                stuck[i] = True
                break
        return allowed, stuck[0], stuck[1]

    def _turns_between(self, lo: float, hi: float) -> list[Piece]:
        if self._turns_path is not self.path:
            self._turns_path = self.path
            self._turns = [p for p in self.path.pieces if p.is_turn]
            self._turn_ends = [p.end_m for p in self._turns]
        out: list[Piece] = []
        for piece in self._turns[bisect.bisect_right(self._turn_ends, lo) :]:
            if piece.start_m >= hi:
                break
            out.append(piece)
        return out

    def _may_use_turn(self, half: _Half, piece: Piece) -> bool:
        if half.clamped:
            return False
        sign = self._aligned_sign(half.roll_rad, piece.roll_rad)
        if sign == 0:
            return False
        steer = self.robot.motion.steer_angle
        return all(j.angle_rad * sign >= steer - 1e-9 for j in half.joints)

    def _aligned_sign(self, half_roll: float, turn_roll: float) -> int:
        tol = self.robot.motion.alignment_tolerance
        if abs(_wrap(half_roll - turn_roll)) <= tol:
            return 1
        if abs(_wrap(half_roll - turn_roll - math.pi)) <= tol:
            return -1
        return 0

    def _decide_tees(self) -> None:
        """Choose straight or branch when the front tip passes the middle of a tee."""
        changed = False
        if self._tees_path is not self.path:
            self._tees_path = self.path
            self._tees = [p for p in self.path.pieces if p.opening_m is not None]
            self._tees_calm = (math.inf, -math.inf)
        low, high = self._tees_calm
        if low <= self.s_m < high:
            return  # no tee can be decided or undecided until s_m leaves [low, high)
        for piece in self._tees:
            assert piece.opening_m is not None
            decided = piece.segment in self._choices
            if decided and self.s_m < piece.opening_m - 1e-9:
                # backed out before the opening: the tee is undecided again
                del self._choices[piece.segment]
                changed = True
            elif not decided and self.s_m >= piece.opening_m + 1e-9:
                fake = replace(piece, kind=PieceKind.TEE_TURN)
                front = self._halves[Half.FRONT]
                choice: TeeChoice = "branch" if self._may_use_turn(front, fake) else "straight"
                self._choices[piece.segment] = choice
                self._event(EventKind.TEE, f"{piece.segment}:{choice}")
                changed = True
                if choice == "branch":
                    self.s_m = piece.opening_m
                break
        if changed:
            self.path = self.network.path(self._choices)
            self._tees_calm = (math.inf, -math.inf)
        else:
            # Nothing changed at s_m: nothing will while s_m stays above the opening of
            # every tee decided and below that of every tee undecided (this method is
            # the only one that changes the choices; a new path resets the interval).
            low, high = -math.inf, math.inf
            for piece in self._tees:
                assert piece.opening_m is not None
                if piece.segment in self._choices:
                    low = max(low, piece.opening_m - 1e-9)
                else:
                    high = min(high, piece.opening_m + 1e-9)
            self._tees_calm = (low, high)

    def _drive_feedback(self, load_ratio: float, stuck: bool) -> None:
        motion = self.robot.motion
        free, stall = motion.drive_free_current, motion.drive_stall_current
        slipping = self.slipping
        for m in self._drives:
            v = m.velocity_mps
            if m.stalled:
                m.current_a = stall if (m.mode is not None and m.value != 0) else 0.0
                m.velocity_mps = m.measured_mps = 0.0
            elif -1e-6 < v < 1e-6:
                m.current_a = 0.0
                m.measured_mps = v
            elif stuck:
                m.current_a = stall  # blocked wheels: no speed, stall current
                m.measured_mps = 0.0
            elif slipping:
                m.current_a = free
                m.measured_mps = v
            else:
                m.current_a = free + (stall - free) * min(load_ratio, 1.0)
                m.measured_mps = v
