"""Faults the simulator injects, written in a network file or on the command line.

In a network file faults are a list under ``faults:`` (see
:class:`~pirate_bt.pipes.model.FaultSpec`). On the command line and in Python a
fault is one short string::

    KIND[:TARGET]@AT[+DURATION]

    motor_stall:bend_1_drive@3s+2s      a drive motor blocked for 2 s from t = 3 s
    sensor_dropout:bend_3_spring@5s     a spring sensor that stops reporting
    sensor_stuck:rotation_angle@1s+4s   a sensor frozen at its value for 4 s
    board_reset:22@10s                  board 22 reboots (motors off, no readings)
    link_loss@12s+500ms                 nothing in or out for half a second

Times are quantities with units. These faults act on the simulated boards and
physics; the link layer's byte faults (drop, corrupt, duplicate, delay) are
added on the host side through the URL (``?faults=...``).
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, get_args

from pirate_bt.errors import ArgumentTypeError, ConfigurationError, InputError, UnitError, shown
from pirate_bt.pipes.model import FaultKind, FaultSpec
from pirate_bt.units import parse_quantity

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription

__all__ = [
    "FAULT_KINDS",
    "MAX_FAULT_TEXT",
    "NO_TARGET_KINDS",
    "FaultTargetError",
    "check_fault_target",
    "format_fault",
    "parse_fault",
    "write_fault",
]


class FaultTargetError(ConfigurationError, InputError):
    """A fault names a motor, state channel or board the robot does not have.

    A :class:`~pirate_bt.errors.ConfigurationError` (a network file's faults and the
    robot it runs do not fit together) and an :class:`~pirate_bt.errors.InputError`
    (a ``faults=`` argument or ``--faults`` option that is bad input); exit code 2.
    """


def _known(names: list[str]) -> str:
    return ", ".join(names[:12]) + (f", ... ({len(names)} in all)" if len(names) > 12 else "")


def check_fault_target(fault: FaultSpec, robot: RobotDescription) -> None:
    """Check that a fault's target exists on ``robot`` (the rule the simulator applies).

    Raises:
        FaultTargetError: an unknown motor, state channel or board, with the known ones;
            a target on a kind that takes none (:data:`NO_TARGET_KINDS`).
    """
    target = fault.target
    if fault.kind in NO_TARGET_KINDS:
        if target is not None:
            raise FaultTargetError(
                f"fault {fault.kind} takes no target ({target!r}): write {fault.kind}@AT"
            )
        return
    if fault.kind == "motor_stall":
        noun, plural, names = "motor", "motors", [m.name for _, m in robot.motors()]
        found = target in names
    elif fault.kind in ("sensor_dropout", "sensor_stuck"):
        noun, plural = "state channel", "channels"
        names = [c.name for c in robot.state_channels()]
        found = target in names
    elif fault.kind in ("board_reset", "board_fault"):
        boards = robot.board_ids()
        noun, plural, names = "board", "boards", [str(b) for b in boards]
        found = (
            target is not None
            and target.isascii()
            and target.isdigit()
            and int(target) in boards  # '022' is board 22
        )
    else:
        return
    if target is None:  # a network file's fault written without one
        raise FaultTargetError(
            f"fault {fault.kind} needs a target: a {noun} ({plural}: {_known(names)})"
        )
    if not found:
        raise FaultTargetError(
            f"fault {fault.kind}: unknown {noun} {target!r} ({plural}: {_known(names)})"
        )


FAULT_KINDS: tuple[str, ...] = get_args(FaultKind)
NO_TARGET_KINDS: tuple[str, ...] = ("link_loss",)
"""The fault kinds that take no target (they act on the whole link, not on one part)."""

_FAULT_RE = re.compile(
    r"^\s*(?P<kind>[a-z_]+)(?::(?P<target>[A-Za-z0-9_.]+))?\s*@\s*(?P<at>[^+]+?)"
    r"(?:\s*\+\s*(?P<duration>.+?))?\s*$"
)


MAX_FAULT_TEXT = 200
"""The longest fault text (``motor_stall:bend_3_drive@5s+20s`` is 31)."""


def parse_fault(text: str, *, option: str = "faults") -> FaultSpec:
    """Parse ``KIND[:TARGET]@AT[+DURATION]`` into a :class:`FaultSpec`.

    Args:
        text: The fault, e.g. ``"board_reset:22@10s"``.
        option: Where the text came from, starting every message (``faults``: the
            API's ``faults=`` and the command line's ``--faults``; ``""``: none, for
            a caller that locates the error itself).

    Returns:
        The fault.

    Raises:
        InputError: malformed text, an unknown kind, a missing target (or a target on a
            kind that takes none, :data:`NO_TARGET_KINDS`) or a bad time;
            text longer than :data:`MAX_FAULT_TEXT` (an ``ArgumentTypeError``: not text).
    """
    prefix = f"{option}: " if option else ""
    if not isinstance(text, str):
        raise ArgumentTypeError(f"{prefix}a simulator fault is text, not {shown(text)}")
    if len(text) > MAX_FAULT_TEXT:
        raise InputError(
            f"{prefix}a fault of {len(text)} characters is too long (at most {MAX_FAULT_TEXT})"
        )
    match = _FAULT_RE.match(text)
    if match is None:
        raise InputError(prefix + _what_is_wrong(text))
    kind = match["kind"]
    if kind not in FAULT_KINDS:
        raise InputError(
            f"{prefix}unknown fault kind {shown(kind)}; known: {', '.join(FAULT_KINDS)}"
        )
    target = match["target"]
    if kind in NO_TARGET_KINDS:
        if target is not None:
            raise InputError(
                f"{prefix}fault {kind} takes no target, so {shown(text)} is bad; write"
                f" {kind}@AT[+DURATION]"
            )
    elif target is None:
        then = f"+{match['duration']}" if match["duration"] else ""
        raise InputError(
            f"{prefix}fault {kind} needs a target: {write_fault(kind, then, match['at'])}"
        )
    try:
        at = parse_quantity(match["at"], "time")
        duration = (
            parse_quantity(match["duration"], "time") if match["duration"] is not None else None
        )
    except UnitError as exc:
        raise InputError(f"{prefix}bad fault {shown(text)}: {exc}") from None
    if at < 0:
        raise InputError(f"{prefix}bad fault {shown(text)}: its time must not be negative")
    if duration is not None and duration <= 0:
        raise InputError(f"{prefix}bad fault {shown(text)}: its duration must be positive")
    return FaultSpec(kind=kind, at=at, duration=duration, target=target)


# The parts of a fault whatever they hold (an empty target, time or duration), to say
# which is missing where _FAULT_RE does not match.
_PARTS_RE = re.compile(
    r"^\s*(?P<kind>[A-Za-z_]+)(?P<colon>:(?P<target>[^@+]*))?\s*@\s*(?P<at>[^+]*?)"
    r"\s*(?P<plus>\+\s*(?P<duration>.*?))?\s*$"
)

# A target each kind of simulator fault takes, for the examples (the bundled robot's).
_EXAMPLE_TARGETS = {
    "motor_stall": "bend_1_drive",
    "sensor_dropout": "bend_3_spring",
    "sensor_stuck": "rotation_angle",
    "board_reset": "22",
    "board_fault": "22",
}


def write_fault(kind: str, then: str = "", at: str = "") -> str:
    """How to write a simulator fault of ``kind`` (its duration ``then`` and time ``at``,
    where given), with an example: ``write board_reset:BOARD@AT[+DURATION], e.g.
    board_reset:22@5s`` (the wording of ``pirate_bt.api.fault_text``)."""
    form = then or "[+DURATION]"
    at = at or "5s"
    if kind in NO_TARGET_KINDS:
        return f"write {kind}@AT{form}, e.g. {kind}@{at}{then}"
    noun = "BOARD" if kind.startswith("board_") else "NAME"
    target = _EXAMPLE_TARGETS.get(kind, noun)
    return f"write {kind}:{noun}@AT{form}, e.g. {kind}:{target}@{at}{then}"


def _what_is_wrong(text: str) -> str:
    """What a fault ``_FAULT_RE`` does not match lacks (its target, its time, its
    duration after ``+``), with an example of its own kind."""
    parts = _PARTS_RE.match(text)
    if parts is None or parts["kind"] not in FAULT_KINDS:
        if parts is not None:
            return f"unknown fault kind {shown(parts['kind'])}; known: {', '.join(FAULT_KINDS)}"
        return f"bad fault {shown(text)}; write KIND[:TARGET]@AT[+DURATION], e.g. link_loss@5s+1s"
    kind, target, at = parts["kind"], (parts["target"] or "").strip(), parts["at"]
    then = f"+{parts['duration']}" if parts["duration"] else ""
    if kind in NO_TARGET_KINDS and parts["colon"]:
        return (
            f"fault {kind} takes no target, so {shown(text)} is bad; {write_fault(kind, then, at)}"
        )
    lacks = []
    if kind not in NO_TARGET_KINDS and not target:
        lacks.append("its target")
    if not at:
        lacks.append("its time")
    if parts["plus"] and not parts["duration"]:
        lacks.append("its duration after '+'")
    if lacks:
        what = " and ".join([", ".join(lacks[:-1]), lacks[-1]] if len(lacks) > 1 else lacks)
        if target and kind not in NO_TARGET_KINDS:  # their own target in the example
            written = f"{kind}:{target}"
            form = then or "[+DURATION]"
            how = f"write {written}@AT{form}, e.g. {written}@{at or '5s'}{then or ''}"
            if parts["plus"] and not parts["duration"]:
                how = f"write {written}@AT+DURATION, e.g. {written}@{at or '5s'}+1s"
        elif parts["plus"] and not parts["duration"]:
            how = write_fault(kind, "+1s", at).replace("@AT+1s", "@AT+DURATION", 1)
        else:
            how = write_fault(kind, then, at)
        return f"simulator fault {shown(text)} lacks {what}: {how}"
    return (
        f"bad fault {shown(text)}: its target {shown(target)} is not a name (letters,"
        f" digits, '_', '.'); {write_fault(kind, then, at)}"
    )


def format_fault(fault: FaultSpec) -> str:
    """The text form of a fault (inverse of :func:`parse_fault`)."""
    target = f":{fault.target}" if fault.target else ""
    duration = f"+{fault.duration:g}s" if fault.duration is not None else ""
    return f"{fault.kind}{target}@{fault.at:g}s{duration}"
