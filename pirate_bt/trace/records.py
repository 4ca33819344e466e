"""What a trace holds, independent of how it is stored.

A trace is a sequence of *records* (plain JSON objects): one ``header``, then
one ``tick`` record per tick in which something changed, then one ``end``
record. The layout of each record is documented in ``docs/formats/trace.md``
and checked by the JSON Schema in ``trace.schema.json`` next to this module;
:data:`TRACE_VERSION` is bumped whenever a reader of the old layout would
misread the new one.

This module also holds the small, explicit inputs the trace writer takes from
the rest of the library each tick, so the trace depends on no layer above
``robot/``: :class:`TickExtras` (state snapshot, command verdicts, link health,
simulator counters, events), :class:`CommandRecord` (one command and what the
supervisor decided) and :class:`TraceEvent` (a fault, an e-stop, an operator
action).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import cache
from importlib import resources
from math import isfinite
from typing import Any

import py_trees

from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState
from pirate_bt.trace.structure import jsonable

__all__ = [
    "CODE_STATUS",
    "FORMAT_NAME",
    "OUTCOMES",
    "STATUS_CODE",
    "TRACE_VERSION",
    "VERDICTS",
    "CommandRecord",
    "StateChanges",
    "TickExtras",
    "TraceEvent",
    "flatten_state",
    "link_health_values",
    "state_from_flat",
    "trace_schema",
]

FORMAT_NAME = "pirate-bt-trace"
TRACE_VERSION = 1

#: One letter per py_trees status, to keep tick records short.
STATUS_CODE: Mapping[py_trees.common.Status, str] = {
    py_trees.common.Status.SUCCESS: "S",
    py_trees.common.Status.FAILURE: "F",
    py_trees.common.Status.RUNNING: "R",
    py_trees.common.Status.INVALID: "I",
}
CODE_STATUS: Mapping[str, py_trees.common.Status] = {v: k for k, v in STATUS_CODE.items()}

VERDICTS = ("pass", "clip", "refuse")
OUTCOMES = ("success", "failure", "error", "interrupted", "running")

# Floats in state, link and counter values are rounded to this many decimals:
# 1 µrad, 1 µm/s, 1 µN are far below any sensor's resolution, and rounding
# keeps noise in the last bits from counting as a change.
_DECIMALS = 6


@dataclass(frozen=True, slots=True)
class CommandRecord:
    """One command a behaviour (or operator) asked for, and the supervisor's verdict.

    Attributes:
        command: The command in short form, e.g. ``clamp(front, 0.5 N·m)``.
        verdict: ``pass``, ``clip`` or ``refuse``.
        reason: Machine-readable reason for a clip or a refusal.
        detail: The reason in words.
        sent: Motor commands actually sent, as ``(motor, mode, value)`` in SI units.
        source: Who asked: ``tree``, ``operator`` or ``supervisor``.
        node: The path id of the behaviour that asked, if known.
    """

    command: str
    verdict: str
    reason: str | None = None
    detail: str | None = None
    sent: tuple[tuple[str, str, float], ...] = ()
    source: str | None = None
    node: str | None = None

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {VERDICTS}, not {self.verdict!r}")

    @classmethod
    def from_verdict(cls, verdict: Any, node: str | None = None) -> CommandRecord:
        """Record a :class:`pirate_bt.safety.verdict.Verdict` (read via its ``to_record()``)."""
        data = verdict.to_record()
        sent = tuple((str(m), str(mode), float(v)) for m, mode, v in data.get("sent", ()))
        return cls(
            command=str(data["command"]),
            verdict=str(data["outcome"]),
            reason=None if data.get("reason") is None else str(data["reason"]),
            detail=str(data["detail"]) if data.get("detail") else None,
            sent=sent,
            source=None if data.get("source") is None else str(data["source"]),
            node=node,
        )

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"command": self.command, "verdict": self.verdict}
        # Spelled out (not a getattr loop): one command per tick is on the trace's hot path.
        if self.reason is not None:
            out["reason"] = self.reason
        if self.detail is not None:
            out["detail"] = self.detail
        if self.source is not None:
            out["source"] = self.source
        if self.node is not None:
            out["node"] = self.node
        if self.sent:
            out["sent"] = [[m, mode, jsonable(v)] for m, mode, v in self.sent]
        return out


@dataclass(frozen=True, slots=True)
class TraceEvent:
    """Something that happened during a tick and is not a status or a value.

    Attributes:
        kind: ``fault`` (link loss, sensor fault, injected fault), ``estop``,
            ``operator`` (pause, takeover, confirm), ``exception`` or ``note``.
        message: What happened, in words.
        node: The path id of the node concerned, if any.
    """

    kind: str
    message: str
    node: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {k: v for k, v in asdict(self).items() if v is not None}


@dataclass(frozen=True)
class TickExtras:
    """What else happened in a tick, handed to the trace writer with the tree.

    Every field is optional; leave out what a run does not have.

    Attributes:
        state: The robot state snapshot the tick saw.
        commands: Commands asked for in this tick, with verdicts.
        link: Link health after the tick.
        sim: Simulator counters (name -> number), when simulated.
        events: Faults, e-stops and operator actions in this tick.
    """

    state: RobotState | None = None
    commands: Sequence[CommandRecord] = ()
    link: LinkHealth | None = None
    sim: Mapping[str, float] | None = None
    events: Sequence[TraceEvent] = field(default_factory=tuple)


def _round(value: float) -> float | str:
    if isfinite(value):
        return round(value, _DECIMALS)
    rounded = jsonable(float(value))
    assert isinstance(rounded, str)
    return rounded


_VIEWS = ("joint_angle_rad", "clamp_force_n", "imu_rad", "drive_velocity_mps", "motor_current_a")
_SINGLES = ("rotation_rad", "camera_tilt_rad", "camera_pan_rad", "front_tilt_rad")
_MISSING: Any = object()


def flatten_state(state: RobotState, readings: bool = False) -> dict[str, Any]:
    """A state snapshot as flat ``name -> value`` pairs, for change detection.

    Keys are the snapshot's attribute names, with the item after a dot for the
    role-based views: ``joint_angle_rad.bend_1``, ``clamp_force_n.bend_2``,
    ``rotation_rad``, ``imu_rad.roll``, ``drive_velocity_mps.bend_1_drive``,
    ``motor_current_a.rotate``. With ``readings``, every channel is added as
    ``readings.<channel>`` too. ``stamp_s`` is not included (each tick has a time).
    """
    flat: dict[str, Any] = {}
    for view in _VIEWS:
        mapping: Mapping[str, float] = getattr(state, view)
        for key, value in mapping.items():
            flat[f"{view}.{key}"] = _round(value)
    for single in _SINGLES:
        value = getattr(state, single)
        if value is not None:
            flat[single] = _round(value)
    if readings:
        for name, reading in state.readings.items():
            flat[f"readings.{name}"] = _round(reading.value)
    return flat


class StateChanges:
    """The :func:`flatten_state` values that changed since the last snapshot, found cheaply.

    Same result as comparing ``flatten_state(state)`` with the values recorded so
    far (a name that disappears, such as an unreported rotation, is not a change),
    but built for the trace's hot path: a snapshot's raw values are gathered into
    one tuple, so an unchanged snapshot costs one tuple comparison, and only the
    values that differ from the previous snapshot are rounded and named.

    Args:
        readings: Also track every raw channel (``readings.<channel>``).
    """

    def __init__(self, readings: bool = False) -> None:
        self.readings = readings
        self.values: dict[str, Any] = {}
        """Flat name -> last recorded (rounded) value."""
        self._keys: tuple[tuple[str, ...], ...] = ()
        self._names: tuple[str, ...] = ()
        self._raw: tuple[Any, ...] = ()

    def changes(self, state: RobotState) -> dict[str, Any]:
        """Record ``state`` and return the flat values that changed (possibly empty)."""
        views = (
            state.joint_angle_rad,
            state.clamp_force_n,
            state.imu_rad,
            state.drive_velocity_mps,
            state.motor_current_a,
        )
        singles = (
            state.rotation_rad,
            state.camera_tilt_rad,
            state.camera_pan_rad,
            state.front_tilt_rad,
        )
        if self.readings:
            keys = (*map(tuple, views), tuple(state.readings))
            raw = (
                *[v for view in views for v in view.values()],
                *singles,
                *[reading.value for reading in state.readings.values()],
            )
        else:
            keys = tuple(map(tuple, views))
            raw = (*[v for view in views for v in view.values()], *singles)
        changed: dict[str, Any] = {}
        values = self.values
        if keys != self._keys:
            # New names (first snapshot, or a sensor appeared): compare every value.
            self._keys = keys
            names = [f"{view}.{key}" for view, ks in zip(_VIEWS, keys, strict=False) for key in ks]
            names += _SINGLES
            if self.readings:
                names += [f"readings.{name}" for name in keys[-1]]
            self._names = tuple(names)
            previous: tuple[Any, ...] = (_MISSING,) * len(raw)
        elif raw == self._raw:
            return changed
        else:
            previous = self._raw
        self._raw = raw
        for name, value, before in zip(self._names, raw, previous, strict=True):
            if value is None or value is before or value == before:
                continue
            # -inf < v < inf is false for nan and the infinities: those take _round's spelling.
            rounded = round(value, _DECIMALS) if -_INF < value < _INF else _round(value)
            if values.get(name, _MISSING) != rounded:
                values[name] = rounded
                changed[name] = rounded
        return changed


_INF = float("inf")


def _number(value: Any) -> float:
    return float(value) if isinstance(value, int | float | str) else float("nan")


def state_from_flat(values: Mapping[str, Any], stamp_s: float) -> RobotState:
    """Rebuild a :class:`RobotState` from :func:`flatten_state` values.

    Readings (when the trace recorded them) get ``stamp_s`` as their freshness
    stamp: a trace keeps values, not per-channel freshness, which the
    supervisor's verdicts already account for.
    """
    views: dict[str, dict[str, float]] = {
        "joint_angle_rad": {},
        "clamp_force_n": {},
        "imu_rad": {},
        "drive_velocity_mps": {},
        "motor_current_a": {},
    }
    singles: dict[str, float] = {}
    readings: dict[str, Reading] = {}
    for key, value in values.items():
        head, _, tail = key.partition(".")
        if head == "readings" and tail:
            readings[tail] = Reading(_number(value), stamp_s)
        elif head in views and tail:
            views[head][tail] = _number(value)
        elif not tail:
            singles[head] = _number(value)
    return RobotState(
        stamp_s=stamp_s,
        readings=readings,
        joint_angle_rad=views["joint_angle_rad"],
        clamp_force_n=views["clamp_force_n"],
        imu_rad=views["imu_rad"],
        drive_velocity_mps=views["drive_velocity_mps"],
        motor_current_a=views["motor_current_a"],
        rotation_rad=singles.get("rotation_rad"),
        camera_tilt_rad=singles.get("camera_tilt_rad"),
        camera_pan_rad=singles.get("camera_pan_rad"),
        front_tilt_rad=singles.get("front_tilt_rad"),
    )


_LINK_FIELDS = tuple(LinkHealth.__dataclass_fields__)


def link_health_values(health: LinkHealth) -> dict[str, Any]:
    """Link health as flat JSON values, floats rounded."""
    out: dict[str, Any] = {}
    for name in _LINK_FIELDS:
        value = getattr(health, name)
        out[name] = _round(value) if isinstance(value, float) else value
    return out


@cache
def trace_schema() -> dict[str, Any]:
    """The JSON Schema of one trace record (``header``, ``tick`` or ``end``)."""
    text = resources.files("pirate_bt.trace").joinpath("trace.schema.json").read_text("utf-8")
    schema: dict[str, Any] = json.loads(text)
    return schema
