"""The supervisor's protective hold: no robot left falling in a steep pipe.

:class:`HoldMixin` is the side of :class:`~pirate_bt.safety.supervisor.Supervisor`
that acts on its own when the readings say the robot is held by nothing in a pipe
steeper than ``motion.max_unclamped_slope``. The checks never let a command cause
that (``check_steep_pipe``), so it comes from a fault: a bend joint that stalls on
the half that holds (its wheels stop pressing), a board that loses power, a half
that reached a tee's opening while the link was slow. Every tick, once a half has
held the robot, when the IMU's pitch is steep and no half is clamped by fresh
readings, the supervisor enters its safe state (the drives stop; the first cause is
kept) and clamps every half that is not holding, at :data:`HOLD_TORQUE_FRACTION` of
the bend joints' torque limit, sent to the link directly (a board that cannot be
reached is tried again next tick) but only where the invariants allow it (the front
half does not clamp with the front module in the way). Without a pitch reading it
does nothing (it cannot tell a steep pipe); nor, while a run goes on, for a robot set
down free, before any half held (its tree's first clamp is on its way): the end of the
run clamps that one (:meth:`HoldMixin.come_to_rest`). A front half whose module is in
its way is clamped once the hold has tilted the module clear.
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

from pirate_bt.clock import Clock
from pirate_bt.errors import LinkError
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, RobotDescription, SensorKind
from pirate_bt.robot.port import RobotPort
from pirate_bt.robot.state import RobotState, wheel_fresh_window_s
from pirate_bt.safety.checks import (
    Check,
    CheckContext,
    ClampState,
    HalfTarget,
    Intent,
    Problem,
    check_steep_pipe,
    half_states,
    off_wall_rad,
    released_force_n,
    stale_channels,
)
from pirate_bt.safety.commands import Clamp, MoveFrontClear
from pirate_bt.safety.expand import Expander
from pirate_bt.safety.limits import limit
from pirate_bt.safety.operator import Mode
from pirate_bt.safety.verdict import Outcome, Reason, Source, Verdict

__all__ = [
    "HOLD_SETTLE_S",
    "HOLD_TORQUE_FRACTION",
    "STILL_MPS",
    "STOPPED_FRACTION",
    "HoldMixin",
    "hold_torque",
    "why_half_holds_nothing",
]

log = logging.getLogger("pirate_bt.safety")

HOLD_TORQUE_FRACTION = 0.875
"""The protective clamp's torque, as a share of the bend joints' torque limit (0.7 N·m
on the bundled robot's 0.8 N·m joints, the bundled trees' clamp torque)."""


HOLD_SETTLE_S = 3.0
"""How long (clock time) the end of a run waits for a protective clamp to land
(:meth:`HoldMixin.settle_hold`): a joint steered the other way swings across first."""

STILL_MPS = 0.002
"""A wheel reading at most this fast (m/s) is still, for the end of a run."""

STOPPED_FRACTION = 0.25
"""A joint pressing nothing within this share of ``safety.angle_tolerance`` (0.43° on
the bundled robot, five counts of its angle sensors) of the angle a partner joint of its
half presses the wall at stopped there (its motor stalled): one over a tee's opening
swings on under its clamp torque (0.9° in one 10 ms state at 90°/s)."""


def hold_torque(robot: RobotDescription) -> float:
    """The protective clamp's torque: :data:`HOLD_TORQUE_FRACTION` of the lowest bend
    joint torque limit (twice ``clamp.min_torque`` without one), never below the
    minimum that holds."""
    limits = [
        lim.max
        for half in Half
        for m in robot.bend_modules(half)
        if (lim := robot.joint_motor(m.name).limits.torque) is not None
    ]
    torque = HOLD_TORQUE_FRACTION * min(limits) if limits else 2 * robot.clamp.min_torque
    return max(torque, robot.clamp.min_torque)


def why_half_holds_nothing(
    robot: RobotDescription, state: RobotState, half: Half, kind: ClampState
) -> str:
    """Why ``half`` (of clamp state ``kind``) holds nothing, joint by joint, for people:
    ``front released``, ``rear bend_3 off the wall at 110.0°, over an opening``, ``rear
    bend_3 off the wall at 84.0° with its spring at 0.0 N, over an opening`` (a joint
    bent as far as the half's holding joints, or further, pressing on nothing: it
    swings out over a tee's opening), ``front bend_1 presses 4.0 N at 83.1° (a clamp
    holds from 8.75 N)``, ``front bend_1 presses 0.0 N at 83.1°, stopped at the wall (a
    stalled joint motor?)`` (a released force at the angle its partner presses at, within
    :data:`STOPPED_FRACTION` of the angle tolerance: a joint pressing nothing over an
    opening swings on past it). A drive's slip and the protective hold say it alike."""
    if kind is ClampState.UNCLAMPED:
        return f"{half} released"
    clamp = robot.clamp
    tol = robot.safety.angle_tolerance
    beyond = off_wall_rad(robot)
    wall_min = min(c.angle for c in clamp.contact_angles) - tol
    joints = []
    for module in robot.bend_modules(half):
        angle = state.joint_angle_rad.get(module.name)
        force = state.clamp_force_n.get(module.name)
        joints.append((module.name, None if angle is None else abs(angle), force))
    held = [
        a
        for _, a, f in joints
        if a is not None and a >= wall_min and (f is None or clamp.holds_force(abs(f)))
    ]
    still = tol * STOPPED_FRACTION
    released = released_force_n(robot)
    off: list[str] = []
    stopped: list[str] = []
    other: list[str] = []
    for name, angle, force in joints:
        if angle is None:
            other.append(f"{name} unread")
            continue
        deg = math.degrees(angle)
        if angle > beyond:
            off.append(f"{name} off the wall at {deg:.1f}°")
        elif force is None or clamp.holds_force(abs(force)):
            continue  # at the wall, or no spring to say otherwise
        elif held and abs(force) < released and min(abs(angle - a) for a in held) <= still:
            # at the very angle its partner presses the wall at, pressing nothing: the
            # joint stopped at the wall (its motor stalled, its power gone). One over an
            # opening swings on past it under its clamp torque (until 2026-11-30 it was
            # said to be 'over an opening' in a riser that had none)
            stopped.append(
                f"{name} presses {abs(force):.1f} N at {deg:.1f}°, stopped at the wall"
                " (a stalled joint motor?)"
            )
        elif held and angle >= min(held) - tol:
            off.append(f"{name} off the wall at {deg:.1f}° with its spring at {abs(force):.1f} N")
        else:
            need = clamp.min_torque / clamp.lever_arm
            other.append(
                f"{name} presses {abs(force):.1f} N at {deg:.1f}° (a clamp holds from {need:.2f} N)"
            )
    said = [f"{', '.join(off)}, over an opening"] if off else []
    said += stopped + other
    if said:
        return f"{half} {', '.join(said)}"
    return f"{half} {kind.value}"


