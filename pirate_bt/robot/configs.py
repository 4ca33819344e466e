"""Robot-wide parameters of a robot description: clamp, motion, safety, bridge.

The blocks of ``hardware/*.yaml`` that are not parts: how a half clamps (the
one threshold of "clamped"), the physics the simulator and the protective
layer share, the protective layer's own parameters, and the bridge's line.
"""

from __future__ import annotations

import itertools

from pydantic import (
    Field,
    model_validator,
)

from pirate_bt.robot.parts import _Model
from pirate_bt.units import (
    Angle,
    Current,
    Dimensionless,
    Duration,
    Flag,
    Force,
    Length,
    Torque,
    Velocity,
    WholeNumber,
)

__all__ = ["Band", "BridgeConfig", "ClampConfig", "ContactPoint", "MotionConfig", "SafetyConfig"]


class ContactPoint(_Model):
    """Joint angle at which the wheels touch the wall, for one pipe diameter."""

    diameter: Length = Field(gt=0)
    """internal pipe diameter"""
    angle: Angle = Field(gt=0)
    """joint angle at wall contact"""


class Band(_Model):
    """An angle band [min, max]."""

    min: Angle
    """lower end"""
    max: Angle
    """upper end"""

    @model_validator(mode="after")
    def _order(self) -> Band:
        if self.min >= self.max:
            raise ValueError("band: min must be below max")
        return self

    def contains(self, angle_rad: float) -> bool:
        return self.min <= angle_rad <= self.max


_HOLD_SLACK = 1e-9


class ClampConfig(_Model):
    """How a half clamps: joint torque presses the wheels against the wall."""

    nominal_band: Band = Field(description="joint angles at which a clamp counts as nominal")
    min_torque: Torque = Field(
        gt=0,
        description="least joint torque that holds a clamp: the one threshold of 'clamped',"
        " read by the simulator (torque) and the protective layer (spring force)",
    )
    lever_arm: Length = Field(gt=0, description="normal force = joint torque / lever arm")
    contact_angles: list[ContactPoint] = Field(
        min_length=2, description="wall-contact joint angle against pipe diameter (interpolated)"
    )
    unclamped_below: Angle = Field(description="joint angle below which a half is unclamped")
    front_clear_angle: Angle = Field(
        description="front tilt angle that moves the front module clear before a front clamp"
    )
    assumption: Flag = False
    """true when the values are not public"""

    @property
    def holding_force_n(self) -> float:
        """The wall normal force of one joint pressing with :attr:`min_torque`."""
        return self.min_torque / self.lever_arm

    def holds(self, torque_nm: float) -> bool:
        """Whether a joint pressing the wall with ``torque_nm`` holds its half.

        This is the one meaning of "clamped": the simulator asks it of each joint's
        press torque, the protective layer asks :meth:`holds_force` of each spring
        reading. A relative slack of 1e-9 absorbs float rounding only.
        """
        return abs(torque_nm) >= self.min_torque * (1.0 - _HOLD_SLACK)

    def holds_force(self, force_n: float) -> bool:
        """Whether a wheel's wall normal force ``force_n`` shows a holding joint."""
        return abs(force_n) >= self.holding_force_n * (1.0 - _HOLD_SLACK)

    def contact_angle(self, diameter_m: float) -> float:
        """Wall-contact angle for a pipe diameter, linearly interpolated and held at the ends."""
        pts = self.contact_angles
        if diameter_m <= pts[0].diameter:
            return pts[0].angle
        for a, b in itertools.pairwise(pts):
            if diameter_m <= b.diameter:
                t = (diameter_m - a.diameter) / (b.diameter - a.diameter)
                return a.angle + t * (b.angle - a.angle)
        return pts[-1].angle

    def diameter_for(self, angle_rad: float) -> float:
        """The pipe diameter a joint pressing the wall at ``angle_rad`` clamps in: the
        inverse of :meth:`contact_angle` (interpolated, held at the table's ends)."""
        pts = self.contact_angles
        angle = abs(angle_rad)
        rising = pts[-1].angle > pts[0].angle
        for a, b in itertools.pairwise(pts):
            low, high = sorted((a.angle, b.angle))
            if low <= angle <= high and high > low:
                t = (angle - a.angle) / (b.angle - a.angle)
                return a.diameter + t * (b.diameter - a.diameter)
        below_first = angle < pts[0].angle if rising else angle > pts[0].angle
        return pts[0].diameter if below_first else pts[-1].diameter


class MotionConfig(_Model):
    """Motion and physics parameters shared by the simulator and the protective layer."""

    nominal_speed: Velocity = Field(gt=0)
    """cruise speed of a straight run"""
    friction_coefficient: Dimensionless = Field(gt=0, le=2)
    """wheel-wall friction; traction = friction x normal force"""
    alignment_tolerance: Angle = Field(gt=0, description="bend-plane alignment needed at a bend")
    steer_angle: Angle = Field(gt=0, description="joint angle that counts as steered into a bend")
    max_unclamped_slope: Angle = Field(
        ge=0, description="steepest pipe in which both halves may be unclamped"
    )
    over_torque_time: Duration = Field(gt=0, description="time above torque limit = damage")
    weight: Force = Field(15.0, gt=0, description="robot weight (gravity load on slopes)")
    drive_free_current: Current = Field(0.15, ge=0, description="drive current, wheels free")
    drive_stall_current: Current = Field(1.5, gt=0, description="drive current, wheels blocked")
    position_hold_torque: Torque = Field(
        0.4, gt=0, description="torque a position-mode joint presses with when held by the wall"
    )
    slide_speed: Velocity = Field(0.2, gt=0, description="speed of an unclamped robot sliding")
    assumption: Flag = False
    """true when the values are not public"""


class SafetyConfig(_Model):
    """Parameters of the protective layer (``pirate_bt.safety``); every field has a default."""

    stale_after_periods: float = Field(
        10.0,
        gt=1,
        allow_inf_nan=False,
        description="a reading older than this many sensor periods is stale",
    )
    max_link_silence: Duration = Field(
        0.5, gt=0, description="longest time without a valid frame before the link counts as lost"
    )
    max_refusals: WholeNumber = Field(
        5, ge=1, description="consecutive refused tree commands that put the robot in safe state"
    )
    rate_window: Duration = Field(
        0.1, gt=0, description="longest time step a rate-of-change limit allows in one command"
    )
    angle_tolerance: Angle = Field(
        0.03, ge=0, description="slack on clamp-contact and front-clear angle comparisons"
    )
    release_force_fraction: Dimensionless = Field(
        0.2, ge=0, le=1, description="below this share of the minimum clamp force a half is free"
    )
    clamp_force_fraction: Dimensionless = Field(
        0.9,
        gt=0,
        le=1,
        description="share of a clamp's commanded force a clamp step waits to read (sensor"
        " slack); whether a half holds is clamp.min_torque alone",
    )


class BridgeConfig(_Model):
    """The PIRATEbay bridge and its serial line."""

    baud: WholeNumber = Field(115200, ge=1200, le=4_000_000)
    """serial line speed (bit/s)"""
    # the bounds of the firmware's header (whole milliseconds, 1 ms .. 60 s); the host
    # waits reset_time on opening a port, so it is bounded too
    state_period: Duration = Field(ge=0.001, le=60, description="time between state frames")
    watchdog: Duration = Field(
        ge=0.001, le=60, description="bridge stops drives when the host is silent"
    )
    reset_time: Duration = Field(ge=0, le=60, description="Arduino reset after DTR toggles on open")
