"""Groot2's live protocol (BehaviorTree.CPP 4.10, protocol 2), as bytes: no sockets here.

Groot2 talks to a running tree over ZeroMQ: requests on a REQ/REP pair (port
P, 1667 by default), breakpoint notices on a PUB socket (port P + 1). Every
request is a multipart message whose first part is a 6-byte header, all
integers little-endian:

=======  ===========================================================
bytes    content
=======  ===========================================================
1        protocol, ``2``
1        request type, one ASCII letter (:class:`RequestType`)
4        request id, chosen by the client (unsigned 32-bit)
=======  ===========================================================

A reply's first part is 22 bytes: the request's header echoed (protocol set
to 2) and the tree's 16-byte UUID, new for every tree a server serves. The
other parts depend on the request:

- ``T`` (full tree): the tree as BT.CPP XML, every node with its ``_uid``,
  every subtree with its ``_fullpath``.
- ``S`` (status): 3 bytes per node, the node's UID (16 bits) and its status:
  0 IDLE, 1 RUNNING, 2 SUCCESS, 3 FAILURE, 4 SKIPPED, and 10 + s for "was s,
  now IDLE" (BT.CPP resets a node to IDLE when its parent finishes).
- ``B`` (blackboard; a second part ``name;name;...`` of subtree instances):
  MessagePack of ``{name: {key: value}}``.
- ``r`` (recording; a second part ``start`` or ``stop``): ``start`` answers the
  server's time in microseconds since 1970, as text.
- ``t`` (transitions since the last ``t``, recorded after a ``start``): 9 bytes
  each, 6 of microseconds since the start, 2 of node UID, 1 of the new status.
- ``I``, ``R``, ``U`` (insert, remove a hook; unlock a breakpoint; a second
  part of JSON), ``D`` (the hooks, as JSON), ``A`` (remove every hook), ``X``
  (disable every hook): no other part.

A request the server cannot answer gets a two-part reply, ``error`` and a
message: ``wrong request header`` (a first part that is not 6 bytes), ``must
be 2 parts message``, ``Request not recognized``, ``Node ID not found``, or
what went wrong reading the JSON. A breakpoint reached is published on the PUB
socket as a request header of type ``N`` and the node's UID as text.
"""

from __future__ import annotations

import enum
import json
import os
import struct
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Final

__all__ = [
    "DEFAULT_PORT",
    "ERROR",
    "HEADER_SIZE",
    "IDLE_FROM",
    "NOT_FOUND",
    "NOT_RECOGNIZED",
    "PROTOCOL",
    "REPLY_HEADER_SIZE",
    "STATUS_NAMES",
    "TWO_PARTS",
    "WRONG_HEADER",
    "Hook",
    "HookError",
    "RequestHeader",
    "RequestType",
    "hooks_json",
    "new_tree_uuid",
    "pack_request",
    "pack_transitions",
    "parse_hooks",
    "parse_remove",
    "parse_unlock",
    "reply_header",
    "routing_envelope",
    "unpack_reply_header",
    "unpack_request",
]

PROTOCOL: Final = 2
DEFAULT_PORT: Final = 1667
"""BT.CPP's default server port; the PUB socket is the next one."""
HEADER_SIZE: Final = 6
REPLY_HEADER_SIZE: Final = 22
ERROR: Final = b"error"
WRONG_HEADER: Final = "wrong request header"
TWO_PARTS: Final = "must be 2 parts message"
NOT_RECOGNIZED: Final = "Request not recognized"
NOT_FOUND: Final = "Node ID not found"
IDLE_FROM: Final = 10
"""A node's status code is ``IDLE_FROM + s`` when it went back to IDLE from ``s``."""
STATUS_NAMES: Final = ("IDLE", "RUNNING", "SUCCESS", "FAILURE", "SKIPPED")
"""BT.CPP's ``NodeStatus`` names by value."""

_HEADER = struct.Struct("<BBI")


class RequestType(enum.IntEnum):
    """The request types (``Monitor::RequestType``), one ASCII letter each."""

    FULLTREE = ord("T")
    STATUS = ord("S")
    BLACKBOARD = ord("B")
    HOOK_INSERT = ord("I")
    HOOK_REMOVE = ord("R")
    BREAKPOINT_REACHED = ord("N")
    BREAKPOINT_UNLOCK = ord("U")
    HOOKS_DUMP = ord("D")
    REMOVE_ALL_HOOKS = ord("A")
    DISABLE_ALL_HOOKS = ord("X")
    TOGGLE_RECORDING = ord("r")
    GET_TRANSITIONS = ord("t")


