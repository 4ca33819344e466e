"""Operator authority: modes after FlexBE's autonomy levels, actions, and input sources.

The operator always outranks the tree. The supervisor is in one of four modes:

``AUTONOMOUS``
    The tree's commands go through the checks and out.
``SUPERVISED``
    Each motion primitive asks :meth:`~pirate_bt.safety.supervisor.Supervisor.request_confirmation`
    before it moves; the tree's commands are refused (``not_confirmed``) unless a
    step has been granted and not yet ended.
``MANUAL``
    The tree is paused (the runner does not tick it and its commands are refused
    with ``tree_paused``); operator commands go through the same checks.
``ESTOP``
    Latched by an e-stop. Nothing but ``Stop`` goes out until an operator resets
    it, which leaves the robot in ``MANUAL``.

An operator acts through :class:`OperatorAction` values. They reach the
supervisor directly (:meth:`~pirate_bt.safety.supervisor.Supervisor.apply`) or
from an :class:`OperatorInput` the supervisor drains at the start of every
tick, so a takeover or a hand-back takes effect before the tree is next
ticked. :class:`ScriptedOperator` is the input used by tests and planner code;
the terminal teleop (``pirate-bt teleop``) is another.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol, runtime_checkable

from pirate_bt.errors import InputError
from pirate_bt.safety.commands import Command
from pirate_bt.units import parse_quantity

__all__ = [
    "Confirm",
    "Confirmation",
    "Deny",
    "EStop",
    "Mode",
    "OperatorAction",
    "OperatorCommand",
    "OperatorInput",
    "ResetEStop",
    "Resume",
    "SafeStop",
    "ScriptedOperator",
    "SetMode",
]


class Mode(StrEnum):
    """Who is in charge (FlexBE's autonomy levels, plus the latched e-stop)."""

    AUTONOMOUS = "autonomous"
    SUPERVISED = "supervised"
    MANUAL = "manual"
    ESTOP = "estop"


class Confirmation(StrEnum):
    """The answer to :meth:`~pirate_bt.safety.supervisor.Supervisor.request_confirmation`."""

    PENDING = "pending"
    GRANTED = "granted"
    DENIED = "denied"


@dataclass(frozen=True, slots=True)
class SetMode:
    """Switch to ``mode`` (takeover = ``MANUAL``, hand-back = ``AUTONOMOUS``/``SUPERVISED``).

    ``ESTOP`` here is the same as :class:`EStop`; leaving ``ESTOP`` needs :class:`ResetEStop`.
    """

    mode: Mode


@dataclass(frozen=True, slots=True)
class EStop:
    """Emergency stop: always passes, stops everything, latches."""

    reason: str = "operator e-stop"


@dataclass(frozen=True, slots=True)
class ResetEStop:
    """Release a latched e-stop; the supervisor comes back in ``MANUAL``."""


@dataclass(frozen=True, slots=True)
class SafeStop:
    """Put the robot in its safe state (drives stopped, clamps held)."""

    reason: str = "operator stop"


@dataclass(frozen=True, slots=True)
class Resume:
    """Leave the safe state (the operator has looked at why it was entered)."""


@dataclass(frozen=True, slots=True)
class Confirm:
    """Grant a pending step (``None``: the oldest one)."""

    step: str | None = None


@dataclass(frozen=True, slots=True)
class Deny:
    """Deny a pending step (``None``: the oldest one)."""

    step: str | None = None


@dataclass(frozen=True, slots=True)
class OperatorCommand:
    """A motion command from the operator (checked like any other)."""

    command: Command


OperatorAction = SetMode | EStop | ResetEStop | SafeStop | Resume | Confirm | Deny | OperatorCommand
"""Everything an operator can do."""


@runtime_checkable
class OperatorInput(Protocol):
    """A source of operator actions, drained by the supervisor at the start of each tick.

    An input may also say whether it can release what it latches (an attribute
    ``releases``, true when absent): one that only stops (the ROS 2 e-stop topic) is
    no operator who could reset an e-stop or resume, so a run does not wait for it
    (:attr:`~pirate_bt.safety.supervisor.Supervisor.operator_attached`).
    """

    def poll(self, tick: int, now_s: float) -> Sequence[OperatorAction]:
        """Actions that are due at supervisor tick ``tick`` / clock time ``now_s``."""
        ...


class ScriptedOperator:
    """Operator actions scheduled by tick number or by clock time.

    Args:
        at_tick: ``(tick, action)`` pairs; an action is due at the start of that tick
            (a whole number).
        at_time: ``(time, action)`` pairs; due at the first tick at or after that time
            (seconds, or a time as text: ``"5 s"``).

    Raises:
        InputError: a pair that is none, a tick that is no whole number or a time that
            is no finite time (checked here: a time as text raised ``TypeError`` out of
            every supervisor tick, and a NaN held back every action after it).

    Example:
        >>> from pirate_bt.safety.operator import Mode, ScriptedOperator, SetMode
        >>> op = ScriptedOperator(at_tick=[(3, SetMode(Mode.MANUAL))])
        >>> op.poll(2, 0.0), op.poll(3, 0.0)
        ([], [SetMode(mode=<Mode.MANUAL: 'manual'>)])
    """

    def __init__(
        self,
        at_tick: Iterable[tuple[int, OperatorAction]] = (),
        at_time: Iterable[tuple[float, OperatorAction]] = (),
    ) -> None:
        ticks = [(_tick(tick), action) for tick, action in _pairs(at_tick, "at_tick")]
        times = [(_time(when), action) for when, action in _pairs(at_time, "at_time")]
        self._by_tick = sorted(ticks, key=lambda p: p[0])
        self._by_time = sorted(times, key=lambda p: p[0])
        self._queue: list[OperatorAction] = []

    def push(self, action: OperatorAction) -> None:
        """Queue ``action`` for the next tick (planner code acting as the operator)."""
        self._queue.append(action)

    def poll(self, tick: int, now_s: float) -> list[OperatorAction]:
        due: list[OperatorAction] = []
        while self._by_tick and self._by_tick[0][0] <= tick:
            due.append(self._by_tick.pop(0)[1])
        while self._by_time and self._by_time[0][0] <= now_s:
            due.append(self._by_time.pop(0)[1])
        due.extend(self._queue)
        self._queue.clear()
        return due

    @property
    def exhausted(self) -> bool:
        """True when every scripted action has been handed out."""
        return not (self._by_tick or self._by_time or self._queue)


def _pairs(items: Iterable[object], name: str) -> list[tuple[object, OperatorAction]]:
    """``items`` as ``(when, action)`` pairs, or a one-line :class:`InputError`."""
    pairs: list[tuple[object, OperatorAction]] = []
    for item in items:
        if not isinstance(item, tuple | list) or len(item) != 2:
            raise InputError(f"{name}: not a (when, action) pair: {item!r}"[:200])
        pairs.append((item[0], item[1]))
    return pairs


def _tick(value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(f"at_tick: {value!r} is not a tick number (a whole number)"[:200])
    return int(value)


def _time(value: object) -> float:
    try:
        return parse_quantity(value, "time", require_unit=False)
    except InputError as exc:
        raise InputError(f"at_time: {exc}"[:200]) from None