def objection(checks: list[Check], ctx: CheckContext, intent: Intent) -> Problem | None:
    """The first problem ``checks`` find with a protective action, a check that raises
    (one of yours, ``sup.add_check``) logged and passed over: the protective clamp of a
    robot in a steep pipe is not held back by a check that cannot judge it (until
    2026-11-30 its exception went out of every ``tick()`` and no clamp was sent)."""
    for check in checks:
        try:
            problem = check(ctx, intent)
        except Exception as exc:  # a user's check must not drop the robot
            name = getattr(check, "__qualname__", None) or repr(check)[:80]
            log.error(
                "check %s raised %s on a protective action: %s", name, type(exc).__name__, exc
            )
            continue
        if problem is not None:
            return problem
    return None


def half_channels(robot: RobotDescription) -> dict[Half, tuple[str, ...]]:
    """The angle and spring channels of each half's bend modules."""
    out: dict[Half, tuple[str, ...]] = {}
    for half in Half:
        names: list[str] = []
        for module in robot.bend_modules(half):
            for kind in (SensorKind.ANGLE, SensorKind.SPRING):
                try:
                    names.append(robot.sensor_of(module.name, kind).name)
                except KeyError:
                    continue
        out[half] = tuple(names)
    return out


class HoldMixin:
    """The protective hold (mixed into ``Supervisor``)."""

    # set by the supervisor
    _port: RobotPort
    robot: RobotDescription
    clock: Clock
    _mode: Mode
    _targets: dict[Half, HalfTarget]
    _last_setpoint: dict[str, tuple[ControlMode, float, float]]
    _holding: set[Half]
    _hold_refused: set[Half]
    _hold_clearing: bool
    _ever_held: bool
    _run_ended: bool
    _hold_sent_s: float
    _was_steep: bool
    _hold_torque: float
    _hold_seen: RobotState | None = None
    """The newest snapshot the hold read on the last tick (see :meth:`_hold_each_state`)."""
    _hold_away: frozenset[Half] = frozenset()
    """Halves whose protective clamp the link refused, their board away (rebooting):
    the end of a run waits for them as for a clamp on its way (the bridge hands a board
    that answers again the setpoints it keeps, the clamp among them)."""
    _checks: list[Check]
    _expander: Expander
    _half_channels: dict[Half, tuple[str, ...]]

    if TYPE_CHECKING:  # defined by the supervisor and its other sides

        def safe_state(self, reason: str, *, error: BaseException | None = None) -> None: ...

        def _record(self, verdict: Verdict) -> Verdict: ...

        def tick(self) -> None: ...

        def _send_stop(self) -> tuple[MotorCommand, ...]: ...

    @property
    def holding(self) -> bool:
        """True while a protective clamp is on its way and no half holds yet."""
        return bool(self._holding or self._hold_away) or self._hold_clearing

    def end_safe(self, reason: str) -> None:
        """The safe state at the end of a run that did not succeed: :meth:`safe_state`
        (the first cause kept), then :meth:`settle_hold`."""
        self.safe_state(reason)
        self._hold_at_end()
        self.settle_hold()

    def settle_hold(self, step_s: float = 0.05) -> bool:
        """At the end of a run: while a protective clamp is landing, go on ticking the
        supervisor (the link polled, the hold checked again) until a half holds, for at
        most :data:`HOLD_SETTLE_S` of clock time, so a run does not hand back a robot
        still sliding. Returns at once when no clamp is pending.

        Returns:
            True when no protective clamp is pending any more.
        """
        deadline = self.clock.now() + HOLD_SETTLE_S
        while self.holding and self.clock.now() < deadline:
            self.clock.sleep(step_s)
            self.tick()
        return not self.holding

    def come_to_rest(self) -> bool:
        """At the end of a run, whatever its outcome: is the robot at rest yet?

        The runner asks before each of its settling ticks (the link polled, the checks
        and the protective hold as on every tick, odometry and the trace too, the tree
        no more), so that a run hands back a robot at rest and counts the distance its
        wheels ramp down over. Drives still set to turn are stopped first (a tree may
        succeed with a speed set).

        Returns:
            True when every drive with a fresh speed reads still (at most
            :data:`STILL_MPS`) and no protective clamp is landing; also True when no
            wheel can be read (the link lost, every speed stale) and no clamp is
            landing: there is nothing to wait for that could be seen.
        """
        self._hold_at_end()
        if any(
            (s := self._last_setpoint.get(m.name)) is not None and s[1] != 0.0
            for m in self.robot.drive_motors()
        ):
            self._send_stop()
            log.info("end of run: the drives were still set to turn; stopped")
        return not self.holding and self._wheels_still() is not False

    def _hold_at_end(self) -> None:
        """The end of a run, once: the protective hold for a robot no half has held yet.

        A robot set down free in a steep pipe is left to its tree's first clamp while
        the tree runs. When the run ends before that clamp held (its board reset, its
        joint stalled, the tree failed first), no clamp is on its way any more: the hold
        clamps then, as for a robot that lost its hold, and the end waits for it.
        """
        if self._ever_held or self._run_ended:
            return  # only a robot never held: the others were watched every tick
        self._run_ended = True
        state = self._port.state()
        if state is not None and self._port.health().connected:
            self._hold_in_steep_pipe(state, self.clock.now())

    def _wheels_still(self) -> bool | None:
        """Every drive with a fresh speed reads still; None when none reads fresh.

        A wheel whose speed went stale (a sensor dropped out) is left out, as odometry
        leaves it out: it keeps its last value."""
        state = self._port.state()
        if state is None or not self._port.health().connected:
            return None
        oldest = self.clock.now() - wheel_fresh_window_s(self.robot)
        readings = state.readings
        seen = False
        for motor, speed in state.drive_velocity_mps.items():
            reading = readings.get(f"{motor}.velocity")
            if reading is not None and reading.stamp_s < oldest:
                continue
            if abs(speed) > STILL_MPS:
                return False
            seen = True
        return True if seen else None

    def _halves_holding(
        self, state: RobotState, now_s: float
    ) -> tuple[dict[Half, ClampState], list[Half]]:
        """Each half's clamp state, and the halves clamped by fresh readings."""
        halves = half_states(self.robot, state, self._targets)
        holding = [
            h
            for h, s in halves.items()
            if s is ClampState.CLAMPED
            and not stale_channels(self.robot, state, self._half_channels[h], now_s)
        ]
        return halves, holding

    def _hold_each_state(self, state: RobotState, now_s: float) -> None:
        """The protective hold on ``state`` (the newest), and on the STATEs since the last
        tick when the newest shows a half holding: a 20 Hz tick reads one STATE in five,
        and a half riding a tee's opening may hold nothing in one of the four it does not
        read and hold again in the fifth (the robot slid meanwhile). The first of them in
        a steep pipe in which no half holds (by its readings' freshness at its arrival)
        is acted on as the newest would be (the safe state, the protective clamp), once;
        the newest is judged after it. Only where the hold may act and is not acting: once
        a half has held, not latched, no protective clamp on its way, steep now or on the
        last tick; elsewhere (most ticks) it costs a few lookups. A port without
        ``states_between`` (an optional method; a test's fake) is judged on its newest
        STATE only, as before."""
        seen, self._hold_seen = self._hold_seen, state
        if (
            seen is not None
            and seen is not state
            and (self._ever_held or self._run_ended)
            and self._mode is not Mode.ESTOP
            and not self.holding
        ):
            limit = self.robot.motion.max_unclamped_slope
            pitch = state.imu_rad.get("pitch")
            steep = pitch is not None and abs(pitch) > limit
            between = getattr(self._port, "states_between", None)
            if (
                (steep or self._was_steep)
                and between is not None
                and self._halves_holding(state, now_s)[1]  # else the newest says it
            ):
                for earlier in between(seen, state):
                    tilt = earlier.imu_rad.get("pitch")
                    if (
                        tilt is not None
                        and abs(tilt) > limit
                        and not self._halves_holding(earlier, earlier.stamp_s)[1]
                    ):
                        self._hold_in_steep_pipe(earlier, earlier.stamp_s)
                        break
        self._hold_in_steep_pipe(state, now_s)

    def _hold_in_steep_pipe(self, state: RobotState, now_s: float) -> None:
        """Clamp what may clamp when nothing holds the robot in a steep pipe any more."""
        # Runs every tick: on the level (most ticks) it costs one lookup.
        pitch = state.imu_rad.get("pitch")
        was_steep = self._was_steep
        self._was_steep = False
        if pitch is None or abs(pitch) <= self.robot.motion.max_unclamped_slope:
            if not self._ever_held and self._halves_holding(state, now_s)[1]:
                # held on the level: a robot that reaches a steep pipe held by nothing
                # later lost its hold there (its first steep tick may be after the fault)
                self._ever_held = True
            if self.holding:
                if (
                    now_s - self._hold_sent_s < HOLD_SETTLE_S
                    and not self._halves_holding(state, now_s)[1]
                ):
                    # The robot slid down to where the pipe is no longer steep (the foot
                    # of a bend) while the protective clamp was landing: it stopped
                    # there, held by nothing yet. The clamp is still on its way; the end
                    # of a run waits for it (settle_hold, come_to_rest) as in the steep
                    # pipe, so that it does not hand back a robot on the very step its
                    # slide ended.
                    return
                self._holding.clear()
                self._hold_away = frozenset()
                self._hold_clearing = False
                return
            if pitch is None or not was_steep or self._halves_holding(state, now_s)[1]:
                return
            # Steep on the last tick, and now nothing holds where the pitch reads under
            # the limit: the half that held lost its hold (its board away) and the robot
            # slid down to the foot of the bend between two ticks. It may still be
            # sliding there: clamp as in the steep pipe, so that the end of a run waits
            # for the clamp rather than handing back a robot held by nothing.
        else:
            self._was_steep = True
        halves, holding = self._halves_holding(state, now_s)
        if holding:
            self._holding.clear()
            self._hold_away = frozenset()
            self._hold_clearing = False
            self._hold_refused.clear()  # a later episode logs its refusals again
            self._ever_held = True
            return
        if not (self._ever_held or self._run_ended) or self._mode is Mode.ESTOP:
            # never held yet (a robot set down free in a steep pipe: clamping is its
            # tree's first step, and a clamp on its way is no fault) while a run goes
            # on, or latched
            return
        todo = [h for h in Half if h not in self._holding]
        if not todo:
            return  # clamped already this episode: the clamp is on its way
        cause = (
            f"{Reason.STEEP_PIPE_UNCLAMPED}: no half holds the robot in a steep pipe"
            f" (pitch {math.degrees(pitch):.0f}°): the supervisor clamps"
        )
        # why, joint by joint: the run's why names the joint over an opening, the half
        # released (before: only that no half held)
        why = "; ".join(
            f"{h} readings stale"
            if k is ClampState.CLAMPED
            else why_half_holds_nothing(self.robot, state, h, k)
            for h, k in halves.items()
        )
        # the drives stop first; a first cause before stays first
        self.safe_state(f"{cause}; {why}")
        # the live setpoints: the front module's tilt clear, sent on a tick before the
        # clamp, is where the module is going
        ctx = CheckContext(
            self.robot, state, now_s, halves, dict(self._targets), self._last_setpoint
        )
        for half in todo:
            if (
                half is Half.FRONT
                and self._hold_clearing
                and not self._move_front_clear(ctx, cause)
            ):
                continue  # the clamp waits until the whole tilt is sent, as a tree's does
            command = Clamp(half, self._hold_torque)
            intent = self._expander.expand(command, state)
            problem = (
                intent if isinstance(intent, Problem) else objection(self._checks, ctx, intent)
            )
            if problem is not None or isinstance(intent, Problem):
                # the invariants still hold: the front half does not clamp with the front
                # module in the way (it would press the module into the wall): the module
                # is tilted clear first, and the clamp tried again on the next ticks
                if (
                    problem is not None
                    and problem.reason is Reason.FRONT_NOT_CLEAR
                    and not self._hold_clearing
                ):
                    self._move_front_clear(ctx, cause)
                if half not in self._hold_refused:
                    self._hold_refused.add(half)
                    log.error("protective clamp of the %s half refused: %s", half, problem)
                continue
            cmds = intent.motor_commands
            try:
                self._port.send(cmds)
            except LinkError as exc:  # its board is away: again next tick
                # a board the bridge reports rebooting gets its clamp back from the
                # bridge when it answers: the end of a run waits for that (not for a
                # link that is lost)
                away: tuple[int, ...] = getattr(self._port, "boards_not_answering", tuple)()
                if half in self._hold_away:
                    continue  # said once, not every tick
                if {self.robot.board_of(c.motor).id for c in cmds} & set(away):
                    self._hold_away |= {half}
                    self._hold_sent_s = now_s
                log.error("could not clamp the %s half: %s", half, exc)
                continue
            self._holding.add(half)
            if half is Half.FRONT:
                self._hold_clearing = False
            self._hold_sent_s = now_s
            self._targets[half] = HalfTarget.CLAMP
            for c in cmds:
                self._last_setpoint[c.motor] = (c.mode, c.value, now_s)
            log.warning("protective clamp of the %s half: %s", half, cause)
            self._record(
                Verdict(
                    Outcome.PASS,
                    command,
                    Source.SUPERVISOR,
                    sent=cmds,
                    reason=Reason.STEEP_PIPE_UNCLAMPED,
                    detail=f"protective clamp: {cause} the {half} half",
                )
            )

    def _move_front_clear(self, ctx: CheckContext, cause: str) -> bool:
        """Tilt the front module clear so that the protective clamp of the front half may
        land: a robot set down free has its module in front of it until its tree's first
        steps move it. Checked as the clamp is (the module leaves no clamped half's way),
        rate limited as a tree's tilt, sent every tick until the whole tilt is sent.

        Returns:
            True once the tilt's target itself has been sent (not a step toward it).
        """
        state, now_s = ctx.state, ctx.now_s
        tilt = state.front_tilt_rad
        command = MoveFrontClear(-1 if tilt is not None and tilt < 0 else 1)
        intent = self._expander.expand(command, state)
        if isinstance(intent, Problem):
            return False
        # check_steep_pipe asks for a clamp first, and this tilt is what lets the clamp
        # land (it moves no wheel): the other checks hold as for any tilt
        checks = [c for c in self._checks if c is not check_steep_pipe]
        if objection(checks, ctx, intent) is not None:
            return False
        cmds: list[MotorCommand] = []
        for mc in intent.motor_commands:
            limited = limit(self.robot, self._last_setpoint, mc, state, now_s)
            if isinstance(limited, Problem):
                return False
            cmds.append(MotorCommand(mc.motor, mc.mode, limited[0]))
        try:
            self._port.send(cmds)
        except LinkError as exc:  # its board is away: again next tick
            log.error("could not tilt the front module clear: %s", exc)
            return False
        for c in cmds:
            self._last_setpoint[c.motor] = (c.mode, c.value, now_s)
        if not self._hold_clearing:
            self._hold_clearing = True
            self._hold_sent_s = now_s
            log.warning("protective hold: the front module tilts clear: %s", cause)
            self._record(
                Verdict(
                    Outcome.PASS,
                    command,
                    Source.SUPERVISOR,
                    sent=tuple(cmds),
                    reason=Reason.STEEP_PIPE_UNCLAMPED,
                    detail=f"protective hold: {cause}; the front module tilts clear first",
                )
            )
        return all(c.value == mc.value for c, mc in zip(cmds, intent.motor_commands, strict=True))