@dataclass(frozen=True, slots=True)
class RequestHeader:
    """The 6-byte header: protocol, type (any byte: unknown types get an error), id."""

    protocol: int
    type: int
    unique_id: int


def pack_request(kind: int, unique_id: int | None = None, protocol: int = PROTOCOL) -> bytes:
    """A request header (a random id when none is given)."""
    if unique_id is None:
        unique_id = int.from_bytes(os.urandom(4), "little")
    return _HEADER.pack(protocol, kind, unique_id)


def unpack_request(data: bytes) -> RequestHeader | None:
    """The header of a request's first part, or ``None`` when it is not 6 bytes."""
    if len(data) != HEADER_SIZE:
        return None
    return RequestHeader(*_HEADER.unpack(data))


def reply_header(request: RequestHeader, tree_uuid: bytes) -> bytes:
    """A reply's 22-byte first part: the request echoed (protocol 2) and the tree's UUID."""
    return _HEADER.pack(PROTOCOL, request.type, request.unique_id) + tree_uuid


def unpack_reply_header(data: bytes) -> tuple[RequestHeader, bytes]:
    """``(the echoed request, the tree's UUID)`` of a reply's first part.

    Raises:
        ValueError: not 22 bytes.
    """
    if len(data) != REPLY_HEADER_SIZE:
        raise ValueError(f"a reply header is {REPLY_HEADER_SIZE} bytes, not {len(data)}")
    return RequestHeader(*_HEADER.unpack(data[:HEADER_SIZE])), data[HEADER_SIZE:]


def new_tree_uuid() -> bytes:
    """16 random bytes marked as a version-4 UUID, as BT.CPP makes one per tree served."""
    raw = bytearray(os.urandom(16))
    raw[8] = (raw[8] & 0xBF) | 0x80  # variant 10xxxxxx
    raw[6] = (raw[6] & 0x4F) | 0x40  # version 0100xxxx
    return bytes(raw)


def pack_transitions(transitions: Iterable[tuple[int, int, int]]) -> bytes:
    """``(microseconds, uid, status)`` triples as 9 bytes each (6 + 2 + 1)."""
    out = bytearray()
    for time_us, uid, status in transitions:
        out += (time_us & 0xFFFF_FFFF_FFFF).to_bytes(6, "little")
        out += struct.pack("<HB", uid, status)
    return bytes(out)


class HookError(ValueError):
    """A hook request that cannot be read (its message is the error reply's)."""


@dataclass(slots=True)
class Hook:
    """One hook, as Groot2 sends it (``Monitor::Hook``).

    Attributes:
        uid: The node.
        position: 0 before the node's tick (PRE), 1 after it (POST).
        mode: 0 a breakpoint (the tree waits until Groot2 unlocks it), 1 replace
            the node's result with ``desired_status`` without waiting.
        enabled: Disabled hooks do nothing.
        once: Remove the hook once it has fired.
        desired_status: The result to give instead of the node's (``SUCCESS`` or
            ``FAILURE``; anything else lets the node run).
    """

    uid: int
    position: int = 0
    mode: int = 0
    enabled: bool = True
    once: bool = False
    desired_status: str = "SKIPPED"
    ready: bool = False
    """A breakpoint was unlocked (and may pass)."""

    def to_json(self) -> dict[str, Any]:
        """As BT.CPP's ``to_json(Hook)``."""
        return {
            "enabled": self.enabled,
            "uid": self.uid,
            "mode": self.mode,
            "once": self.once,
            "desired_status": self.desired_status,
            "position": self.position,
        }

    def update(self, other: Hook) -> None:
        """Take ``other``'s settings (an insert for a hook that exists)."""
        self.enabled, self.mode, self.once = other.enabled, other.mode, other.once
        self.desired_status, self.position = other.desired_status, other.position


def _field(data: Mapping[str, Any], key: str, kind: type) -> Any:
    if key not in data:
        raise HookError(f"hook: key '{key}' not found")
    value = data[key]
    if kind is int and isinstance(value, float) and value.is_integer():
        # a whole number written as one (5.0: JSON has one kind of number, and a client
        # in JavaScript or Python may write it so); BT.CPP's nlohmann reads it as 5, and
        # until 2026-11-30 this refused it
        return int(value)
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise HookError(f"hook: '{key}' must be {kind.__name__}, not {json.dumps(value)[:40]}")
    return value


