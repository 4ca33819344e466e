"""Pipe networks as data: pydantic models of ``scenarios/*.yaml``.

A network is a tree of pipe *lines*. The main line starts where the robot is
put in; it is a list of segments, front to back:

- ``straight``: a run of pipe with a length, optionally its own internal
  diameter and its inclination (``slope``, to the horizontal).
- ``bend``: a 90° elbow (or a smaller angle) whose curve points in a
  ``direction`` (``up``, ``down``, ``left``, ``right``) or at a ``roll`` angle.
- ``tee``: a T-joint. The line goes on straight; a branch line leaves the
  opening in the middle of the tee toward its ``direction``/``roll``, and
  holds its own list of segments.
- ``reducer``: a short cone that changes the internal diameter.

Directions are given in the pipe's own cross-section, looking along the
direction of travel: ``up`` is roll 0, ``right`` 90°, ``down`` 180°,
``left`` -90° (see ``docs/networks.md``). The frame is carried along the pipe
without twisting, so on horizontal runs "up" is up.

Validation is two steps, as for robot descriptions: pydantic checks shapes and
bounds, then :meth:`NetworkSpec.cross_check` checks rules spanning the file
(unique ids, one direction per turn) and returns each problem with its path.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from pirate_bt.robot.parts import Title
from pirate_bt.units import Angle, Duration, Force, Length, SchemaVersion

__all__ = [
    "DIRECTION_ROLL_RAD",
    "BendSpec",
    "Direction",
    "FaultSpec",
    "NetworkSpec",
    "ReducerSpec",
    "SegmentSpec",
    "StartSpec",
    "StraightSpec",
    "TeeBranchSpec",
    "TeeSpec",
]

Ident = Annotated[
    str,
    Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]*$", max_length=40, description="segment id"),
]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)


class Direction(StrEnum):
    """Named directions in the pipe's cross-section, looking along the travel."""

    UP = "up"
    RIGHT = "right"
    DOWN = "down"
    LEFT = "left"


DIRECTION_ROLL_RAD: dict[Direction, float] = {
    Direction.UP: 0.0,
    Direction.RIGHT: math.pi / 2,
    Direction.DOWN: math.pi,
    Direction.LEFT: -math.pi / 2,
}


class _Turn(_Model):
    direction: Direction | None = Field(
        None, description="where the curve points: up, down, left or right"
    )
    roll: Angle | None = Field(
        None,
        ge=-math.pi - 1e-9,
        le=2 * math.pi,
        description="roll angle of the curve's plane, clockwise from up looking forward",
    )

    @model_validator(mode="after")
    def _one_direction(self) -> _Turn:
        if (self.direction is None) == (self.roll is None):
            raise ValueError("give exactly one of 'direction' (up/down/left/right) or 'roll'")
        return self

    @property
    def roll_rad(self) -> float:
        """The roll angle of the turn, wrapped to (-pi, pi]."""
        value = DIRECTION_ROLL_RAD[self.direction] if self.direction is not None else self.roll
        assert value is not None
        return _wrap(value)


