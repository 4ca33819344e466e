"""Topic names, message encoding and the JSON Schemas of the Foxglove topics.

The part of the trace-record <-> Foxglove topic mapping that both directions share:
:mod:`pirate_bt.interop.foxglove_topics` (records -> messages) and
:mod:`pirate_bt.interop.foxglove_records` (messages -> records). Imports neither.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from typing import Any

__all__ = ["TOPICS", "encode_message", "escape_surrogates", "missing_extra", "schema_of"]

EXTRA_HINT = "pip install 'pirate-bt[foxglove]'"

RUN = "/pirate/run"
STATE = "/pirate/state"
TREE = "/pirate/tree"
BLACKBOARD = "/pirate/blackboard"
COMMANDS = "/pirate/commands"
LINK = "/pirate/link"
SIM = "/pirate/sim"
LOCALISATION = "/pirate/localisation"
LOG = "/pirate/log"
END = "/pirate/end"
TICK = "/pirate/tick"

_STATUS_NAME = {"S": "SUCCESS", "F": "FAILURE", "R": "RUNNING", "I": "INVALID"}
_STATUS_CODE = {v: k for k, v in _STATUS_NAME.items()}
_TICK_KEYS = frozenset(
    {
        "type",
        "n",
        "t_s",
        "status",
        "feedback",
        "bb",
        "bb_unset",
        "state",
        "full",
        "commands",
        "link",
        "sim",
        "events",
    }
)
_STATE_DERIVED = frozenset({"n", "t_s", "full", "speed_mps"})
_TASK = "task."
_MISSING: Any = object()

# foxglove.Log levels.
_DEBUG, _INFO, _WARNING, _ERROR = 1, 2, 3, 4
_EVENT_LEVEL = {"fault": _ERROR, "exception": _ERROR, "estop": _ERROR, "operator": _INFO}
_END_LEVEL = {"success": _INFO, "running": _INFO, "interrupted": _WARNING}

encode_json = json.JSONEncoder(separators=(",", ":"), ensure_ascii=False).encode
_encode_strict = json.JSONEncoder(separators=(",", ":"), ensure_ascii=False, allow_nan=False).encode


_SURROGATE = re.compile("[\ud800-\udfff]")


def _escaped(found: re.Match[str]) -> str:
    return f"\\u{ord(found[0]):04x}"


def escape_surrogates(text: str) -> str:
    """JSON ``text`` with each lone surrogate (no UTF-8 has one) as its ``\\uXXXX`` escape,
    which JSON reads back as the same character."""
    return _SURROGATE.sub(_escaped, text)


def missing_extra(what: str, module: str) -> str:
    """The one-line message for a missing optional dependency."""
    return f"{what} needs the '{module}' package: {EXTRA_HINT}"


def _finite(value: Any) -> Any:
    """``value`` with every float that is not finite as the string the trace uses."""
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)  # "nan", "inf", "-inf"
    if isinstance(value, Mapping):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def encode_message(message: Mapping[str, Any]) -> bytes:
    """A message as compact UTF-8 JSON (the ``json`` message encoding).

    Numbers that are not finite are the strings ``"nan"``, ``"inf"``, ``"-inf"``, as in the
    trace: Python's ``NaN`` and ``Infinity`` are not JSON, and Foxglove's parser refuses the
    whole message (until 2026-11-30 a float of a record given as data, a ``.jsonl`` with
    ``NaN`` exported to MCAP, or a mean wheel speed that overflowed was written so).
    """
    try:
        text = _encode_strict(message)
    except ValueError:
        text = _encode_strict(_finite(message))
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError:
        # A lone surrogate (in a name or a message of a tree built in Python) has no
        # UTF-8: written as JSON's escape, read back as the same character. Until
        # 2026-11-30 it stopped the trace's writer (`--trace RUN.mcap` failed the run
        # with SinkError, where `.jsonl` kept it) and the export of such a trace.
        return escape_surrogates(text).encode("utf-8")


# --- schemas -----------------------------------------------------------------------

_NUMBER = {"type": ["number", "string"], "description": "a number; nan, inf, -inf as strings"}
_TICK_N = {"type": "integer", "description": "tick number (the first tick is 1)"}
_T_S = {"type": "number", "description": "seconds since the start of the run (the run's clock)"}


def _values(description: str) -> dict[str, Any]:
    return {"type": "object", "description": description, "additionalProperties": _NUMBER}


def _object(
    title: str, description: str, properties: dict[str, Any], **more: Any
) -> dict[str, Any]:
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        **more,
    }


_SCHEMAS: dict[str, tuple[str, dict[str, Any]]] = {
    RUN: (
        "pirate.Run",
        _object(
            "pirate.Run",
            "The trace header: tree shape (nodes by path id), robot, scenario, clock, software.",
            {
                "format": {"type": "string"},
                "version": {"type": "integer"},
                "created_utc": {"type": "string"},
                "tree": {"type": "object"},
                "robot": {"type": "object"},
                "scenario": {"type": ["string", "null"]},
                "seed": {"type": ["integer", "null"]},
                "clock": {"type": "string"},
                "tick_period_s": {"type": ["number", "null"]},
                "meta": {"type": "object"},
            },
        ),
    ),
    STATE: (
        "pirate.RobotState",
        _object(
            "pirate.RobotState",
            "The robot state as the host saw it (SI units), every value as it is now.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "joint_angle_rad": _values("bend joint angle per module, rad"),
                "clamp_force_n": _values("clamp force per module, N"),
                "imu_rad": _values("roll, pitch, yaw, rad"),
                "drive_velocity_mps": _values("measured wheel speed per drive motor, m/s"),
                "motor_current_a": _values("current per motor, A"),
                "rotation_rad": _NUMBER,
                "camera_tilt_rad": _NUMBER,
                "camera_pan_rad": _NUMBER,
                "front_tilt_rad": _NUMBER,
                "readings": _values("raw channels, when the trace records them"),
                "speed_mps": {**_NUMBER, "description": "mean wheel speed, m/s"},
                "full": {"type": "boolean", "description": "the trace recorded every value"},
            },
            additionalProperties=_NUMBER,
        ),
    ),
    TREE: (
        "pirate.TreeStatus",
        _object(
            "pirate.TreeStatus",
            "Status and feedback changes of the tree's nodes in one tick.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "active": {
                    "type": "string",
                    "description": "name path of the deepest RUNNING node ('' when none)",
                },
                "status": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "properties": {
                            "id": {"type": "string", "description": "path id, e.g. 0.1.2"},
                            "name": {"type": "string"},
                            "path": {"type": "string", "description": "names from the root"},
                            "status": {
                                "type": "string",
                                "enum": ["SUCCESS", "FAILURE", "RUNNING", "INVALID"],
                            },
                        },
                    },
                },
                "feedback": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "properties": {
                            "id": {"type": "string"},
                            "name": {"type": "string"},
                            "feedback": {},
                        },
                    },
                },
                "snapshot": {
                    "type": "boolean",
                    "description": "live only: every node's status, sent to a new subscriber",
                },
            },
        ),
    ),
    BLACKBOARD: (
        "pirate.Blackboard",
        _object(
            "pirate.Blackboard",
            "Blackboard writes in one tick, and every value as it is now.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "set": {"type": "object"},
                "unset": {"type": "array", "items": {"type": "string"}},
                "values": {"type": "object"},
            },
        ),
    ),
    COMMANDS: (
        "pirate.Verdict",
        _object(
            "pirate.Verdict",
            "One command, who asked for it and what the safety supervisor decided.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "command": {"type": "string", "description": "e.g. clamp(front, 0.5 N·m)"},
                "verdict": {"type": "string", "enum": ["pass", "clip", "refuse"]},
                "reason": {"type": "string"},
                "detail": {"type": "string"},
                "source": {"type": "string", "description": "tree, operator or supervisor"},
                "node": {"type": "string", "description": "path id of the asking node"},
                "node_path": {"type": "string", "description": "names from the root"},
                "sent": {
                    "type": "array",
                    "items": {
                        "type": "object",
                        "properties": {
                            "motor": {"type": "string"},
                            "mode": {"type": "string"},
                            "value": _NUMBER,
                        },
                    },
                },
            },
        ),
    ),
    LINK: (
        "pirate.LinkHealth",
        _object(
            "pirate.LinkHealth",
            "Health of the link to the bridge, every field as it is now.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "connected": {"type": "boolean"},
                "last_heard_s": _NUMBER,
                "rtt_s": _NUMBER,
                "loss_ratio": _NUMBER,
                "crc_errors": {"type": "integer"},
                "retries": {"type": "integer"},
                "failed": {"type": "integer"},
                "duplicates": {"type": "integer"},
                "estopped": {"type": "boolean"},
                "estop_input": {"type": "boolean"},
            },
            additionalProperties=True,
        ),
    ),
    SIM: (
        "pirate.SimTruth",
        _object(
            "pirate.SimTruth",
            "What the simulator knows and the robot does not: counters and truth.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "distance_m": _NUMBER,
                "stuck_events": _NUMBER,
                "slip_events": _NUMBER,
                "violations": _NUMBER,
                "damage": _NUMBER,
                "frames_dropped": _NUMBER,
                "frames_rejected": _NUMBER,
                "watchdog_trips": _NUMBER,
                "truth": {
                    "type": "object",
                    "description": "pirate-bt sim only: front_m, velocity_mps, rotation_rad...",
                },
            },
            additionalProperties=_NUMBER,
        ),
    ),
    LOCALISATION: (
        "pirate.Localisation",
        _object(
            "pirate.Localisation",
            "Where the mission believes the robot is, and (simulated) where it is.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "belief_m": _NUMBER,
                "truth_m": _NUMBER,
                "error_m": _NUMBER,
                "fixes": _NUMBER,
            },
            additionalProperties=_NUMBER,
        ),
    ),
    LOG: (
        "foxglove.Log",
        _object(
            "foxglove.Log",
            "A log line (Foxglove's Log panel): events, refusals, the end of the run.",
            {
                "timestamp": {
                    "type": "object",
                    "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
                },
                "level": {"type": "integer", "description": "1 debug, 2 info, 3 warning, 4 error"},
                "message": {"type": "string"},
                "name": {"type": "string"},
                "file": {"type": "string"},
                "line": {"type": "integer"},
                "n": _TICK_N,
                "t_s": _T_S,
                "record": {
                    "type": "string",
                    "enum": ["events", "commands", "end"],
                    "description": "what of the trace this line comes from",
                },
                "event": {"type": "object", "description": "the trace's event, as it is"},
            },
        ),
    ),
    END: (
        "pirate.RunEnd",
        _object(
            "pirate.RunEnd",
            "How the run ended: outcome, reason, the failing node.",
            {
                "n": _TICK_N,
                "t_s": _T_S,
                "outcome": {"type": "string"},
                "reason": {"type": "string"},
                "error": {"type": "object"},
                "dropped": {
                    "type": "integer",
                    "description": "Live view only: ticks merged into later ones because the"
                    " server's process lagged (absent when none).",
                },
            },
        ),
    ),
    TICK: (
        "pirate.Tick",
        _object(
            "pirate.Tick",
            "A tick record no other topic carries, or its keys no other topic knows.",
            {"n": _TICK_N, "t_s": _T_S, "extra": {"type": "object"}},
        ),
    ),
}

TOPICS: tuple[str, ...] = tuple(_SCHEMAS)
"""Every topic, in the order their channels are made."""


def schema_of(topic: str) -> tuple[str, dict[str, Any]]:
    """The schema name and JSON Schema of a topic."""
    return _SCHEMAS[topic]
