"""A scripted drive in plain Python: the reference manoeuvres, without a tree.

:class:`ScriptedDrive` moves the robot through a path with the conventions of
``docs/simulator.md`` - one half always clamped, the other steered into each
turn after rotating its bending plane onto the turn's plane, inchworming over
tee openings - and nothing else. It exists for tests, the benchmark and as a
readable specification for the motion primitives; behaviour trees do the same
with primitives, guards and a safety layer in between.

It cheats in one way a tree cannot: it reads the simulator's ground truth to
know where the robot is, instead of localising itself.

Commands go through a :class:`CommandSink`: :class:`ModelSink` drives the model
directly (fast, no wire); :class:`LinkSink` sends through a host
:class:`~pirate_bt.link.RobotLink` over the real protocol.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Protocol

from pirate_bt.clock import SimClock
from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, kind_of, shown
from pirate_bt.pipes import Piece, PieceKind
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, Half, MotorFunction, RobotDescription
from pirate_bt.robot.port import RobotPort
from pirate_bt.sim.model import SimTruth
from pirate_bt.sim.simulator import Simulator

__all__ = ["CommandSink", "LinkSink", "ModelSink", "ScriptedDrive", "rotation_for_turn"]


class CommandSink(Protocol):
    """Where a script's commands go, and how it waits."""

    def send(self, commands: Sequence[MotorCommand]) -> None: ...

    def wait(self, seconds: float) -> None: ...


class ModelSink:
    """Commands straight into the simulator's model; waiting advances the shared clock."""

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim

    def send(self, commands: Sequence[MotorCommand]) -> None:
        for command in commands:
            self.sim.model.command(command)

    def wait(self, seconds: float) -> None:
        self.sim.clock.advance(seconds)


class LinkSink:
    """Commands through a host link; waiting advances the clock in steps and polls the link.

    Args:
        port: A connected link (e.g. from :func:`pirate_bt.link.open_link` on ``sim.url``).
        clock: The simulated clock shared with the simulator.
        step_s: Clock step between polls (the state period is a good choice).
    """

    def __init__(self, port: RobotPort, clock: SimClock, step_s: float = 0.01) -> None:
        self.port = port
        self.clock = clock
        self.step_s = step_s

    def send(self, commands: Sequence[MotorCommand]) -> None:
        self.port.send(commands)
        self.port.poll()

    def wait(self, seconds: float) -> None:
        end = self.clock.now() + seconds
        while self.clock.now() < end - 1e-9:
            self.clock.advance(min(self.step_s, end - self.clock.now()))
            self.port.poll()


def _amount(name: str, value: object, unit: str, most: float | None = None) -> float:
    """``value`` as a finite number above 0 (and at most ``most``), else one line naming
    the argument: a speed of 0 was a *ZeroDivisionError*, a negative one *a clock cannot
    go back*, ``nan`` a drive that never moved while the script went on as if it had."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ArgumentTypeError(f"{name}: give a number of {unit}, not {kind_of(value)}")
    try:
        good = math.isfinite(value) and value > 0 and (most is None or value <= most)
    except OverflowError:  # a whole number too large for a float
        good = False
    if not good:
        bound = f" and at most {most:g}" if most is not None else ""
        raise ArgumentValueError(f"{name}: {shown(value)} is not a number of {unit} above 0{bound}")
    return float(value)


def _finite(name: str, value: object, unit: str) -> float:
    """``value`` as a finite number, else one line naming it (``drive_to(nan)`` advanced
    the shared clock by ``nan`` seconds: the clock read ``nan`` from then on)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ArgumentTypeError(f"{name}: give a number of {unit}, not {kind_of(value)}")
    try:
        good = math.isfinite(value)
    except OverflowError:  # a whole number too large for a float
        good = False
    if not good:
        raise ArgumentValueError(f"{name}: {shown(value)} is not a finite number of {unit}")
    return float(value)


def rotation_for_turn(turn_roll_rad: float, rear_roll_rad: float) -> tuple[float, int]:
    """The rotate-joint angle and steer sign that align the front half with a turn.

    The front half's roll is ``rear_roll + rotation``. Its bending plane is
    aligned when that roll equals the turn's roll (steer with positive joint
    angles) or the turn's roll + 180° (steer with negative angles); the smaller
    rotation wins.

    Args:
        turn_roll_rad: Roll of the turn (0 up, +pi/2 right, pi down, -pi/2 left).
        rear_roll_rad: Current roll of the rear half.

    Returns:
        ``(rotation_rad, steer_sign)``.
    """
    direct = math.remainder(turn_roll_rad - rear_roll_rad, 2 * math.pi)
    flipped = math.remainder(direct - math.pi, 2 * math.pi)
    if abs(direct) <= abs(flipped) + 1e-9:
        return direct, 1
    return flipped, -1


