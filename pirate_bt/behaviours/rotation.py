"""The rotation primitives: ``rotate`` the halves, and ``align_roll`` a half to a plane.

Split out of :mod:`pirate_bt.behaviours.primitives` (which re-exports both, and
whose docstring describes what every primitive does and when it is done).
"""

from __future__ import annotations

import math
from typing import Any

from py_trees.common import Status
from pydantic import Field

from pirate_bt.behaviours.base import (
    NodeParams,
)
from pirate_bt.behaviours.primitive import (
    _SETTLE_TICKS,
    Primitive,
    _commands,
    _deg,
    _exact_deg,
    _wrap,
    _write_blackboard,
)
from pirate_bt.robot.description import Half, RobotDescription
from pirate_bt.robot.state import RobotState
from pirate_bt.units import Angle, Duration

__all__ = ["AlignRoll", "AlignRollParams", "Rotate", "RotateParams"]


class RotateParams(NodeParams):
    angle: Angle = Field(description="angle between the halves (front minus rear)")
    tolerance: Angle = Field(0.05, gt=0, description="how close counts as reached")
    timeout: Duration = Field(10.0, gt=0, description="fail if not reached within this time")


def _rotate_range_problem(robot: RobotDescription, angle: float, field: str) -> list[str]:
    lim = robot.rotate_motor().limits.angle
    if lim is not None and not lim.min <= angle <= lim.max:
        return [
            f"{field}: {_exact_deg(angle)} is beyond the rotation range [{_deg(lim.min)},"
            f" {_deg(lim.max)}]"
        ]
    return []


class _Rotation(Primitive):
    """Drive the rotational joint to ``self._target`` and wait for the sensor."""

    verb = "rotate"
    _target: float
    _tolerance: float
    _done_sending: bool
    _held: int

    def _rotate_to(self, state: RobotState) -> Status:
        if not self._done_sending:
            ok, done = self.send(_commands().Rotate(self._target))
            if not ok:
                return self.refused()
            self._sent = True
            self._done_sending = done
        rotation = state.rotation_rad
        reached = (
            self._done_sending
            and rotation is not None
            and abs(rotation - self._target) <= self._tolerance
        )
        shown = _deg(rotation) if rotation is not None else "unknown"
        self.feedback_message = f"rotating to {_deg(self._target)}: at {shown}"
        self._held = self._held + 1 if reached else 0
        return Status.SUCCESS if self._held >= _SETTLE_TICKS else Status.RUNNING

    def initialise(self) -> None:
        self._sent = False
        super().initialise()

    def stop_motion(self) -> None:
        """Halted or failed on the way: hold the rotation where it reads, rather than let
        it finish the step already sent (the safe state brakes it itself). A hold the
        checks would refuse (no half clamped any more) is not asked for."""
        sup = self.supervisor
        if not getattr(self, "_sent", False) or sup.safe_state_reason is not None:
            return
        state = sup.state()
        if state is None or state.rotation_rad is None:
            return
        hold = _commands().Rotate(state.rotation_rad)
        if sup.check(hold).ok:
            sup.command(hold)


class Rotate(_Rotation):
    """Set the angle between the two halves; exactly one half must be clamped."""

    Params = RotateParams

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        return _rotate_range_problem(robot, params.angle, "angle")

    def start(self) -> None:
        p: RotateParams = self.params  # type: ignore[assignment]
        self._target = p.angle
        self._tolerance = p.tolerance
        self._done_sending = False
        self._held = 0

    def step(self, state: RobotState) -> Status:
        return self._rotate_to(state)


class AlignRollParams(NodeParams):
    roll: Angle = Field(
        description="roll of the turn's plane: 0 up, 90 deg right, 180 deg down, -90 deg left"
    )
    half: Half = Field(
        Half.FRONT,
        description=(
            "the free half to align: front (the rear half holds; the forward turn) or rear"
            " (the front half holds; a turn passed backwards, rear half first)"
        ),
    )
    sign_key: str = Field(
        "steer_sign", description="blackboard key for the steering sign (+1 or -1) chosen"
    )
    tolerance: Angle = Field(0.05, gt=0, description="how close counts as reached")
    timeout: Duration = Field(10.0, gt=0, description="fail if not aligned within this time")


class AlignRoll(_Rotation):
    """Rotate the free half so that its bending plane lies in a turn's plane.

    ``half: front`` (the default, a turn passed forwards): the rear half must be
    clamped; the front half turns. Its roll is the rear half's roll (the IMU's: the
    IMU sits in the rotational module, rigid with the rear half) plus the rotation.
    ``half: rear`` (a turn passed backwards, rear half first): the front half must be
    clamped; rotating turns the rear half by the opposite amount, so the rotation
    that puts the rear half on roll ``t`` is (IMU roll + rotation) - ``t``, the front
    half's roll less ``t``.

    The bending plane is aligned with a turn of roll ``r`` when the half's roll is
    ``r`` (steer with positive joint angles) or ``r + 180°`` (steer with negative
    angles); of the two, the one whose rotation is nearer 0 and within the joint's
    range is chosen, and its sign is written to ``sign_key`` for ``bend``. The inside
    of a turn lies toward roll ``r`` whichever way the robot passes it, so the rule is
    the same for both halves and both directions.
    """

    Params = AlignRollParams

    @classmethod
    def blackboard_writes(cls, params: Any) -> tuple[str, ...]:
        return (params.sign_key,)

    def start(self) -> None:
        self._target = math.nan
        self._tolerance = self.params.tolerance  # type: ignore[attr-defined]
        self._done_sending = False
        self._held = 0

    def _choose(self, state: RobotState) -> str | None:
        p: AlignRollParams = self.params  # type: ignore[assignment]
        rear_roll = state.imu_rad.get("roll")
        if rear_roll is None:
            return "no IMU roll reading: cannot tell the rear half's roll"
        if p.half is Half.FRONT:

            def rotation_for(target: float) -> float:
                return _wrap(target - rear_roll)  # the front half turns by the rotation

        else:
            rotation = state.rotation_rad
            if rotation is None:
                return "no rotation reading: cannot tell the front half's roll"
            front_roll = rear_roll + rotation

            def rotation_for(target: float) -> float:
                return _wrap(front_roll - target)  # the rear half turns against it

        lim = self.robot.rotate_motor().limits.angle
        lo, hi = (lim.min, lim.max) if lim is not None else (-math.pi, math.pi)
        candidates = sorted(
            ((rotation_for(p.roll + offset), sign) for offset, sign in ((0, 1), (math.pi, -1))),
            key=lambda c: (round(abs(c[0]), 6), -c[1]),
        )
        for rotation, sign in candidates:
            if lo <= rotation <= hi:
                self._target = rotation
                _write_blackboard(p.sign_key, sign)
                return None
        return f"no rotation within [{_deg(lo)}, {_deg(hi)}] aligns with roll {_deg(p.roll)}"

    def step(self, state: RobotState) -> Status:
        if math.isnan(self._target):
            problem = self._choose(state)
            if problem is not None:
                return self.fail(problem)
        return self._rotate_to(state)
