"""The encoding half of the trace's writer process: tick messages to JSON text.

Split out of :mod:`pirate_bt.trace.sink` (which re-exports every name here, and
whose docstring describes the messages): how values are rounded and spelled
(:func:`encode_value`, :func:`round_value`, :func:`nonfinite_text`,
:data:`encode_json`), the flat state names of a layout (:func:`layout_names`),
the change trackers (:class:`StateDiff`, :class:`FieldChanges`,
:class:`CounterChanges`) and :class:`TickEncoder`, which turns a ``TICK`` message
into a tick record's line.

Like the rest of the writer process, this module needs only the standard library
and imports nothing from ``pirate_bt``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from enum import Enum
from itertools import compress, repeat
from operator import is_not, itemgetter, ne
from typing import Any, cast

__all__ = [
    "DECIMALS",
    "SINGLES",
    "VIEWS",
    "CounterChanges",
    "FieldChanges",
    "StateDiff",
    "TickEncoder",
    "encode_json",
    "encode_str",
    "encode_value",
    "layout_names",
    "nonfinite_text",
    "round_value",
    "rounded_json",
    "value_json",
]

# Floats in state, link and counter values are rounded to this many decimals:
# 1 µrad, 1 µm/s, 1 µN are far below any sensor's resolution, and rounding
# keeps noise in the last bits from counting as a change.
DECIMALS = 6

_INF = float("inf")
_MISSING: Any = object()
_first = itemgetter(0)
_second = itemgetter(1)
_concat = str.__add__

# One encoder built once: json.dumps with keyword arguments builds a new JSONEncoder
# on every call. Records hold fresh plain data (no cycles), so the check is skipped.
encode_json = json.JSONEncoder(
    separators=(",", ":"), ensure_ascii=False, allow_nan=False, check_circular=False
).encode
"""Any JSON value as compact text, non-ASCII kept, non-finite numbers refused."""
encode_str = json.encoder.encode_basestring
"""A ``str`` as JSON text, non-ASCII kept (what :data:`encode_json` does, in C)."""

_NUMBERS_MAX = 1 << 16
"""Most raw floats a :class:`StateDiff` keeps the rounded value and text of."""


# --- values ------------------------------------------------------------------------


def nonfinite_text(value: float) -> str:
    """How the trace spells a number strict JSON has no spelling for: ``nan``, ``inf``, ``-inf``."""
    return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")


def round_value(value: float) -> float | str:
    """A float rounded to 6 decimals; ``nan``, ``inf``, ``-inf`` as those strings."""
    return round(value, DECIMALS) if math.isfinite(value) else nonfinite_text(value)


def encode_value(value: Any) -> Any:
    """A state, health or counter value as JSON data: floats rounded (non-finite as strings)."""
    kind = type(value)
    if kind is float:
        return round(value, DECIMALS) if -_INF < value < _INF else round_value(value)
    if kind is int or kind is bool or kind is str or value is None:
        return value
    if isinstance(value, Enum):
        return encode_value(value.value)
    if isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):  # a float subclass, such as numpy's float64
        return round_value(float(value))
    if isinstance(value, Mapping):
        return {str(k): encode_value(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [encode_value(v) for v in value]
    try:
        return repr(value)
    except Exception as exc:  # a planner's feedback object whose __repr__ raises
        return f"<{type(value).__name__}: not recorded: {type(exc).__name__}>"


def rounded_json(value: Any) -> tuple[Any, str]:
    """``value`` as :func:`encode_value` gives it, and that as JSON text."""
    encoded = encode_value(value)
    return encoded, repr(encoded) if type(encoded) is float else encode_json(encoded)


def value_json(value: Any) -> str:
    """A feedback message as a JSON string: text as it is, anything else a behaviour
    set (a number, an object) as its ``str()`` (the trace's feedback is text, and a
    reader refuses other kinds; an int 42 was written as the number 42)."""
    if type(value) is str:
        return encode_str(value)
    try:
        text = str(value)
    except Exception as exc:  # a planner's feedback object whose __str__ raises
        text = f"<{type(value).__name__}: not recorded: {type(exc).__name__}>"
    return encode_str(text)


# --- state -------------------------------------------------------------------------

VIEWS = ("joint_angle_rad", "clamp_force_n", "imu_rad", "drive_velocity_mps", "motor_current_a")
"""The role-based views of a state snapshot, in the order of a layout."""
SINGLES = ("rotation_rad", "camera_tilt_rad", "camera_pan_rad", "front_tilt_rad")
"""The single values of a state snapshot, after the views."""


def layout_names(keys: Sequence[str | None], readings: bool) -> list[str]:
    """Flat state names (``joint_angle_rad.bend_1``...) for a state layout.

    A layout is the key of every view in :data:`VIEWS` order, each view ended by
    ``None``, then (with ``readings``) the channel names; the raw values that go
    with it are the views' values, the :data:`SINGLES`, then the channels'.
    """
    names: list[str] = []
    views = iter(VIEWS)
    view = next(views)
    for index, key in enumerate(keys):
        if key is None:
            view = next(views, "")
            if not view:  # past the last view: the readings, if any
                names += SINGLES
                if readings:
                    names += [f"readings.{name}" for name in keys[index + 1 :]]
                break
        else:
            names.append(f"{view}.{key}")
    return names


class StateDiff:
    """The flat state values that changed since they were last recorded.

    Fed a layout (when it changes) and a tuple of raw values, it returns the
    values that differ from the last recorded ones after rounding: a raw change
    that rounds to the recorded value is noise, not a change, and a value that
    stops being reported (``None``) is not a change either. An unchanged tuple
    costs one tuple comparison; otherwise only the values that moved are looked
    at, in C loops (``map``, ``compress``), with their rounded value and JSON
    text taken from a cache, since readings are quantised and values recur.
    """

    def __init__(self, readings: bool = False) -> None:
        self.readings = readings
        self.values: dict[str, Any] = {}
        """Flat name -> last recorded (rounded) value."""
        self.names: tuple[str, ...] = ()
        self._members: tuple[str, ...] = ()
        self._raw: tuple[Any, ...] = ()
        self._last: list[Any] = []
        self._numbers: dict[float, tuple[Any, str]] = {}

    def set_layout(self, keys: Sequence[str | None]) -> None:
        """A new layout (first snapshot, or a sensor appeared): every value is looked at."""
        self.names = tuple(layout_names(keys, self.readings))
        self._members = tuple([encode_str(name) + ":" for name in self.names])
        self._last = [self.values.get(name, _MISSING) for name in self.names]
        self._raw = ()

    def diff(self, raw: tuple[Any, ...]) -> tuple[list[int], list[Any], list[str]]:
        """Record ``raw``; the indices, rounded values and JSON texts of what changed."""
        previous = self._raw
        if raw == previous:
            return [], [], []
        self._raw = raw
        if len(previous) != len(raw):
            previous = (_MISSING,) * len(raw)
        indices = list(compress(range(len(raw)), map(ne, raw, previous)))
        moved = list(map(raw.__getitem__, indices))
        hits: list[tuple[Any, str] | None] = list(map(self._numbers.get, moved))
        if None in hits:
            hits = list(map(self._number, moved))
            if None in hits:  # a value no longer reported (None) is not a change
                present = list(map(is_not, hits, repeat(None)))
                indices = list(compress(indices, present))
                hits = list(compress(hits, present))
        found = cast(list[tuple[Any, str]], hits)
        last = self._last
        rounded = list(map(_first, found))
        fresh = list(map(ne, rounded, map(last.__getitem__, indices)))
        if False in fresh:
            indices = list(compress(indices, fresh))
            rounded = list(compress(rounded, fresh))
            found = list(compress(found, fresh))
        for index, value in zip(indices, rounded, strict=True):
            last[index] = value
        self.values.update(zip(map(self.names.__getitem__, indices), rounded, strict=True))
        return indices, rounded, list(map(_second, found))

    def diff_json(self, raw: tuple[Any, ...]) -> str:
        """:meth:`diff` as the members of a JSON object (``"name":value,...``), or ``""``."""
        indices, _, texts = self.diff(raw)
        return ",".join(map(_concat, map(self._members.__getitem__, indices), texts))

    def full_json(self, raw: tuple[Any, ...]) -> str:
        """Every reported value (the ``full_state`` option), recording them as well."""
        self.diff(raw)
        parts = [
            self._members[index] + rounded_json(value)[1]
            for index, value in enumerate(raw)
            if value is not None
        ]
        return ",".join(parts)

    def _number(self, value: Any) -> tuple[Any, str] | None:
        if value is None:
            return None
        # Only finite, non-zero floats are cached: 0.0 == -0.0 would share one spelling,
        # nan never equals itself, and an int would take the spelling of an equal float.
        if type(value) is float and -_INF < value < _INF and value:
            numbers = self._numbers
            if len(numbers) >= _NUMBERS_MAX:
                numbers.clear()
            rounded = round(value, DECIMALS)
            hit = numbers[value] = (rounded, repr(rounded))
            return hit
        return rounded_json(value)


class FieldChanges:
    """The values of a fixed list of named fields that changed since the last call.

    For link health, which the trace reads every tick but which changes rarely:
    the raw values arrive as one tuple, so an unchanged reading costs one tuple
    comparison, and only fields whose raw value differs are encoded (floats
    rounded) and compared with what was recorded.

    Args:
        names: The field names, in the order of the tuples given to :meth:`changes`.
    """

    def __init__(self, names: Sequence[str]) -> None:
        self.names = tuple(names)
        self.values: dict[str, Any] = {}
        """Field name -> last recorded (encoded) value."""
        self._raw: tuple[Any, ...] = (_MISSING,) * len(self.names)

    def changes(self, raw: tuple[Any, ...]) -> dict[str, Any]:
        """Record ``raw`` (one value per name) and return the encoded values that changed."""
        previous = self._raw
        if raw == previous:
            return {}
        self._raw = raw
        moved = compress(zip(self.names, raw, strict=True), map(ne, raw, previous))
        return _record(self.values, moved)


class CounterChanges:
    """Simulator counters (name -> number) that changed; names may come and go."""

    def __init__(self) -> None:
        self.values: dict[str, Any] = {}
        """Counter name -> last recorded (encoded) value."""
        self._raw: dict[Any, Any] = {}

    def changes(self, sim: Mapping[Any, Any]) -> dict[str, Any]:
        """Record ``sim`` and return the encoded values that changed (possibly empty)."""
        raw = self._raw
        if sim == raw:
            return {}
        keys = list(compress(list(sim), map(ne, sim.values(), map(raw.get, sim, repeat(_MISSING)))))
        raw.update(zip(keys, map(sim.__getitem__, keys), strict=True))
        names = [key if type(key) is str else str(key) for key in keys]
        return _record(self.values, zip(names, map(sim.__getitem__, keys), strict=True))


def _record(values: dict[str, Any], moved: Iterable[tuple[str, Any]]) -> dict[str, Any]:
    """Encode the raw values that moved; keep and return those that differ from ``values``."""
    changed: dict[str, Any] = {}
    for name, value in moved:
        encoded = encode_value(value)
        if values.get(name, _MISSING) != encoded:
            values[name] = encoded
            changed[name] = encoded
    return changed


# --- tick records ------------------------------------------------------------------


class TickEncoder:
    """Turns tick messages into tick records' JSON text (``None``: nothing to write).

    Args:
        node_ids: Path ids of the tree's nodes, depth first.
        link_fields: Names of the fields of the link-health tuples
            (``pirate_bt.trace.records.LINK_FIELDS``).
        every_tick: Give a line for every tick, even one where nothing changed.
        full_state: Give every state value in every tick that has a state.
        readings: The state layouts include the raw channels.
    """

    def __init__(
        self,
        node_ids: Sequence[str],
        *,
        link_fields: Sequence[str],
        every_tick: bool = False,
        full_state: bool = False,
        readings: bool = False,
    ) -> None:
        self.every_tick = every_tick
        self.full_state = full_state
        # Encoded once: each node's '"<id>":' member name, and its status members.
        self._members = [encode_str(node_id) + ":" for node_id in node_ids]
        self._status = [{code: f'{member}"{code}"' for code in "SFRI"} for member in self._members]
        self.state = StateDiff(readings=readings)
        self._link = FieldChanges(link_fields)
        self._sim = CounterChanges()

    def encode(self, message: Sequence[Any]) -> str | None:
        """The line for one ``TICK`` message, ``\\n``-terminated, or ``None``."""
        (_, n, t_s, status, feedback, bb, keys, raw, commands, link, sim, events) = message
        parts: list[str] = []
        if status:
            tables = self._status
            members = [tables[index][code] for index, code in status]
            parts.append(',"status":{' + ",".join(members) + "}")
        if feedback:
            names = self._members
            members = [names[index] + value_json(text) for index, text in feedback]
            parts.append(',"feedback":{' + ",".join(members) + "}")
        if bb:
            parts.append(bb)
        if keys is not None:
            self.state.set_layout(keys)
        if raw is not None:
            if self.full_state:
                parts.append(',"state":{' + self.state.full_json(raw) + '},"full":true')
            else:
                members_text = self.state.diff_json(raw)
                if members_text:
                    parts.append(',"state":{' + members_text + "}")
        if commands:
            parts.append(',"commands":[' + ",".join(commands) + "]")
        if link is not None:
            changed = self._link.changes(tuple(link))
            if changed:
                parts.append(',"link":' + encode_json(changed))
        if sim is not None:
            changed = self._sim.changes(sim)
            if changed:
                parts.append(',"sim":' + encode_json(changed))
        if events:
            parts.append(events)
        if not parts and not self.every_tick:
            return None
        t_s = round(t_s, DECIMALS)
        time_text = repr(t_s) if type(t_s) is float and -_INF < t_s < _INF else encode_json(t_s)
        return f'{{"type":"tick","n":{n},"t_s":{time_text}{"".join(parts)}}}\n'