class ScriptedDrive:
    """Drives the simulated robot along its path with the reference manoeuvres.

    Args:
        sim: The simulator (read for ground truth).
        sink: Where commands go.
        clamp_torque_nm: Joint torque of a clamp.
        steer_rad: Joint angle (magnitude) when steering into a turn, up to pi.
        speed_mps: Driving speed (default the robot's ``motion.nominal_speed``), at most
            its drive motors' velocity limit.

    Raises:
        InputError: an argument of the wrong type (``ArgumentTypeError``), or a torque,
            angle or speed that is no finite number above 0, an angle above pi, a speed
            above the drives' limit (``ArgumentValueError``).
    """

    def __init__(
        self,
        sim: Simulator,
        sink: CommandSink,
        *,
        clamp_torque_nm: float = 0.7,
        steer_rad: float = math.radians(35),
        speed_mps: float | None = None,
    ) -> None:
        if not isinstance(sim, Simulator):
            raise ArgumentTypeError(f"sim: give a Simulator, not {kind_of(sim)}")
        if not all(callable(getattr(sink, verb, None)) for verb in ("send", "wait")):
            raise ArgumentTypeError(
                f"sink: give a CommandSink (ModelSink, LinkSink), not {kind_of(sink)}"
            )
        robot: RobotDescription = sim.robot
        fastest = min(
            (m.limits.velocity.max for m in robot.drive_motors() if m.limits.velocity),
            default=None,
        )
        self.sim = sim
        self.sink = sink
        self.robot = robot
        self.clamp_torque_nm = _amount("clamp_torque_nm", clamp_torque_nm, "N*m")
        self.steer_rad = _amount("steer_rad", steer_rad, "radians", math.pi)
        self.speed_mps = (
            _amount("speed_mps", speed_mps, "m/s", fastest)
            if speed_mps is not None
            else robot.motion.nominal_speed
        )
        self._joints = {
            half: [robot.joint_motor(m.name).name for m in robot.bend_modules(half)]
            for half in Half
        }
        self._drives = [m.name for m in robot.drive_motors()]
        self._rotate = robot.rotate_motor().name
        tilt = [
            m.name
            for board, m in robot.motors()
            if m.function is MotorFunction.TILT and robot.module(board.module).half is Half.FRONT
        ]
        self._tilt = tilt[0] if tilt else None
        self._rate = min(robot.motor(n).limits.angular_velocity.max for n in self._all_joints())  # type: ignore[union-attr]
        self.log: list[str] = []

    def _all_joints(self) -> list[str]:
        return [*self._joints[Half.FRONT], *self._joints[Half.REAR], self._rotate]

    @property
    def truth(self) -> SimTruth:
        return self.sim.truth()

    def _joint_time(self, angle_rad: float) -> float:
        return abs(angle_rad) / self._rate + 0.3

    # -- primitives -----------------------------------------------------------------

    def clamp(self, half: Half) -> None:
        """Press a half's wheels on the wall (front module tilted clear first)."""
        if half is Half.FRONT and self._tilt is not None:
            clear = self.robot.clamp.front_clear_angle + math.radians(10)
            self.sink.send([MotorCommand(self._tilt, ControlMode.POSITION, clear)])
            self.sink.wait(self._joint_time(clear))
        self.sink.send(
            [MotorCommand(n, ControlMode.TORQUE, self.clamp_torque_nm) for n in self._joints[half]]
        )
        self.sink.wait(self._joint_time(math.pi / 2))
        self.log.append(f"clamp {half}")

    def bend(self, half: Half, angle_rad: float) -> None:
        """Set a half's joints to ``angle_rad`` (0 releases a clamp, ±steer steers)."""
        angle_rad = _finite("angle_rad", angle_rad, "radians")
        self.sink.send(
            [MotorCommand(n, ControlMode.POSITION, angle_rad) for n in self._joints[half]]
        )
        self.sink.wait(self._joint_time(math.pi / 2))
        self.log.append(f"bend {half} {math.degrees(angle_rad):.0f} deg")

    def rotate(self, angle_rad: float) -> None:
        """Set the rotate joint (exactly one half must be clamped)."""
        angle_rad = _finite("angle_rad", angle_rad, "radians")
        delta = angle_rad - self.truth.rotation_rad
        self.sink.send([MotorCommand(self._rotate, ControlMode.POSITION, angle_rad)])
        rate = self.robot.motor(self._rotate).limits.angular_velocity
        speed = rate.max if rate is not None else 1.0
        self.sink.wait(abs(delta) / speed + 0.2)
        self.log.append(f"rotate {math.degrees(angle_rad):.0f} deg")

    def drive_to(self, front_m: float) -> None:
        """Drive until the front tip is at ``front_m`` (then stop).

        Raises:
            InputError: ``front_m`` is no finite number of metres.
        """
        front_m = _finite("front_m", front_m, "metres")
        distance = front_m - self.truth.front_m
        if abs(distance) < 1e-3:
            return
        v = math.copysign(self.speed_mps, distance)
        self.sink.send([MotorCommand(n, ControlMode.VELOCITY, v) for n in self._drives])
        accel = self.robot.motor(self._drives[0]).limits.acceleration
        ramp = self.speed_mps / accel.max if accel is not None else 0.0
        self.sink.wait(abs(distance) / self.speed_mps)
        self.sink.send([MotorCommand(n, ControlMode.VELOCITY, 0.0) for n in self._drives])
        self.sink.wait(ramp + 0.05)
        self.log.append(f"drive to {front_m:.2f} m")

    # -- manoeuvres -----------------------------------------------------------------

    def start(self) -> None:
        """Clamp the rear half, keep the front free (the travelling posture)."""
        self.clamp(Half.REAR)

    def through_turn(self, turn: Piece) -> None:
        """Pass a bend (or turn into a tee branch) with the rear clamped first."""
        rotation, sign = rotation_for_turn(turn.roll_rad, self.truth.halves[Half.REAR].roll_rad)
        self.drive_to(turn.start_m - 0.02)
        self.rotate(rotation)
        self.bend(Half.FRONT, sign * self.steer_rad)
        clamp_at = turn.end_m + 0.05
        if turn.kind is PieceKind.TEE_TURN:
            # the front half's last joint must be past the junction before it can hold
            clamp_at = max(clamp_at, turn.start_m + self.sim.model.half_extent_m(Half.FRONT)[1])
        self.drive_to(clamp_at)
        self.clamp(Half.FRONT)
        self.bend(Half.REAR, 0.0)
        self.rotate(0.0)  # brings the rear's plane onto the front's, i.e. onto the turn
        self.bend(Half.REAR, sign * self.steer_rad)
        self.drive_to(turn.end_m + self.sim.model.length_m + 0.05)
        self.clamp(Half.REAR)
        self.bend(Half.FRONT, 0.0)

    def over_tee(self, tee: Piece) -> None:
        """Go straight through a tee: inchworm so that one half always holds."""
        assert tee.opening_m is not None
        self.drive_to(tee.opening_m + 0.25)
        self.clamp(Half.FRONT)
        self.bend(Half.REAR, 0.0)
        self.drive_to(tee.opening_m + 0.5)
        self.clamp(Half.REAR)
        self.bend(Half.FRONT, 0.0)

    def over_step(self, at_m: float) -> None:
        """Cross an abrupt widening at ``at_m`` as a tee's opening is crossed.

        A half whose joint passes a step out to a wider pipe is off the wall until its
        joints have swung out to it, so it must not be the half that holds: the free
        front crosses with the rear holding, then the front holds while the rear
        crosses. Until the twenty-second session the script crossed a step with the
        rear half alone holding, and up a riser with a step from 63 to 80 mm the robot
        slid 384 times, 0.77 m in all, and stopped 1.1 m short of where it said.
        """
        at_m = _finite("at_m", at_m, "metres")
        self.drive_to(at_m + 0.25)
        self.clamp(Half.FRONT)
        self.bend(Half.REAR, 0.0)
        self.drive_to(at_m + 0.5)
        self.clamp(Half.REAR)
        self.bend(Half.FRONT, 0.0)
        self.log.append(f"over the step at {at_m:.2f} m")

    def run_path(
        self, stop_before_end_m: float = 0.1, progress: Callable[[str], None] | None = None
    ) -> None:
        """Drive the current path to its end, passing every turn and tee straight.

        Raises:
            InputError: ``stop_before_end_m`` is no finite number of metres of at least 0
                (refused before anything moves: ``"0.1 m"`` drove the whole path, then
                raised *TypeError: unsupported operand*; ``nan`` was refused as
                ``front_m``, an argument nobody gave, after the drive), or ``progress``
                is no function (it raised *'str' object is not callable* at the first
                turn, the robot in it).
        """
        stop_m = _finite("stop_before_end_m", stop_before_end_m, "metres")
        if stop_m < 0:
            raise ArgumentValueError(
                f"stop_before_end_m: {shown(stop_before_end_m)} is not a number of metres"
                " of at least 0 (the robot cannot stop beyond the pipe's end)"
            )
        if progress is not None and not callable(progress):
            raise ArgumentTypeError(
                f"progress: give a function of a segment's name, or None, not {kind_of(progress)}"
            )
        self.start()
        path = self.sim.model.path
        before = 0.0  # the diameter where the last piece ended
        for piece in path.pieces:
            wider = before > 0.0 and piece.diameter_start_m > before + 1e-9
            before = piece.diameter_end_m
            if piece.end_m <= self.truth.front_m:
                continue
            if wider and piece.start_m > self.truth.front_m:
                self.over_step(piece.start_m)  # a step out to a wider pipe: no half holds
            if piece.is_turn:
                self.through_turn(piece)
            elif piece.kind is PieceKind.TEE:
                self.over_tee(piece)
            elif not wider:
                continue
            if progress is not None:
                progress(piece.segment)
        self.drive_to(path.length_m - stop_m)
