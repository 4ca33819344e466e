"""Protocol messages as plain JSON and back, the form the shared test vectors use.

Messages are plain objects: ``type`` by name, enums by their wire value, control
modes by name, ``null`` = keep. :mod:`pirate_bt.link.vectors` (which re-exports both
functions) and :mod:`pirate_bt.link.vector_sequences` build on this module.
"""

from __future__ import annotations

import dataclasses
from enum import Enum
from typing import Any

from pirate_bt.link.messages import (
    Ack,
    AckStatus,
    BoardCounters,
    BridgeFlags,
    BridgeHeartbeat,
    BulkSetpoints,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    Nack,
    NackCode,
    Setpoint,
    State,
)
from pirate_bt.robot.description import ControlMode

__all__ = ["message_from_json", "message_to_json"]

_TYPES: dict[str, type[Message]] = {
    cls.TYPE.name: cls
    for cls in (
        Hello,
        Setpoint,
        BulkSetpoints,
        Heartbeat,
        EStop,
        EStopReset,
        CountersRequest,
        HelloReply,
        State,
        Ack,
        Nack,
        Counters,
        BridgeHeartbeat,
    )
}


def message_to_json(msg: Message) -> dict[str, Any]:
    """A message as plain JSON (``type`` by name, enums by value, ``None`` modes as null)."""

    def plain(value: Any) -> Any:
        if isinstance(value, Enum):
            return value.value
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        if isinstance(value, tuple | list):
            return [plain(v) for v in value]
        return value

    out: dict[str, Any] = {"type": msg.TYPE.name}
    out.update(plain(msg))
    return out


def message_from_json(data: dict[str, Any]) -> Message:
    """Inverse of :func:`message_to_json` (every field present).

    Raises:
        KeyError: unknown type name.
        TypeError, ValueError: fields that do not make the message.
    """
    fields = dict(data)
    cls = _TYPES[fields.pop("type")]
    if cls is BulkSetpoints:
        fields["modes"] = tuple(None if m is None else ControlMode(m) for m in fields["modes"])
        fields["raw_values"] = tuple(fields["raw_values"])
    elif cls is Setpoint:
        fields["mode"] = ControlMode(fields["mode"])
    elif cls is State:
        fields["flags"] = BridgeFlags(fields["flags"])
        fields["board_status"] = tuple(fields["board_status"])
        fields["raw_values"] = tuple(fields["raw_values"])
    elif cls is BridgeHeartbeat or cls is HelloReply:
        fields["flags"] = BridgeFlags(fields.get("flags", 0))
    elif cls is Ack:
        fields["status"] = AckStatus(fields["status"])
    elif cls is Nack:
        fields["error"] = NackCode(fields["error"])
    elif cls is Counters:
        fields["boards"] = tuple(BoardCounters(**b) for b in fields["boards"])
    msg: Message = cls(**fields)
    return msg