def _uid(data: Mapping[str, Any]) -> int:
    uid = _field(data, "uid", int)
    if not 0 <= uid <= 0xFFFF:
        raise HookError(f"hook: uid {uid} is not a 16-bit node UID")
    return int(uid)


def _position(data: Mapping[str, Any]) -> int:
    position = _field(data, "position", int)
    if position not in (0, 1):
        raise HookError(f"hook: position {position} is neither 0 (pre) nor 1 (post)")
    return int(position)


_DIGITS_READ = 4300
"""The longest integer read (Python's limit for converting text to an integer)."""


def _integer(text: str) -> int:
    if len(text) > _DIGITS_READ:  # no UID, position or mode: named, not Python's advice
        digits = len(text.lstrip("-"))
        raise HookError(f"hook: a number of {digits} digits is no UID, position or mode")
    return int(text)


def _load(text: bytes) -> Any:
    try:
        # an integer of more than 4,300 digits said "not JSON: Exceeds the limit (4300
        # digits) for integer string conversion: ... use sys.set_int_max_str_digits() to
        # increase the limit", advice for Python to the client's user, until 2026-11-30
        return json.loads(text.decode("utf-8"), parse_int=_integer)
    except HookError:
        raise
    except (UnicodeDecodeError, ValueError) as exc:
        raise HookError(f"not JSON: {exc}") from None
    except RecursionError:  # [[[[...]]]] nested deeper than the parser goes
        raise HookError("not JSON: nested too deep") from None


def parse_hooks(text: bytes) -> list[Hook]:
    """The hook(s) of an insert request (one JSON object, or an array of them).

    Raises:
        HookError: not JSON, a missing or mistyped field, an unknown status.
    """
    data = _load(text)
    items = data if isinstance(data, list) else [data]
    hooks: list[Hook] = []
    for item in items:
        if not isinstance(item, dict):
            raise HookError("hook: a JSON object with uid, position, mode, ...")
        status = _field(item, "desired_status", str)
        if status not in STATUS_NAMES:
            raise HookError(f"hook: desired_status {status!r} is not a node status")
        mode = _field(item, "mode", int)
        if mode not in (0, 1):
            raise HookError(f"hook: mode {mode} is neither 0 (breakpoint) nor 1 (replace)")
        hooks.append(
            Hook(
                uid=_uid(item),
                position=_position(item),
                mode=int(mode),
                enabled=bool(_field(item, "enabled", bool)),
                once=bool(_field(item, "once", bool)),
                desired_status=status,
            )
        )
    return hooks


def parse_unlock(text: bytes) -> tuple[int, int, str, bool]:
    """``(uid, position, status, remove)`` of an unlock request; the status is
    ``SUCCESS``, ``FAILURE`` or ``SKIPPED`` (anything else: the node runs).

    Raises:
        HookError: not JSON, a missing or mistyped field.
    """
    data = _load(text)
    if not isinstance(data, dict):
        raise HookError("unlock: a JSON object with uid, position, desired_status, ...")
    status = _field(data, "desired_status", str)
    remove = _field(data, "remove_when_done", bool)
    return (
        _uid(data),
        _position(data),
        status if status in ("SUCCESS", "FAILURE") else ("SKIPPED"),
        bool(remove),
    )


def parse_remove(text: bytes) -> tuple[int, int]:
    """``(uid, position)`` of a remove request.

    Raises:
        HookError: not JSON, a missing or mistyped field.
    """
    data = _load(text)
    if not isinstance(data, dict):
        raise HookError("remove: a JSON object with uid and position")
    return _uid(data), _position(data)


def hooks_json(hooks: Sequence[Hook]) -> bytes:
    """The hooks dump: a JSON array, compact, keys sorted (as ``nlohmann::json::dump``)."""
    return json.dumps([h.to_json() for h in hooks], sort_keys=True, separators=(",", ":")).encode(
        "utf-8"
    )


def routing_envelope(parts: Sequence[bytes]) -> list[bytes] | None:
    """The routing envelope of a message read off the ROUTER socket, as REP keeps it for
    the reply: the parts up to the first empty one (the REQ socket's delimiter) and that
    one; ``None`` when there is none, or no request after it."""
    for index in range(1, len(parts) - 1):
        if not parts[index]:
            return list(parts[: index + 1])
    return None
