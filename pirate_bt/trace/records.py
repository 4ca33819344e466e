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
import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import cache
from importlib import resources
from operator import attrgetter
from typing import Any

import py_trees

from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState
from pirate_bt.trace.sink import (
    SINGLES,
    VIEWS,
    FieldChanges,
    StateDiff,
    encode_value,
    round_value,
)
from pirate_bt.trace.structure import jsonable

__all__ = [
    "BAD_RECORD",
    "CODE_STATUS",
    "FORMAT_NAME",
    "LINK_FIELDS",
    "OUTCOMES",
    "STATUS_CODE",
    "TRACE_VERSION",
    "VERDICTS",
    "CommandRecord",
    "FieldChanges",
    "StateChanges",
    "TickExtras",
    "TraceEvent",
    "encode_value",
    "end_problem",
    "flatten_state",
    "link_health_raw",
    "link_health_values",
    "objects",
    "state_from_flat",
    "state_layout",
    "status_codes",
    "trace_schema",
]

BAD_RECORD: tuple[type[Exception], ...] = (
    ValueError,
    TypeError,
    AttributeError,
    LookupError,
    ArithmeticError,
    struct.error,
)
"""What converting a record with a value of the wrong kind, or out of range, raises (a
hand-edited or foreign trace; the MCAP and rosbag2 exports): said as the record's error,
never as an internal one."""

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
        # On the trace's hot path when a behaviour re-sends a setpoint every tick: each
        # value is looked up once, and str()/float() run only on what is not one already.
        reason, detail, source = data.get("reason"), data.get("detail"), data.get("source")
        sent = tuple(
            (
                m if type(m) is str else str(m),
                mode if type(mode) is str else str(mode),
                v if type(v) is float else float(v),
            )
            for m, mode, v in data.get("sent", ())
        )
        command, outcome = data["command"], data["outcome"]
        return cls(
            command=command if type(command) is str else str(command),
            verdict=outcome if type(outcome) is str else str(outcome),
            reason=None if reason is None else str(reason),
            detail=str(detail) if detail else None,
            sent=sent,
            source=None if source is None else str(source),
            node=node if node is not None else data.get("node"),
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


def flatten_state(state: RobotState, readings: bool = False) -> dict[str, Any]:
    """A state snapshot as flat ``name -> value`` pairs, for change detection.

    Keys are the snapshot's attribute names, with the item after a dot for the
    role-based views: ``joint_angle_rad.bend_1``, ``clamp_force_n.bend_2``,
    ``rotation_rad``, ``imu_rad.roll``, ``drive_velocity_mps.bend_1_drive``,
    ``motor_current_a.rotate``. With ``readings``, every channel is added as
    ``readings.<channel>`` too. ``stamp_s`` is not included (each tick has a time).
    """
    flat: dict[str, Any] = {}
    for view in VIEWS:
        mapping: Mapping[str, float] = getattr(state, view)
        for key, value in mapping.items():
            flat[f"{view}.{key}"] = round_value(value)
    for single in SINGLES:
        value = getattr(state, single)
        if value is not None:
            flat[single] = round_value(value)
    if readings:
        for name, reading in state.readings.items():
            flat[f"readings.{name}"] = round_value(reading.value)
    return flat


def state_layout(
    state: RobotState, readings: bool = False
) -> tuple[tuple[str | None, ...], tuple[Any, ...]]:
    """A snapshot's layout and raw values (see :func:`pirate_bt.trace.sink.layout_names`).

    Runs every traced tick: tuple displays with ``*`` unpacking gather the keys and
    values in C, with no per-value Python loop. In the keys a ``None`` (never a name)
    ends each view, so a name that moves from one view to another is a new layout.
    """
    joints, forces, imu = state.joint_angle_rad, state.clamp_force_n, state.imu_rad
    drives, currents = state.drive_velocity_mps, state.motor_current_a
    keys: tuple[str | None, ...] = (
        *joints,
        None,
        *forces,
        None,
        *imu,
        None,
        *drives,
        None,
        *currents,
        None,
    )
    raw: tuple[Any, ...] = (
        *joints.values(),
        *forces.values(),
        *imu.values(),
        *drives.values(),
        *currents.values(),
        state.rotation_rad,
        state.camera_tilt_rad,
        state.camera_pan_rad,
        state.front_tilt_rad,
    )
    if readings:
        keys += tuple(state.readings)
        raw += tuple([reading.value for reading in state.readings.values()])
    return keys, raw


class StateChanges:
    """The :func:`flatten_state` values that changed since the last snapshot, found cheaply.

    Same result as comparing ``flatten_state(state)`` with the values recorded so
    far (a name that disappears, such as an unreported rotation, is not a change),
    but built for the trace's hot path: :func:`state_layout` gathers a snapshot's
    raw values into one tuple, and a :class:`~pirate_bt.trace.sink.StateDiff`
    rounds and names only those that moved.

    Args:
        readings: Also track every raw channel (``readings.<channel>``).
    """

    def __init__(self, readings: bool = False) -> None:
        self.readings = readings
        self._diff = StateDiff(readings=readings)
        self._keys: tuple[str | None, ...] | None = None

    @property
    def values(self) -> dict[str, Any]:
        """Flat name -> last recorded (rounded) value."""
        return self._diff.values

    def _raw(self, state: RobotState) -> tuple[Any, ...]:
        keys, raw = state_layout(state, self.readings)
        if keys != self._keys:
            self._keys = keys
            self._diff.set_layout(keys)
        return raw

    def changes(self, state: RobotState) -> dict[str, Any]:
        """Record ``state`` and return the flat values that changed (possibly empty)."""
        indices, rounded, _ = self._diff.diff(self._raw(state))
        return dict(zip(map(self._diff.names.__getitem__, indices), rounded, strict=True))

    def changes_json(self, state: RobotState) -> str:
        """Record ``state``; the changes as the members of a JSON object, or ``""``."""
        return self._diff.diff_json(self._raw(state))


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


#: The fields of :class:`LinkHealth` a trace records, in the order of
#: :func:`link_health_raw`: all but ``bridge_resets``, ``bus_fault``,
#: ``faulted_boards``, ``states_refused``, ``line_noise`` and ``latch_kept``, which the trace schema
#: predates (a reset mid-session shows as the bridge's latch and the supervisor's e-stop
#: cause; a bus or board fault as the supervisor's safe-state cause, which names the
#: boards; refused STATE frames as ``crc_errors``, ``duplicates`` and the safe-state
#: cause; a line's noise as ``crc_errors`` and the safe-state cause; a latch kept
#: from the start as the supervisor's e-stop cause).
LINK_FIELDS: tuple[str, ...] = tuple(
    f
    for f in LinkHealth.__dataclass_fields__
    if f
    not in (
        "bridge_resets",
        "bus_fault",
        "faulted_boards",
        "states_refused",
        "line_noise",
        "latch_kept",
    )
)

link_health_raw: Callable[[LinkHealth], tuple[Any, ...]] = attrgetter(*LINK_FIELDS)
"""Link health as a tuple of raw values, in ``LinkHealth`` field order: one C call,
with no Python function around it (the trace's capture calls it every tick)."""


def link_health_values(health: LinkHealth) -> dict[str, Any]:
    """Link health as flat JSON values, floats rounded."""
    out: dict[str, Any] = {}
    for name in LINK_FIELDS:
        value = getattr(health, name)
        out[name] = round_value(value) if isinstance(value, float) else value
    return out


@cache
def trace_schema() -> dict[str, Any]:
    """The JSON Schema of one trace record (``header``, ``tick`` or ``end``)."""
    text = resources.files("pirate_bt.trace").joinpath("trace.schema.json").read_text("utf-8")
    schema: dict[str, Any] = json.loads(text)
    return schema


# -- what a reader checks of a record's members ------------------------------------------


def status_codes(value: Any) -> dict[str, str]:
    """A tick's ``status`` member, each code one of :data:`CODE_STATUS`'s.

    Raises:
        ValueError: a code that is none (a list or a number passed, and later made
            ``trace show`` and ``render --trace`` end with an internal error).
        TypeError: not an object.
    """
    status = dict(value)
    for node_id, code in status.items():
        if not isinstance(code, str) or code not in CODE_STATUS:
            raise ValueError(f"node {node_id!r}: status {code!r} is none of S, F, R, I")
    return status


def objects(value: Any, member: str) -> tuple[dict[str, Any], ...]:
    """A record's list of objects (a tick's ``commands``).

    Raises:
        ValueError: not a list of objects (text, or a list of numbers, passed and
            ended ``trace summary`` with an internal error).
    """
    if not isinstance(value, list | tuple) or not all(isinstance(v, dict) for v in value):
        raise ValueError(f"{member} is a list of objects, not {json.dumps(value)[:60]}")
    return tuple(value)


def end_problem(record: Mapping[str, Any]) -> str | None:
    """What is wrong with an end record's ``n``, ``t_s`` or ``outcome`` (a ``null``
    tick number ended ``trace summary`` and ``show`` with an internal error), or None."""
    n, t_s, outcome = record.get("n", 0), record.get("t_s", 0.0), record.get("outcome")
    if (
        isinstance(n, int)
        and not isinstance(n, bool)
        and isinstance(t_s, int | float)
        and not isinstance(t_s, bool)
        and isinstance(outcome, str)
    ):
        return None
    return (
        "bad end record: n is a whole number, t_s a number and outcome text"
        f" (n {json.dumps(n)[:40]}, t_s {json.dumps(t_s)[:40]},"
        f" outcome {json.dumps(outcome)[:40]})"
    )
