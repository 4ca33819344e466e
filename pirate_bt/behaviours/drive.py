"""The ``drive`` primitive: drive every wheel until a distance or a feature of the pipe.

A drive ends when the wheel odometry has covered a distance, or when a feature
shows itself in the sensors: the robot is blocked at a turn it may not take, a
joint of the leading half swings off the wall over a tee's opening, or the
joints of the trailing half have crossed an opening and are back at the wall.
Driving backwards the rear half leads: ``rear_opening`` and
``front_opening_passed`` are the mirrors of ``front_opening`` and
``opening_passed``. ``front_opening_cleared`` backs the front half off an
opening it stopped over; ``turned`` ends when the IMU's heading (the pipe's
direction at the rotational module) has turned: the robot is entering a turn.
``stop_when_turned`` also ends an ``until: blocked`` drive on that turn: entering a
tee's branch of 65 mm and more, the holding rear half would reach the branch's
opening, and let go of the wall, before the turn could block it.
``stop_at_change`` ends a distance drive where the pipe changes under the robot
(a survey's straights end there): the IMU's
pitch has moved from where the drive started (a slope change at the rotational
module), or a joint of the leading half, at the wall, reads another diameter than
it did at the start (a reducer under the leading half).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Literal

from py_trees.common import Status
from pydantic import Field, StrictBool

from pirate_bt.behaviours.base import NodeParams
from pirate_bt.behaviours.grip import GripWatch
from pirate_bt.behaviours.opening_edge import OpeningEdge
from pirate_bt.behaviours.pipe_change import (
    DIAMETER_CHANGE_M,
    DIAMETER_SETTLE_M,
    SLOPE_CHANGE_RAD,
    SLOPE_WINDOW_TICKS,
    PipeChangeWatch,
)
from pirate_bt.behaviours.primitive import (
    _SETTLE_TICKS,
    Primitive,
    _commands,
    _exact,
    _read_metres,
    _write_blackboard,
)
from pirate_bt.behaviours.slip_watch import SlipWatch, no_turn_felt
from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.robot.state import RobotState, wheel_fresh_window_s
from pirate_bt.safety import ClampState
from pirate_bt.safety.checks import classify_half, off_wall_rad
from pirate_bt.units import Angle, Current, Duration, Length, Velocity

__all__ = [
    "DIAMETER_CHANGE_M",
    "DIAMETER_SETTLE_M",
    "SLOPE_CHANGE_RAD",
    "SLOPE_WINDOW_TICKS",
    "TIME_MARGIN",
    "Drive",
    "DriveParams",
    "Until",
]


TIME_MARGIN = 2.0
"""A drive given no ``timeout`` has this many times the time its travel takes at its
speed, when that is longer than the default (120 s): the straight PAB gives none, and
a mission's leg of 11 m at 80 mm/s (137 s) timed out at 9.6 m, in pipe the robot
drives through (before the twenty-third session)."""

Until = Literal[
    "distance",
    "blocked",
    "front_opening",
    "rear_opening",
    "opening_passed",
    "front_opening_passed",
    "front_opening_cleared",
    "turned",
]


def _heading_vector(imu_rad: Mapping[str, float]) -> tuple[float, float, float] | None:
    """The unit vector along the pipe at the IMU, from its pitch and yaw (``None``
    without both): x, y level, z up."""
    pitch = imu_rad.get("pitch")
    yaw = imu_rad.get("yaw")
    if pitch is None or yaw is None:
        return None
    return (math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch))


class DriveParams(NodeParams):
    velocity: Velocity = Field(description="wheel speed; negative drives backwards")
    reverse: StrictBool = Field(
        False,
        description=(
            "drive at minus velocity: a PAB that passes a feature backwards takes its"
            " speed as its forward twin does (positive) and drives it backwards"
        ),
    )
    distance: Length | None = Field(
        None, gt=0, description="odometry distance that completes the drive (until: distance)"
    )
    until: Until = Field(
        "distance",
        description=(
            "what completes the drive: 'distance' travelled; 'blocked' (every drive draws"
            " stall current: the leading half is held at a turn it may not take);"
            " 'front_opening' (a front joint swung past every wall-contact angle: the"
            " front half is over a tee's opening);"
            " 'rear_opening' (the same for a rear joint: driving backwards, the rear half"
            " is over a tee's opening);"
            " 'opening_passed' (every rear joint, pressing the wall, swung off it over a"
            " tee's opening and is back at the wall behind it);"
            " 'front_opening_passed' (the same for every front joint: driving backwards,"
            " the front half crossed the opening);"
            " 'front_opening_cleared' (a front joint off the wall over an opening when the"
            " drive starts, and now none: backing from a 'front_opening' stop, the front"
            " half is back before the opening; fails at once when no front joint is off"
            " the wall at the start);"
            " 'turned' (the IMU's heading, the pipe's direction at the rotational module"
            " from its pitch and yaw, turned by at least 'turn_angle' from where the drive"
            " started, two ticks running: the robot is entering a turn)"
        ),
    )
    turn_angle: Angle = Field(
        math.radians(10.0),
        gt=0,
        lt=math.pi,
        description="with until: turned, the heading change that completes the drive",
    )
    max_distance: Length = Field(
        3.0, gt=0, description="fail when no feature was found within this distance"
    )
    distance_key: str | None = Field(
        None,
        pattern=r"^(/?[A-Za-z_][A-Za-z0-9_/]*)?$",
        description=(
            "blackboard key holding the distance in metres, read when the drive starts"
            " (instead of 'distance'; a planner writes it from the robot's belief);"
            " a value of 1 mm or less completes the drive at once; empty: not used"
        ),
    )
    travelled_key: str | None = Field(
        None,
        pattern=r"^(/?[A-Za-z_][A-Za-z0-9_/]*)?$",
        description=(
            "blackboard key the drive writes the distance it travelled to (metres of"
            " odometry, never negative) when it ends, however it ends (0 when it starts):"
            " a drive back the same way reads it with 'distance_key'; empty: not used"
        ),
    )
    overshoot_key: str | None = Field(
        None,
        pattern=r"^(/?[A-Za-z_][A-Za-z0-9_/]*)?$",
        description=(
            "blackboard key the drive writes when a joint off the wall over an opening"
            " ends it: how far it drove since that joint began to swing off the wall"
            " (metres past the opening's near edge; 0 when it starts, and for any other"
            " end): a later drive takes it off its distance with 'less_key'; empty: not"
            " used"
        ),
    )
    less_key: str | None = Field(
        None,
        pattern=r"^(/?[A-Za-z_][A-Za-z0-9_/]*)?$",
        description=(
            "blackboard key holding metres to take off 'distance' when the drive starts"
            " (an 'overshoot_key': a distance counted from an opening's near edge, not"
            " from where the drive that found it stopped); nothing left completes the"
            " drive at once; empty: not used"
        ),
    )
    stop_at_feature: StrictBool = Field(
        False,
        description=(
            "with until: distance, also complete the drive (early) when a feature shows:"
            " blocked at a turn, or a joint of the leading half (front driving forwards,"
            " rear driving backwards) off the wall over an opening"
        ),
    )
    stop_at_change: StrictBool = Field(
        False,
        description=(
            "with until: distance, also complete the drive (early) where the pipe changes:"
            f" the IMU's pitch, a mean of {SLOPE_WINDOW_TICKS} readings,"
            f" {math.degrees(SLOPE_CHANGE_RAD):g} deg or more from its mean at the start (a"
            " slope change at the rotational module), or a joint of the leading half, at"
            f" the wall, reading a diameter {DIAMETER_CHANGE_M * 1000:g} mm or more off its"
            f" reading at the start over {DIAMETER_SETTLE_M * 1000:g} mm of travel (a reducer)"
        ),
    )
    stop_when_turned: StrictBool = Field(
        False,
        description=(
            "with until: blocked, also complete the drive when the IMU's heading has turned"
            " by at least 'turn_angle' from where the drive started, two ticks running"
            " (fails at once without IMU pitch and yaw): turning into a tee's branch, the"
            " holding rear half must stop before it reaches the branch's opening, which in"
            " a tee of 65 mm and more comes before the turn could block it"
        ),
    )
    stall_current: Current | None = Field(
        None, gt=0, description="current counted as stalled (default 80 % of the stall current)"
    )
    stall_time: Duration = Field(0.5, gt=0, description="how long a stall lasts before failing")
    timeout: Duration = Field(
        120.0,
        gt=0,
        description=(
            "fail if not done within this time; not given, a drive whose travel (its"
            " distance, else max_distance) takes longer at its speed has twice that time"
        ),
    )


class Drive(Primitive):
    """Drive every wheel at ``velocity`` until a distance or a feature; stop at the end.

    Odometry integrates the mean measured wheel speed. A drive motor drawing at least
    ``stall_current`` while turning at less than a fifth of the commanded speed for
    ``stall_time`` is a stall (failure). Every motor drawing stall current while the
    robot makes no progress (mean wheel speed below a fifth of the command) means
    the robot is held by the pipe: success for ``until: blocked``, a failure
    otherwise. A heavy load that the wheels still carry (nearly stall current at
    speed) is neither. No half holding the robot, because a joint that pressed the wall
    stopped where it was and presses nothing (a stalled clamp joint), is a failure
    (``grip lost``, :mod:`pirate_bt.behaviours.grip`): the wheels would slip and the
    odometry count it. ``terminate()`` always stops the drives.
    """

    Params = DriveParams
    verb = "drive"

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        problems: list[str] = []
        if params.velocity == 0:
            problems.append("velocity: must not be 0")
        if params.until == "distance" and params.distance is None and not params.distance_key:
            problems.append("distance: required with until: distance")
        if params.stop_when_turned and params.until != "blocked":
            problems.append("stop_when_turned: only with until: blocked")
        if params.stop_at_change and params.until != "distance":
            problems.append("stop_at_change: only with until: distance")
        if params.overshoot_key and not (
            params.until in ("front_opening", "rear_opening") or params.stop_at_feature
        ):
            problems.append(
                "overshoot_key: only with until: front_opening or rear_opening, or stop_at_feature"
            )
        if params.less_key and params.until != "distance":
            problems.append("less_key: only with until: distance")
        for key in ("distance", "distance_key"):  # else ignored: it drove max_distance
            if getattr(params, key) and params.until != "distance":
                problems.append(
                    f"{key}: only with until: distance (max_distance bounds a drive until"
                    f" {params.until})"
                )
        drives = robot.drive_motors()
        if drives and not any(m.feedback.velocity for m in drives):
            # it would drive "0.000 m" until its timeout, or call every drive blocked
            problems.append(
                "the robot's drives have no velocity feedback (feedback.velocity in its"
                " description): a drive measures its distance and its grip by the wheels'"
                " speed"
            )
        for motor in drives:
            lim = motor.limits.velocity
            if lim is not None and abs(params.velocity) > lim.max:
                problems.append(
                    f"velocity: {_exact(params.velocity * 1000)} mm/s is above {motor.name}'s limit"
                    f" {lim.max * 1000:g} mm/s"
                )
                break
        return problems

    @classmethod
    def blackboard_reads(cls, params: Any) -> tuple[str, ...]:
        keys = (params.distance_key, params.less_key)
        return tuple(k.lstrip("/") for k in keys if k)

    @classmethod
    def blackboard_writes(cls, params: Any) -> tuple[str, ...]:
        keys = (params.travelled_key, params.overshoot_key)
        return tuple(k.lstrip("/") for k in keys if k)

    def start(self) -> None:
        p: DriveParams = self.params  # type: ignore[assignment]
        self._distance_m = p.distance
        self._wheel_window_s = wheel_fresh_window_s(self.robot)  # odometry's freshness
        self._bad_distance: str | None = None
        self.sensed: str | None = None
        """What ended the drive early (``blocked``, ``front_opening``), if anything."""
        self.sensed_after_m: float | None = None
        """How far the drive had travelled when it sensed what ended it (``sensed``)."""
        for key, less in ((p.distance_key, False), (p.less_key, True)):
            value = _read_metres(key) if key and self._bad_distance is None else None
            if isinstance(value, str):
                self._bad_distance = value
            elif value is not None:  # a distance, or metres off it (none left: done)
                taken = max((self._distance_m or 0.0) - value, 0.0)
                self._distance_m = taken if less else value
        if "timeout" not in p.model_fields_set:  # the default: long enough for the travel
            travel = self._distance_m if p.until == "distance" else p.max_distance
            if travel is not None and math.isfinite(travel):
                self._timeout_s = max(p.timeout, TIME_MARGIN * travel / abs(p.velocity))
        self._at_speed = False
        self._resend = False
        self._odometry_m = 0.0
        self._last_s = self.now()
        self._stall_since: dict[str, float] = {}
        self._blocked_since: float | None = None
        self._lost_wall: dict[str, bool] = {}
        self._found_wall: set[str] = set()
        self._back_ticks: dict[str, int] = {}
        self._slow_since: float | None = None
        self._heading0: tuple[float, float, float] | None = None
        self._turned_ticks = 0
        self._change = PipeChangeWatch(self.robot)
        self.sensed_back_m = 0.0
        """How far back (metres of travel) a sensed slope change began: 0 otherwise."""
        self._first_step = True
        self._grip = GripWatch(self.robot)
        self._slip = SlipWatch(self.robot)
        self._edge = OpeningEdge(self.robot, self._opening_halves(self._velocity()))
        self._write_travelled()
        if p.overshoot_key:
            _write_blackboard(p.overshoot_key, 0.0)

    def stop_motion(self) -> None:
        self.supervisor.stop()

    def terminate(self, new_status: Status) -> None:
        if self.supervisor is not None:
            self.supervisor.stop()
        if hasattr(self, "_odometry_m"):  # started at least once
            self._write_travelled()

    def _write_travelled(self) -> None:
        key = self.params.travelled_key  # type: ignore[attr-defined]
        if key:
            _write_blackboard(key, abs(self._odometry_m))

    def _ramped(self, velocity: float) -> float:
        """The speed to ask for this tick: ``velocity``, or where an acceleration limit
        refuses a larger step (``policy: refuse``), the step toward it that it allows
        (with ``clip`` the supervisor clips the step and the drive asks again)."""
        refuses = any(
            (acc := m.limits.acceleration) is not None and acc.policy.value == "refuse"
            for m in self.robot.drive_motors()
        )
        reach = getattr(self.supervisor, "drive_reach", None)
        return float(reach(velocity)) if refuses and reach is not None else velocity

    def _off_wall(self, state: RobotState, half: Half) -> dict[str, bool]:
        """Per bend module of ``half``: has its joint swung past every wall-contact angle?"""
        beyond = off_wall_rad(self.robot)
        return {
            m.name: abs(state.joint_angle_rad.get(m.name, 0.0)) > beyond
            for m in self.robot.bend_modules(half)
        }

    def _velocity(self) -> float:
        p: DriveParams = self.params  # type: ignore[assignment]
        return -p.velocity if p.reverse else p.velocity

    def _opening_halves(self, velocity: float) -> tuple[Half, ...]:
        """The halves whose joints off the wall end this drive: the one ``until`` names,
        and with ``stop_at_feature`` the leading one (the rear half driving backwards)."""
        p: DriveParams = self.params  # type: ignore[assignment]
        halves: tuple[Half, ...] = ()
        if p.until == "front_opening":
            halves = (Half.FRONT,)
        elif p.until == "rear_opening":
            halves = (Half.REAR,)
        if p.stop_at_feature:
            leading = Half.FRONT if velocity > 0 else Half.REAR
            if leading not in halves:
                halves = (*halves, leading)
        return halves

    def _opening_passed(self, state: RobotState, half: Half) -> bool:
        """True once every bend module of ``half`` has crossed an opening and is at the
        wall again.

        A pressing joint swings past every wall-contact angle over the opening (lost)
        and is pushed back by the wall behind it. It counts as past the opening only
        when it is back *at the wall* - within the contact range and, with a spring
        sensor, pressing on it, for ``_SETTLE_TICKS`` ticks - not as soon as it swings
        back below the off-wall threshold, when the module may still be at the edge of
        the opening. A joint
        that swings out again (a second opening, noise) must come back again.
        """
        robot = self.robot
        clamp = robot.clamp
        tol = robot.safety.angle_tolerance
        wall_max = max(c.angle for c in clamp.contact_angles) + tol
        wall_min = min(c.angle for c in clamp.contact_angles) - tol
        pressing_n = robot.safety.clamp_force_fraction * clamp.min_torque / clamp.lever_arm
        passing = [m.name for m in robot.bend_modules(half)]
        for name, off in self._off_wall(state, half).items():
            angle = state.joint_angle_rad.get(name)
            force = state.clamp_force_n.get(name)
            if off:
                self._lost_wall[name] = True
                self._back_ticks[name] = 0
                self._found_wall.discard(name)
            elif self._lost_wall.get(name) and angle is not None:
                # at the wall: in the contact range and, with a spring, pressing on it
                at_wall = wall_min <= abs(angle) <= wall_max and (
                    force is None or abs(force) >= pressing_n
                )
                self._back_ticks[name] = self._back_ticks.get(name, 0) + 1 if at_wall else 0
                if self._back_ticks[name] >= _SETTLE_TICKS:
                    self._found_wall.add(name)
        return bool(passing) and self._found_wall >= set(passing)

    def _start_state(self, state: RobotState) -> str | None:
        """Read what ``until`` compares with on the first state; a reason to fail, if any."""
        p: DriveParams = self.params  # type: ignore[assignment]
        if all(classify_half(self.robot, state, h) is ClampState.UNCLAMPED for h in Half):
            # the supervisor lets it go on the level (nothing is damaged), but the
            # wheels would turn on the spot while the odometry counted the distance
            return (
                "no half holds the robot (front unclamped, rear unclamped): the wheels"
                " would turn on the spot; clamp a half first"
            )
        if p.until == "front_opening_cleared" and not any(
            self._off_wall(state, Half.FRONT).values()
        ):
            return "front half not over an opening: no front joint off the wall"
        if p.until == "turned" or p.stop_when_turned:
            self._heading0 = _heading_vector(state.imu_rad)
            if self._heading0 is None:
                why = "until: turned" if p.until == "turned" else "stop_when_turned"
                return f"no IMU pitch and yaw: cannot tell a turn ({why})"
        return None

    def _turned(self, state: RobotState) -> float | None:
        """The heading change since the start once it is at least ``turn_angle`` for
        ``_SETTLE_TICKS`` ticks running, else ``None``."""
        p: DriveParams = self.params  # type: ignore[assignment]
        now = _heading_vector(state.imu_rad)
        if now is None or self._heading0 is None:
            self._turned_ticks = 0
            return None
        dot = sum(a * b for a, b in zip(self._heading0, now, strict=True))
        angle = math.acos(max(-1.0, min(1.0, dot)))
        self._turned_ticks = self._turned_ticks + 1 if angle >= p.turn_angle else 0
        return angle if self._turned_ticks >= _SETTLE_TICKS else None

    def step(self, state: RobotState) -> Status:
        p: DriveParams = self.params  # type: ignore[assignment]
        if self._bad_distance is not None:
            return self.fail(self._bad_distance)
        target = self._distance_m
        if p.until == "distance" and target is not None and target <= 1e-3:
            self.feedback_message = "nothing to drive"
            return Status.SUCCESS
        now = self.now()
        dt = max(now - self._last_s, 0.0)
        self._last_s = now
        speed = state.mean_drive_velocity_mps(state.stamp_s - self._wheel_window_s)
        self._odometry_m += speed * dt
        travelled = abs(self._odometry_m)
        velocity = self._velocity()
        if self._first_step:
            self._first_step = False
            problem = self._start_state(state)
            if problem is not None:
                return self.fail(problem)
        # checked before (re)sending: a half already over an opening is done at once
        self._edge.update(state, travelled, dt)
        for half in self._opening_halves(velocity):
            off = [name for name, out in self._off_wall(state, half).items() if out]
            if off:
                past = self._edge.past(off, travelled)
                self.feedback_message = (
                    f"{half} half over an opening after {travelled:.3f} m"
                    f" ({past * 1000:.0f} mm past its edge)"
                )
                self.sensed = f"{half}_opening"
                if p.overshoot_key:
                    _write_blackboard(p.overshoot_key, past)
                return Status.SUCCESS
        if p.stop_at_change:
            change = self._change.changed(state, velocity, travelled)
            if change is not None:
                self.sensed_back_m = self._change.sensed_back_m
                self.feedback_message = f"the {change} changed after {travelled:.3f} m"
                self.sensed = change
                return Status.SUCCESS
        lost = self._grip.update(state, now)
        if lost is not None:
            return self.fail(f"{lost} (after {travelled:.3f} m)")
        slip = self._slip.update(state, now, travelled)
        if slip is not None:
            if p.stop_when_turned:  # the turn into a tee's branch, and none was felt
                slip += no_turn_felt(self._heading0, _heading_vector(state.imu_rad), p.turn_angle)
            search = f"no feature ({p.until}) before slipping" if p.until != "distance" else ""
            return self.fail(f"{search or 'slipping'}: {slip}")
        if not self._at_speed:
            asked = self._ramped(velocity)
            command = _commands().Drive(asked)
            if self._resend and self.supervisor.check(command).refused:
                pass  # asking again now would be refused: keep going, ask again later
            else:
                ok, done = self.send(command)
                if not ok:
                    return self.refused()
                self._at_speed = done and asked == velocity
        robot = self.robot
        stall_a = p.stall_current or 0.8 * robot.motion.drive_stall_current
        drives = robot.drive_motors()
        currents = {m.name: state.motor_current_a.get(m.name, 0.0) for m in drives}
        speeds = {m.name: state.drive_velocity_mps.get(m.name, 0.0) for m in drives}
        self.feedback_message = (
            f"drove {travelled:.3f} m at {speed * 1000:.0f} mm/s"
            f" (max current {max(currents.values(), default=0.0):.2f} A)"
        )
        # a stall: a motor drawing stall current without turning
        for name, current in currents.items():
            turning = abs(speeds[name]) >= 0.2 * abs(p.velocity)
            if current >= stall_a and not turning:
                since = self._stall_since.setdefault(name, now)
                if now - since >= p.stall_time:
                    return self.fail(
                        f"stall: {name} draws {current:.2f} A at {speeds[name] * 1000:.0f} mm/s"
                        f" for {now - since:.2f} s (commanded {p.velocity * 1000:g} mm/s)"
                    )
            else:
                self._stall_since.pop(name, None)
        # blocked: every wheel pushes against the pipe at stall current and the robot
        # makes no progress. Current alone is not enough: a heavy load (a long tether up
        # a riser) draws nearly stall current while the robot climbs at full speed.
        progressing = abs(speed) >= 0.2 * abs(p.velocity)
        if currents and all(c >= stall_a for c in currents.values()) and not progressing:
            if self._blocked_since is None:
                self._blocked_since = now
            if now - self._blocked_since >= min(p.stall_time, 0.3):
                if p.until == "blocked" or p.stop_at_feature:
                    self.feedback_message = f"blocked after {travelled:.3f} m"
                    self.sensed = "blocked"
                    self.sensed_after_m = travelled
                    return Status.SUCCESS
                return self.fail(
                    f"blocked: every drive draws stall current after {travelled:.3f} m"
                    " (a turn the robot may not take, or the end of the pipe?)"
                )
        else:
            self._blocked_since = None
        if p.until == "distance" and target is not None and travelled >= target:
            return Status.SUCCESS
        passing = {"opening_passed": Half.REAR, "front_opening_passed": Half.FRONT}.get(p.until)
        if passing is not None and self._opening_passed(state, passing):
            self.feedback_message = f"{passing} half passed an opening after {travelled:.3f} m"
            return Status.SUCCESS
        if p.until == "front_opening_cleared" and not any(
            self._off_wall(state, Half.FRONT).values()
        ):
            self.feedback_message = f"front half off the opening after {travelled:.3f} m"
            self.sensed = "front_opening_cleared"
            return Status.SUCCESS
        if p.until == "turned" or (p.until == "blocked" and p.stop_when_turned):
            turned = self._turned(state)
            if turned is not None:
                self.feedback_message = (
                    f"turned {math.degrees(turned):.1f}° after {travelled:.3f} m"
                )
                self.sensed = "turned"
                return Status.SUCCESS
        if p.until != "distance" and travelled >= p.max_distance:
            return self.fail(f"no feature ({p.until}) within {p.max_distance:g} m")
        # the bridge's watchdog may have stopped the wheels: ask again
        if self._at_speed and abs(speed) < 0.2 * abs(p.velocity):
            if self._slow_since is None:
                self._slow_since = now
            elif now - self._slow_since >= 0.5 and max(currents.values(), default=0.0) < stall_a:
                self._at_speed = False
                self._resend = True
                self._slow_since = None
        else:
            self._slow_since = None
        return Status.RUNNING
