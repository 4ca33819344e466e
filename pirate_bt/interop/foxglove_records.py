"""Foxglove topic messages back into trace records: :func:`records_from_messages`.

The inverse of :class:`pirate_bt.interop.foxglove_topics.TopicMapper` (see that
module for the topics and how each one maps to the trace).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import Any

from pirate_bt.interop.foxglove_schemas import (
    _MISSING,
    _SCHEMAS,
    _STATE_DERIVED,
    _STATUS_CODE,
    _TASK,
    BLACKBOARD,
    COMMANDS,
    END,
    LINK,
    LOCALISATION,
    LOG,
    RUN,
    SIM,
    STATE,
    TICK,
    TREE,
)

__all__ = ["records_from_messages"]


def _flatten(nested: Mapping[str, Any], skip: frozenset[str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, value in nested.items():
        if name in skip:
            continue
        if isinstance(value, dict):
            for key, inner in value.items():
                out[f"{name}.{key}"] = inner
        else:
            out[name] = value
    return out


# --- messages -> records -----------------------------------------------------------


def _changes(
    whole: Mapping[str, Any], before: dict[str, Any], skip: frozenset[str]
) -> dict[str, Any]:
    """What in ``whole`` differs from ``before`` (updated to ``whole``)."""
    changed: dict[str, Any] = {}
    for key, value in whole.items():
        if key in skip:
            continue
        if before.get(key, _MISSING) != value or type(before.get(key)) is not type(value):
            changed[key] = value
            before[key] = value
    return changed


_STAMP = frozenset({"n", "t_s"})


def records_from_messages(
    messages: Iterable[tuple[str, Mapping[str, Any]]],
) -> Iterator[dict[str, Any]]:
    """Trace records rebuilt from ``(topic, message)`` pairs in the order they were written.

    The inverse of :class:`TopicMapper`: a trace written by the recorder comes back
    record for record, field for field. Messages on topics it does not know are
    skipped.
    """
    tick: dict[str, Any] | None = None
    state: dict[str, Any] = {}
    link: dict[str, Any] = {}
    sim: dict[str, Any] = {}
    task: dict[str, Any] = {}

    def start(message: Mapping[str, Any]) -> Iterator[dict[str, Any]]:
        nonlocal tick
        n = message.get("n")
        if tick is not None and tick["n"] != n:
            yield tick
            tick = None
        if tick is None:
            tick = {"type": "tick", "n": n, "t_s": message.get("t_s")}

    for topic, message in messages:
        if topic == RUN:
            if tick is not None:
                yield tick
                tick = None
            state, link, sim, task = {}, {}, {}, {}
            yield dict(message)
            continue
        if topic == END:
            if tick is not None:
                yield tick
                tick = None
            yield dict(message)
            continue
        if topic not in _SCHEMAS:
            continue
        if topic == LOG and message.get("record") != "events":
            continue  # derived lines (refusals, the end) are carried by their own topics
        yield from start(message)
        assert tick is not None
        if topic == TREE:
            if message.get("status"):
                tick["status"] = {
                    e["id"]: _STATUS_CODE.get(e["status"], e["status"]) for e in message["status"]
                }
            if message.get("feedback"):
                tick["feedback"] = {e["id"]: e["feedback"] for e in message["feedback"]}
        elif topic == BLACKBOARD:
            if "set" in message:
                tick["bb"] = message["set"]
            if "unset" in message:
                tick["bb_unset"] = message["unset"]
        elif topic == STATE:
            flat = _flatten(message, _STATE_DERIVED)
            if message.get("full"):
                state = dict(flat)
                tick["state"] = flat
                tick["full"] = True
            else:
                tick["state"] = _changes(flat, state, frozenset())
        elif topic == COMMANDS:
            command = {k: v for k, v in message.items() if k not in _STAMP and k != "node_path"}
            if "sent" in command:
                command["sent"] = [[s["motor"], s["mode"], s["value"]] for s in command["sent"]]
            tick.setdefault("commands", []).append(command)
        elif topic == LINK:
            tick["link"] = _changes(message, link, _STAMP)
        elif topic == SIM:
            tick.setdefault("sim", {}).update(_changes(message, sim, _STAMP | {"truth"}))
        elif topic == LOCALISATION:
            changed = _changes(message, task, _STAMP)
            tick.setdefault("sim", {}).update({_TASK + k: v for k, v in changed.items()})
        elif topic == LOG:
            tick.setdefault("events", []).append(message.get("event") or {})
        elif topic == TICK:
            tick.update(message.get("extra") or {})
    if tick is not None:
        yield tick
