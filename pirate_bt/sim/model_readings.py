"""Sensor readings of the simulated robot: the state channels, the IMU, the noise.

:class:`ReadingsMixin` is the sensor side of :class:`~pirate_bt.sim.model.PipeRobotModel`:
it maps every state channel of the robot description to what it reads (a joint's
angle, a spring's normal force, a wheel's measured speed or current, the IMU's
roll, pitch and yaw of the rear half, else 0) and adds the Gaussian noise.
"""

from __future__ import annotations

import math
import random

from pirate_bt.pipes import Path
from pirate_bt.robot.description import Half, RobotDescription, SensorKind
from pirate_bt.sim.model_types import _JOINT_FUNCTIONS, _NO_NOISE, SensorNoise, _Half, _Motor

__all__ = ["ReadingsMixin"]

_TWOPI = 2.0 * math.pi  # random.gauss's own constant


class _Zero:
    """Source of a channel that reads 0 (and the slot an IMU channel fills later)."""

    value = 0.0


_ZERO = _Zero()


class ReadingsMixin:
    """The sensor side of the robot model (mixed into ``PipeRobotModel``)."""

    # set by the model
    robot: RobotDescription
    path: Path
    s_m: float
    noise: SensorNoise
    _rng: random.Random
    _gauss_spare: float | None
    _motors: dict[str, _Motor]
    _halves: dict[Half, _Half]
    _rear: _Half
    _rot_offset: float
    _channels: list[tuple[str, str, str]]
    _channel_names: list[str]
    _sources: list[tuple[object, str]]
    _spring_index: list[int]
    _imu_index: list[tuple[int, str]]
    _sigmas: list[float]
    _imu_key: tuple[float, float] | None
    _imu_value: dict[str, float]

    def _channel_table(self) -> list[tuple[str, str, str]]:
        """(channel, source kind, source name) for every state channel."""
        robot = self.robot
        table: list[tuple[str, str, str]] = []
        spring_of: dict[str, str] = {}
        angle_of: dict[str, str] = {}
        for board in robot.boards:
            for sensor in board.sensors:
                if sensor.kind is SensorKind.SPRING:
                    spring_of[sensor.name] = board.module
                elif sensor.kind is SensorKind.ANGLE:
                    motor = next((m for m in board.motors if m.slot == sensor.slot), None)
                    if motor is not None and motor.function in _JOINT_FUNCTIONS:
                        angle_of[sensor.name] = motor.name
        imu = robot.imu()
        for spec in robot.state_channels():
            name = spec.name
            if name in angle_of:
                table.append((name, "angle", angle_of[name]))
            elif name in spring_of:
                module = spring_of[name]
                table.append((name, "spring", robot.joint_motor(module).name))
            elif imu is not None and name.startswith(f"{imu.name}."):
                table.append((name, "imu", name.split(".", 1)[1]))
            elif name.endswith(".velocity"):
                table.append((name, "velocity", name.rsplit(".", 1)[0]))
            elif name.endswith(".current"):
                table.append((name, "current", name.rsplit(".", 1)[0]))
            else:
                table.append((name, "zero", ""))
        return table

    def _imu(self) -> dict[str, float]:
        s = self.s_m - self._rot_offset
        tangent, up = self.path.frame_at(s)
        roll = self._halves[Half.REAR].roll_rad
        right = (
            tangent[1] * up[2] - tangent[2] * up[1],
            tangent[2] * up[0] - tangent[0] * up[2],
            tangent[0] * up[1] - tangent[1] * up[0],
        )
        b = tuple(math.cos(roll) * u + math.sin(roll) * r for u, r in zip(up, right, strict=True))
        pitch = math.asin(max(-1.0, min(1.0, tangent[2])))
        zt = tangent[2]
        zp = (-zt * tangent[0], -zt * tangent[1], 1.0 - zt * tangent[2])
        n = math.sqrt(zp[0] ** 2 + zp[1] ** 2 + zp[2] ** 2)
        if n < 1e-6:
            imu_roll = roll
        else:
            zp = (zp[0] / n, zp[1] / n, zp[2] / n)
            rg = (
                tangent[1] * zp[2] - tangent[2] * zp[1],
                tangent[2] * zp[0] - tangent[0] * zp[2],
                tangent[0] * zp[1] - tangent[1] * zp[0],
            )
            imu_roll = math.atan2(
                b[0] * rg[0] + b[1] * rg[1] + b[2] * rg[2],
                b[0] * zp[0] + b[1] * zp[1] + b[2] * zp[2],
            )
        yaw = math.atan2(tangent[1], tangent[0]) if abs(zt) < 1 - 1e-9 else 0.0
        return {"roll": imu_roll, "pitch": pitch, "yaw": yaw}

    def readings(self) -> dict[str, float]:
        """Every state channel's SI value (with noise), by channel name."""
        return dict(zip(self._channel_names, self.reading_values(), strict=True))

    def reading_values(self) -> list[float]:
        """Every state channel's SI value (with noise), in the state frame's channel order."""
        # Called once per state period: plain attribute reads in one comprehension (no
        # Python call per channel), then the few channels that need arithmetic.
        values = [getattr(obj, attr) for obj, attr in self._sources]
        lever = self.robot.clamp.lever_arm
        for i in self._spring_index:
            values[i] = values[i] / lever  # press torque -> normal force
        if self._imu_index:
            imu = self._imu_cached()
            for i, key in self._imu_index:
                values[i] = imu.get(key, 0.0)
        if self.noise != _NO_NOISE:
            sigmas = self._sigmas
            noisy = [i for i, sigma in enumerate(sigmas) if sigma > 0]
            for i, z in zip(noisy, self._normals(len(noisy)), strict=True):
                values[i] += z * sigmas[i]
        return values

    def _normals(self, n: int) -> list[float]:
        """``n`` standard normal draws: the very numbers ``n`` calls of the noise
        generator's ``gauss(0.0, 1.0)`` give, and its state after them, in one loop
        (about twice as fast as a call per channel, a quarter of a noisy frame's cost).

        The same Box-Muller pairs as :meth:`random.Random.gauss`, drawn from the same
        uniform numbers in the same order, the odd one kept for the next call as it
        keeps it (the generator serves the noise alone).
        """
        if n <= 0:
            return []
        uniform = self._rng.random
        out: list[float] = []
        if self._gauss_spare is not None:
            out.append(self._gauss_spare)
            self._gauss_spare = None
        log, sqrt, cos, sin = math.log, math.sqrt, math.cos, math.sin
        while len(out) < n:
            x2pi = uniform() * _TWOPI
            g2rad = sqrt(-2.0 * log(1.0 - uniform()))
            out.append(cos(x2pi) * g2rad)
            out.append(sin(x2pi) * g2rad)
        if len(out) > n:
            self._gauss_spare = out.pop()
        return out

    def _reading_sources(
        self,
    ) -> tuple[list[tuple[object, str]], list[int], list[tuple[int, str]]]:
        """(object, attribute) read for each channel; spring and IMU channel indices."""
        sources: list[tuple[object, str]] = []
        springs: list[int] = []
        imu: list[tuple[int, str]] = []
        attr = {"angle": "angle_rad", "velocity": "measured_mps", "current": "current_a"}
        for i, (_, kind, source) in enumerate(self._channels):
            if kind == "imu":
                imu.append((i, source))
                sources.append((_ZERO, "value"))
            elif kind == "zero":
                sources.append((_ZERO, "value"))
            elif kind == "spring":
                springs.append(i)
                sources.append((self._motors[source], "press_nm"))
            else:
                sources.append((self._motors[source], attr[kind]))
        return sources, springs, imu

    def _sigma(self, kind: str) -> float:
        noise = self.noise
        return {
            "angle": noise.angle_rad,
            "imu": noise.angle_rad,
            "spring": noise.force_n,
            "velocity": noise.velocity_mps,
            "current": noise.current_a,
        }.get(kind, 0.0)

    def _imu_cached(self) -> dict[str, float]:
        s = self.s_m - self._rot_offset
        piece = self.path.piece_at(s)
        key = (id(piece) if not piece.is_turn else s, self._rear.roll_rad)
        if key != self._imu_key:
            self._imu_key = key
            self._imu_value = self._imu()
        return self._imu_value
