"""Joints, walls and clamps of the simulated robot, and the torque rules.

:class:`JointsMixin` is the joint side of :class:`~pirate_bt.sim.model.PipeRobotModel`:
each step it moves every joint toward its setpoint (position, torque, PWM, off),
stops bend joints at the wall (``clamp.contact_angle`` of the diameter under
them, none over a tee opening), decides which half is clamped and with what
normal force, turns the rotational module (which half rolls depends on which
is clamped), and applies the over-torque and front-module-in-the-way damage rules.
"""

from __future__ import annotations

import logging
import math

from pirate_bt.pipes import Path
from pirate_bt.robot.description import ControlMode, Half, RobotDescription
from pirate_bt.sim.model_events import EventsMixin
from pirate_bt.sim.model_types import _TORQUE_EPS_NM, _Half, _Motor, _wrap

__all__ = ["JointsMixin"]

_log = logging.getLogger("pirate_bt.sim.model")


class JointsMixin(EventsMixin):
    """The joint, wall and clamp side of the robot model (mixed into ``PipeRobotModel``)."""

    # set by the model
    robot: RobotDescription
    path: Path
    s_m: float
    _halves: dict[Half, _Half]
    _aux_joints: list[_Motor]
    _torqued: list[_Motor]
    _rotate: _Motor
    _front_tilt: _Motor | None
    _front_pressed_since: float | None
    _rotating_free: bool
    _contact_cache: dict[float, float]
    _walls: dict[str, float | None]
    _walls_at: float
    _walls_path: Path | None
    _wall_spans: dict[str, tuple[float, float]]

    def _joint_target(self, m: _Motor) -> tuple[float, float]:
        """(target angle, applied torque if it reaches the target) for a joint motor."""
        if m.mode is ControlMode.POSITION:
            return min(max(m.value, m.angle_min), m.angle_max), 0.0
        if m.mode is ControlMode.TORQUE:
            if abs(m.value) < _TORQUE_EPS_NM:
                return m.angle_rad, 0.0
            return (m.angle_max if m.value > 0 else m.angle_min), abs(m.value)
        if m.mode is ControlMode.PWM:
            if m.value == 0:
                return m.angle_rad, 0.0
            torque = abs(m.value) * m.stall_torque
            return (m.angle_max if m.value > 0 else m.angle_min), torque
        return m.angle_rad, 0.0  # off: limp, the gears hold the angle

    def _step_joints(self, dt_s: float) -> bool:
        """Step every joint; True when a bend joint may have changed (contacts need a look)."""
        hold = self.robot.motion.position_hold_torque
        changed = False
        for half in self._halves.values():
            for j in half.joints:
                wall = self._walls[j.name]
                key = (j.mode, j.value, wall, j.angle_rad, j.stalled)
                if key == j.settled:
                    continue  # nothing moved and nothing changed since the last step
                changed = True
                target, torque = self._joint_target(j)
                if j.stalled:
                    # Blocked where it stands, but the board still closes its loop: in
                    # torque mode the motor applies the commanded torque (PWM: its share
                    # of the stall torque), so a stall alone is no over-torque. Only a
                    # position loop that cannot reach its setpoint saturates.
                    if j.mode is ControlMode.POSITION:
                        j.torque_nm = j.stall_torque if target != j.angle_rad else 0.0
                    else:
                        j.torque_nm = torque
                    j.press_nm = 0.0
                    # Not settled: when the stall ends the joint must be stepped again
                    # (it presses on the wall, or moves on, as its setpoint asks), even
                    # if nothing changed since it last settled.
                    j.settled = None
                    continue
                limit = wall if wall is not None else math.inf
                # the wall stops the joint at +-wall
                blocked_target = min(max(target, -limit), limit)
                step = j.rate_max * dt_s
                delta = blocked_target - j.angle_rad
                j.angle_rad += max(-step, min(step, delta))
                pushing_wall = (
                    wall is not None
                    and abs(j.angle_rad) >= wall - 1e-9
                    and abs(target) > wall + 1e-9
                    and target * j.angle_rad > 0
                )
                if pushing_wall:
                    press = torque if j.mode is not ControlMode.POSITION else hold
                    j.press_nm = press
                    j.torque_nm = press
                else:
                    j.press_nm = 0.0
                    j.torque_nm = torque if j.mode is not ControlMode.POSITION else 0.0
                if j.angle_rad == blocked_target:
                    j.settled = (j.mode, j.value, wall, j.angle_rad, j.stalled)
        for m in self._aux_joints:
            if m.stalled or (m.mode is None and m.torque_nm == 0.0):
                continue
            target, torque = self._joint_target(m)
            step = m.rate_max * dt_s
            m.angle_rad += max(-step, min(step, target - m.angle_rad))
            m.torque_nm = torque
        return changed

    def _wall_angle(self, s_m: float) -> float | None:
        """Joint angle at which the wheels touch the wall at ``s_m``; None over a tee opening,
        infinite in a pipe wider than the robot's ``clamp.contact_angles`` (no wall within
        reach: the joints swing to their limits and the half cannot clamp)."""
        piece = self.path.piece_at(s_m)
        if piece.opening_m is not None and piece.over_opening(s_m):
            return None
        diameter = piece.diameter_at(s_m)
        angle = self._contact_cache.get(diameter)
        if angle is None:
            clamp = self.robot.clamp
            if diameter > max(p.diameter for p in clamp.contact_angles) + 1e-9:
                angle = math.inf  # wider than the table: the wheels never reach the wall
            else:
                angle = clamp.contact_angle(diameter)
            self._contact_cache[diameter] = angle
        return angle

    def _update_walls(self) -> bool:
        """Recompute the wall angle under each bend joint; True when one changed."""
        if self.s_m == self._walls_at and self.path is self._walls_path:
            return False
        changed = False
        self._walls_at = self.s_m
        path_changed = self.path is not self._walls_path
        self._walls_path = self.path
        spans = self._wall_spans
        for half in self._halves.values():
            for j, off in zip(half.joints, half.joint_offsets_m, strict=True):
                at = self.s_m - off
                span = spans.get(j.name)
                if not path_changed and span is not None and span[0] <= at < span[1]:
                    continue  # same plain piece of constant diameter: same wall
                wall = self._wall_angle(at)
                if wall != self._walls.get(j.name, math.nan):
                    changed = True
                self._walls[j.name] = wall
                piece = self.path.piece_at(at)
                plain = piece.opening_m is None and piece.diameter_start_m == piece.diameter_end_m
                spans[j.name] = (piece.start_m, piece.end_m) if plain else (0.0, 0.0)
        return changed or path_changed

    def _update_contacts(self) -> None:
        self._update_walls()
        self._contacts()

    def _contacts(self) -> None:
        clamp = self.robot.clamp
        lever = clamp.lever_arm
        for half in self._halves.values():
            force = 0.0
            ok = bool(half.joints)
            sign = 0.0
            opening = False
            for j in half.joints:
                if self._walls[j.name] is None:
                    opening = True
                force += j.press_nm / lever
                if not clamp.holds(j.press_nm):
                    ok = False
                if sign == 0.0:
                    sign = math.copysign(1.0, j.angle_rad)
                elif sign * j.angle_rad < 0:
                    ok = False
            half.force_n = force
            half.clamped = ok and not opening
            half.over_opening = opening

    def _step_rotation(self, dt_s: float) -> None:
        m = self._rotate
        front, rear = self._halves[Half.FRONT], self._halves[Half.REAR]
        target, torque = self._joint_target(m)
        delta = target - m.angle_rad
        moving = abs(delta) > 1e-9 and not m.stalled
        if front.clamped and rear.clamped and moving:
            m.torque_nm = max(torque, m.stall_torque)  # both halves held: the motor stalls
            self._rotating_free = False
            return
        m.torque_nm = torque if moving else 0.0
        if not moving:
            self._rotating_free = False
            return
        step = m.rate_max * dt_s
        d = max(-step, min(step, delta))
        m.angle_rad += d
        if front.clamped:
            rear.roll_rad = _wrap(rear.roll_rad - d)
            self._rotating_free = False
        elif rear.clamped:
            front.roll_rad = _wrap(front.roll_rad + d)
            self._rotating_free = False
        else:
            front.roll_rad = _wrap(front.roll_rad + d / 2)
            rear.roll_rad = _wrap(rear.roll_rad - d / 2)
            if not self._rotating_free:
                self._violation("uncontrolled_rotation", "rotated with no half clamped")
            self._rotating_free = True

    def _check_torques(self) -> None:
        over_time = self.robot.motion.over_torque_time
        for m in self._torqued:
            if m.torque_nm > m.torque_limit + 1e-9:
                if m.over_since_s is None:
                    m.over_since_s = self.time_s
                elif self.time_s - m.over_since_s >= over_time and not m.damaged_this_episode:
                    m.damaged_this_episode = True
                    self._damage(f"over_torque:{m.name}", f"{m.torque_nm:.2f} N*m")
            else:
                m.over_since_s = None
                m.damaged_this_episode = False
        # the front module in the way of a front clamp
        front = self._halves[Half.FRONT]
        tilt = self._front_tilt
        pressing = any(j.press_nm > 0 for j in front.joints)
        clear = tilt is None or abs(tilt.angle_rad) >= self.robot.clamp.front_clear_angle - 1e-9
        if pressing and not clear:
            if self._front_pressed_since is None:
                self._front_pressed_since = self.time_s
            elif self.time_s - self._front_pressed_since >= over_time:
                self._damage("front_pressed", "front half clamped with the front module in the way")
                self._front_pressed_since = math.inf
        else:
            self._front_pressed_since = None