def _wrap(angle_rad: float) -> float:
    wrapped = math.remainder(angle_rad, 2 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


class StraightSpec(_Model):
    """A straight run of pipe."""

    type: Literal["straight"]
    id: Ident | None = None
    length: Length = Field(gt=0, le=10_000, description="length along the axis")
    diameter: Length | None = Field(
        None, ge=0.04, le=0.2, description="internal diameter (default: the one before)"
    )
    slope: Angle | None = Field(
        None,
        ge=-math.pi / 2,
        le=math.pi / 2,
        description="inclination to the horizontal, positive uphill (default: as before)",
    )


class BendSpec(_Turn):
    """An elbow: the pipe turns by ``angle`` (90° unless given) toward its direction."""

    type: Literal["bend"]
    id: Ident | None = None
    radius: Length = Field(
        0.09, gt=0, le=2.0, description="centre-line radius of the curve (default 90 mm)"
    )
    angle: Angle = Field(
        math.pi / 2, gt=0, le=math.pi / 2 + 1e-9, description="how far the pipe turns"
    )


class TeeBranchSpec(_Turn):
    """The branch of a tee: where it points and the line behind it."""

    radius: Length | None = Field(
        None, gt=0, le=2.0, description="radius of the turn into the branch (default: diameter)"
    )
    segments: list[SegmentSpec] = Field(
        default_factory=list, description="the branch line, front to back (empty: a capped stub)"
    )


class TeeSpec(_Model):
    """A T-joint: the line goes on straight, a branch leaves from the middle."""

    type: Literal["tee"]
    id: Ident | None = None
    length: Length | None = Field(
        None, gt=0, le=1.0, description="length of the straight run through the tee (default 3 x D)"
    )
    branch: TeeBranchSpec


class ReducerSpec(_Model):
    """A cone that changes the internal diameter over its length."""

    type: Literal["reducer"]
    id: Ident | None = None
    diameter: Length = Field(ge=0.04, le=0.2, description="internal diameter after the reducer")
    length: Length = Field(0.05, gt=0, le=1.0, description="length of the cone")


SegmentSpec = Annotated[
    StraightSpec | BendSpec | TeeSpec | ReducerSpec, Field(discriminator="type")
]
TeeBranchSpec.model_rebuild()


class StartSpec(_Model):
    """Where the robot is put into the network."""

    position: Length | None = Field(
        None,
        ge=0,
        description="distance of the robot's front tip from the start of the main line"
        " (default: the robot's length, so its rear is at the entry)",
    )
    roll: Angle = Field(0.0, description="roll of both halves at the start (0 = bending plane up)")


FaultKind = Literal[
    "motor_stall", "sensor_dropout", "sensor_stuck", "board_reset", "board_fault", "link_loss"
]


class FaultSpec(_Model):
    """A fault the simulator injects at a simulated time."""

    kind: FaultKind
    at: Duration = Field(ge=0, description="simulated time the fault starts")
    duration: Duration | None = Field(
        None, gt=0, description="how long it lasts (default: for ever; board_reset: reset time)"
    )
    target: str | None = Field(
        None,
        description="motor name (motor_stall), sensor channel name (sensor_*), board id"
        " (board_reset, board_fault); none for link_loss",
    )

    @field_validator("target", mode="before")
    @classmethod
    def _board_id_as_written(cls, value: object) -> object:
        """A board id written as a number (``target: 22``, as YAML reads it) is the
        board's name, text: it was refused (*must be text, not 22*)."""
        if isinstance(value, int) and not isinstance(value, bool):
            return str(value)
        return value


def _dotted(path: tuple[str | int, ...]) -> str:
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")


class NetworkSpec(_Model):
    """A whole pipe network: defaults, the main line, and scheduled faults."""

    schema_version: SchemaVersion = 1
    name: Title
    description: str = ""
    diameter: Length = Field(
        ge=0.04, le=0.2, description="internal diameter at the start of the main line"
    )
    slope: Angle = Field(
        0.0, ge=-math.pi / 2, le=math.pi / 2, description="inclination of the first segment"
    )
    tether_drag_per_metre: Force = Field(
        0.0, ge=0, description="tether drag per metre of tether in the pipe (a force per metre)"
    )
    start: StartSpec = StartSpec()
    segments: list[SegmentSpec] = Field(min_length=1, description="the main line, front to back")
    faults: list[FaultSpec] = Field(default_factory=list)

    def cross_check(self) -> list[tuple[tuple[str | int, ...], str]]:
        """Rules that span the file, each as ``(path, message)``; empty when valid."""
        out: list[tuple[tuple[str | int, ...], str]] = []
        seen: dict[str, tuple[str | int, ...]] = {}

        generated: dict[str, tuple[str | int, ...]] = {}

        def walk(segments: list[Any], path: tuple[str | int, ...], prefix: str) -> None:
            for i, seg in enumerate(segments):
                here = (*path, i)
                name = seg.id or f"{prefix}-{i + 1}"
                if seg.id is not None:
                    if seg.id in seen:
                        out.append(((*here, "id"), f"duplicate segment id {seg.id!r}"))
                    seen.setdefault(seg.id, here)
                else:
                    generated.setdefault(name, here)
                if isinstance(seg, TeeSpec):
                    walk(seg.branch.segments, (*here, "branch", "segments"), f"{name}-b")

        walk(self.segments, ("segments",), "main")
        for name, here in generated.items():
            if name in seen:
                out.append(
                    (
                        (*seen[name], "id"),
                        f"segment id {name!r} is also the name of a segment without an id"
                        f" ({_dotted(here)}): give that one an id, or this"
                        " one another",
                    )
                )
        for i, fault in enumerate(self.faults):  # what a fault's kind takes, as the
            # simulator checks it (which motor, channel or board: with the robot)
            if fault.kind == "link_loss" and fault.target is not None:
                out.append((("faults", i, "target"), "link_loss takes no target (the whole link)"))
            elif fault.kind != "link_loss" and fault.target is None:
                what = _FAULT_TARGETS[fault.kind]
                out.append((("faults", i), f"{fault.kind} needs a target: {what}"))
        return out


_FAULT_TARGETS = {
    "motor_stall": "a motor's name",
    "sensor_dropout": "a state channel's name",
    "sensor_stuck": "a state channel's name",
    "board_reset": "a board id",
    "board_fault": "a board id",
}
