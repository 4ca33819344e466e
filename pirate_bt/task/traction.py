"""Whether the clamps can pull the robot and its tether where a plan takes it.

The traction rule (DOMAIN.md, ``docs/simulator.md``): the robot moves only while the
friction coefficient times the clamped halves' normal force beats the load, the
tether's drag (``tether_drag_per_metre`` times the metres of tether in the pipe) and
the robot's weight on a climb. Otherwise the wheels turn in place, and the odometry
counts distance the robot does not travel. A leg drives on both halves; a bend or
T-joint PAB moves the robot on one, the other released and steered. Past the tether
length where the load beats one half's traction the bend PAB's search spun its 3 m
out in place, and the mission said the map was wrong (*map disagreement at 134.98 m
(believed): the pipe is not as drawn at bend 'b' (right): the PAB's search met no
turn ...*) though the bend was where drawn. The load is a figure of the map (its
tether drag per metre, its slopes) and the robot (its weight, friction, clamp lever
arm), so a plan that asks for more is refused before anything moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pirate_bt.pipes.network import Path as PipePath
from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.task.plan import PlannedPab

__all__ = ["SAMPLE_M", "Traction"]

SAMPLE_M = 0.05
"""How finely a PAB's span is read for its steepest climb (metres of the front tip)."""


@dataclass(frozen=True)
class Traction:
    """The figures of the traction rule for one robot, one map and the PABs' clamp.

    Attributes:
        half_n: One clamped half's traction at ``torque_nm`` (newtons).
        torque_nm: The clamp torque the PABs press with.
        weight_n: The robot's weight (``motion.weight``).
        drag_per_m: The map's tether drag per metre of tether in the pipe.
        length_m: The robot's length: tether in the pipe is the front tip's place
            less it (as the simulator counts it).
        imu_offset_m: Where the rotational module is behind the front tip (the slope
            that loads the robot is read there, as the simulator reads it).
    """

    half_n: float
    torque_nm: float
    weight_n: float
    drag_per_m: float
    length_m: float
    imu_offset_m: float

    @classmethod
    def of(cls, robot: RobotDescription, drag_per_m: float, torque_nm: float) -> Traction:
        """The figures for ``robot`` on a map of ``drag_per_m``, clamping at ``torque_nm``."""
        joints = len(robot.bend_modules(Half.REAR)) or len(robot.bend_modules(Half.FRONT))
        force_n = joints * torque_nm / robot.clamp.lever_arm
        offsets = robot.behind_front_tip_m()
        length = sum(m.length for m in robot.modules)
        return cls(
            half_n=robot.motion.friction_coefficient * force_n,
            torque_nm=torque_nm,
            weight_n=robot.motion.weight,
            drag_per_m=drag_per_m,
            length_m=length,
            imu_offset_m=offsets[robot.rotational_module().name],
        )

    def load_n(self, path: PipePath, front_m: float) -> tuple[float, float, float]:
        """``(load, tether drag, climb)`` in newtons driving forwards with the front tip
        at ``front_m``."""
        drag = self.drag_per_m * max(front_m - self.length_m, 0.0)
        slope = path.slope_at(min(max(front_m - self.imu_offset_m, 0.0), path.length_m))
        climb = self.weight_n * math.sin(slope)
        return drag + climb, drag, climb

    def problem(self, path: PipePath, pab: PlannedPab) -> str | None:
        """Why ``pab`` cannot move the robot (the load beats the traction of the halves
        it drives on somewhere in its span), or ``None``. Only forward PABs load the
        tether."""
        if pab.pab not in ("straight", "bend", "t-joint") or pab.end_m <= pab.start_m:
            return None
        halves = 2 if pab.pab == "straight" else 1
        traction = self.half_n * halves
        steps = max(1, math.ceil((pab.end_m - pab.start_m) / SAMPLE_M))
        for i in range(steps + 1):
            at = pab.start_m + (pab.end_m - pab.start_m) * i / steps
            load, drag, climb = self.load_n(path, at)
            if load < traction:
                continue
            tether = max(at - self.length_m, 0.0)
            parts = f"{drag:.1f} N of tether drag ({tether:.1f} m at {self.drag_per_m:g} N/m)"
            if climb > 0.05:
                parts += f" and {climb:.1f} N of its weight on the climb"
            who = "both halves" if halves == 2 else "one half (the other is steered)"
            return (
                f"at {at:.2f} m the load is {load:.1f} N, {parts}, and the {pab.pab} PAB"
                f" drives on {who}: {traction:.1f} N of traction at its"
                f" {self.torque_nm:g} N*m clamp; the wheels would turn in place"
            )
        return None
