"""What a navigator sees and says: :class:`Observation` in, :class:`Step` out.

A *navigator* is planner code that drives the robot one PAB at a time (see
:func:`pirate_bt.navigate` and docs/navigators.md). Before every step it is handed
an :class:`Observation` (where the robot believes it is, what it felt since the last
step, how that step ended, the map if there is one, the clock) and answers with the
next :class:`Step`, or ``None`` when it is done::

    class Forward:
        def next_step(self, obs: Observation) -> Step | None:
            if obs.last is not None and obs.last.outcome != "success":
                return None
            return Step("straight", distance="1 m") if obs.step < 3 else None

A step names a PAB with its parameters, written as in the YAML trees and on the
command line (text with a unit, or SI numbers):

======================================  ===============================================
``Step("straight", distance="1 m")``    drive along the straight pipe (negative: back);
                                        ``slow=True`` at the inspection speed;
                                        ``stop_at_feature=True`` (no map) also stops
                                        early where a turn blocks the robot or the
                                        front half is over an opening;
                                        ``stop_at_change=True`` (no map) where the
                                        slope or the diameter changes
``Step("bend", direction="right")``     pass the bend ahead (``up``, ``down``,
                                        ``left``, ``right``, or ``roll="90 deg"``;
                                        with a map a roll must be the bend's, and
                                        ``Step("bend")`` takes it whichever way)
``Step("t-joint", direction="left")``   pass the T-joint ahead (``left``, ``right``,
                                        ``up``, ``down``, ``straight``)
``Step("wait", time="2 s")``            stand still, clamped
``Step("probe-turn")``                  no map: where a straight step stopped blocked,
                                        find which way the pipe turns (``obs.felt``:
                                        a ``bend`` with its direction) or that it
                                        ends there (an ``end``); refused anywhere else
``Step("probe-tee")``                   no map: where a straight step stopped over an
                                        opening, find which side the tee's branch
                                        leaves on (``obs.felt``: a ``tee`` with that
                                        side); it ends before the tee, so a
                                        ``t-joint`` step goes on from there
``Step("bend-back", direction="right")`` no map: back through the bend the robot
                                        passed (its direction as met forwards);
                                        refused with no bend behind it
``Step("t-joint-back", direction=...)``  no map: back through the T-joint the robot
                                        passed (``straight``, or out of the branch
                                        it turned into: ``left``, ``right``, ``up``,
                                        ``down``); refused with no tee behind it
======================================  ===============================================

:func:`check_step` checks a step before anything moves (an unknown PAB, a missing or
malformed parameter, a value out of range); with a map, the step is also planned on
it from where the robot is (a turn where the map has no bend is refused there), and
with none it is checked on what the steps so far passed (:class:`BlindTrail`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from pirate_bt.errors import InputError, UnitError
from pirate_bt.errors import shown as said_briefly
from pirate_bt.task.navigate_planner import call_within, raised_at, raised_on_purpose
from pirate_bt.task.observation import Ahead, Belief, Felt, Observation, OffWall
from pirate_bt.task.route import MAX_WAIT_S
from pirate_bt.units import parse_quantity, plain_number

__all__ = [
    "STEP_PABS",
    "Ahead",
    "Belief",
    "BlindTrail",
    "CheckedStep",
    "Decision",
    "Felt",
    "InvalidStep",
    "Navigator",
    "Observation",
    "OffWall",
    "Step",
    "call_within",
    "check_step",
    "raised_at",
    "raised_on_purpose",
    "shown",
]

STEP_PABS = (
    "straight",
    "bend",
    "t-joint",
    "wait",
    "probe-turn",
    "probe-tee",
    "bend-back",
    "t-joint-back",
)
"""The PABs a step may name."""

_BEND_ROLL_DEG = {"up": 0.0, "right": 90.0, "down": 180.0, "left": -90.0}
_TEE_WAYS = ("left", "right", "straight", "up", "down")
_MAX_DISTANCE_M = 1000.0
_MAX_WAIT_S = MAX_WAIT_S
_KNOWN: dict[str, tuple[str, ...]] = {
    "straight": ("distance", "slow", "stop_at_feature", "stop_at_change"),
    "bend": ("direction", "roll"),
    "t-joint": ("direction",),
    "wait": ("time",),
    "probe-turn": (),
    "probe-tee": (),
    "bend-back": ("direction", "roll"),
    "t-joint-back": ("direction",),
}
_BACK_WAYS = ("left", "right", "up", "down", "straight")
_BLIND_ONLY = ("probe-turn", "probe-tee", "bend-back", "t-joint-back")
"""Steps a map does not plan: probes, and the backward PABs (not in the route language)."""


ENTRY_SLACK_M = 0.05
"""How far past the entry (by the belief) a step with no map may back: odometry's own
error over a run, so that backing to the start is not refused."""


class InvalidStep(InputError):
    """A navigator asked for a step that cannot be run (named in the message)."""


def shown(value: object, limit: int = 80) -> str:
    """``repr(value)`` for a message, at most ``limit`` characters: whatever a navigator
    hands over is shown, never raised on (an integer past Python's limit for turning
    one into text, a broken ``__repr__``)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 128:
        return f"<an integer of about {round(value.bit_length() * math.log10(2))} digits>"
    try:
        text = repr(value)
    except Exception:  # a __repr__ that raises
        text = f"<{type(value).__name__} that cannot be shown>"
    if text.startswith("<") and " at 0x" in text:  # object's own: its type, not its address
        return said_briefly(value)
    return text if len(text) <= limit else f"{text[: limit - 3]}..."


def _name(key: str) -> str:
    """A step parameter's name as a ``repr`` shows it: as written, or quoted and cut
    (one of 100,000 characters was shown whole, twice, in an invalid step's why)."""
    return key if key.isidentifier() and len(key) <= 40 else shown(key, 40)


def _json_value(value: object) -> bool | int | float | str:
    """A step parameter as a trace record holds it: a number or text (an integer too
    large for a float, or any other object, as text)."""
    if isinstance(value, bool | float | str):
        return value
    if isinstance(value, int):
        return value if -(2**63) <= value < 2**63 else shown(value)
    try:
        return str(value)
    except Exception:  # a __str__ that raises
        return shown(value)


@dataclass(frozen=True, init=False)
class Step:
    """One PAB with its parameters: what a navigator asks the robot to do next.

    Attributes:
        pab: One of :data:`STEP_PABS` (``straight``, ``bend``, ``t-joint``, ``wait``;
            with no map also ``probe-turn``, ``probe-tee``, ``bend-back``,
            ``t-joint-back``).
        params: Its parameters as given (``{"distance": "1 m"}``), a NumPy scalar or
            0-d array as the Python number, truth value or text it stands for
            (``numpy.float32(0.3)`` a distance in metres, as ``0.3`` is: it was
            recorded as the text ``"0.3"``, with no unit, and ``numpy.array(0.2)``
            refused as *'0.2' needs a unit*).
    """

    pab: str
    params: Mapping[str, Any]

    def __init__(self, pab: str, /, **params: Any) -> None:
        object.__setattr__(self, "pab", pab)
        object.__setattr__(self, "params", {k: plain_number(v) for k, v in params.items()})

    def __repr__(self) -> str:
        args = "".join(f", {_name(k)}={shown(v)}" for k, v in self.params.items())
        return f"Step({shown(self.pab)}{args})"

    def __hash__(self) -> int:  # a value, as frozen says: a set of steps, a dict's key
        return hash((self.pab, frozenset(self.params.items())))

    def to_json(self) -> dict[str, Any]:
        """``{"pab": ..., "params": {...}}`` with every value as text or a number."""
        return {
            "pab": self.pab,
            "params": {k: _json_value(v) for k, v in self.params.items()},
        }


@dataclass(frozen=True)
class CheckedStep:
    """A step whose parameters were checked, in SI units.

    Attributes:
        step: The step as the navigator gave it.
        distance_m: ``straight``: metres (negative backwards).
        slow: ``straight``: at the inspection speed.
        stop_at_feature: ``straight``: stop early at a turn or an opening.
        stop_at_change: ``straight``: stop early where the slope (the IMU's mean pitch, by
            0.25 degrees) or the diameter (a leading joint, by 2 mm over 40 mm) changes.
        roll_rad: ``bend``, ``bend-back``: the roll of the bend's plane (``nan``: a
            ``bend`` with neither, the map's next bend whichever way it turns).
        direction: ``bend``, ``t-joint`` and their backward twins: the direction
            word, when one was given.
        time_s: ``wait``: seconds.
    """

    step: Step
    distance_m: float = 0.0
    slow: bool = False
    stop_at_feature: bool = False
    stop_at_change: bool = False
    roll_rad: float = 0.0
    direction: str | None = None
    time_s: float = 0.0

    def check_blind(self, belief_m: float, trail: BlindTrail | None = None) -> None:
        """Refuse a step with no map that cannot do what it says where the robot is.

        With no map the belief is measured from where the robot was put in (0 m): the
        mouth is behind it there, and backing past it would take the robot out of the
        pipe (the simulator holds it at the mouth while its wheels turn, so odometry
        would count distance never driven), as a planned route refuses it with a map.
        A bend with neither direction nor roll needs a map to say which way it turns.
        With the ``trail`` of what the steps so far passed: ``probe-turn`` only where a
        straight stopped blocked, and ``bend-back`` (``t-joint-back``) only with a bend
        (a tee) passed and not backed through yet (:class:`BlindTrail`).
        """
        if self.step.pab == "bend" and math.isnan(self.roll_rad):
            raise InvalidStep(f"{self.step!r}: with no map, give the bend's direction or roll")
        if trail is not None:
            trail.check(self.step, belief_m)
        if self.step.pab in ("bend-back", "t-joint-back") and belief_m <= ENTRY_SLACK_M:
            # nothing the robot passed is behind it, only the mouth: the PAB backed it
            # against the mouth for 3 m of wheels turning, and the belief drifted by that
            raise InvalidStep(f"{self.step!r}: {_NOTHING_PASSED.format(at=belief_m)}")
        if self.step.pab != "straight" or self.distance_m >= 0:
            return
        if belief_m + self.distance_m < -ENTRY_SLACK_M:
            raise InvalidStep(
                f"{self.step!r}: the robot can back up at most {max(belief_m, 0.0):.2f} m"
                " here: the pipe's entry, where it was put in, is behind it"
            )

    def route_line(self) -> str:
        """The step as a line of the route language (docs/missions.md)."""
        pab = self.step.pab
        if pab == "straight":
            if self.stop_at_change:
                raise InvalidStep(
                    f"{self.step!r}: stop_at_change is for a pipe with no map (a survey);"
                    " with a map, the legs stop at the map's features"
                )
            verb = "forward" if self.distance_m >= 0 else "back"
            slowly = " slowly" if self.slow else ""
            return f"{verb} {_number(abs(self.distance_m))} m{slowly}"
        if pab == "bend":  # a roll, or none: the next bend (a roll is checked on the plan)
            return f"at the bend turn {self.direction or ''}".rstrip()
        if pab == "t-joint":
            return f"at the T-joint go {self.direction}"
        if pab in ("probe-turn", "probe-tee"):
            raise InvalidStep(
                f"{self.step!r}: with a map the turns are on it; {pab} is for"
                " navigating without one"
            )
        if pab in _BLIND_ONLY:
            raise InvalidStep(
                f"{self.step!r}: with a map, {pab} is not planned yet (the route"
                " language has no backward PABs); it is for navigating without one"
            )
        return f"pause {_number(self.time_s)} s"


def _number(value: float) -> str:
    """``value`` for a route line: to 0.1 mm (or ms), as the plans name it, but never
    rounded to zero or far off: a step of 1e-05 m was planned as '0.0000 m' and refused
    with *'0.0000 m' must be more than zero*, though it is not and runs with no map."""
    return f"{value:.4f}" if value >= 1e-3 else repr(value)


_NOTHING_PASSED = (
    "the robot has passed nothing since it was put in (at {at:.2f} m): the pipe's entry"
    " is behind it, no bend or tee"
)
"""Why a backward PAB is refused when no step has passed a bend or a tee."""


@dataclass
class BlindTrail:
    """What the steps with no map have passed since the robot was put in: what the
    preconditions of ``probe-turn``, ``bend-back`` and ``t-joint-back`` are checked on.

    Attributes:
        behind: The bends and tees passed forwards and not backed through yet, oldest
            first (``"bend"``, ``"tee"``).
        passed: How many of each were passed forwards, in all.
        blocked: The robot stands where a forward straight stopped blocked (only a
            ``wait`` or a ``probe-turn``, which ends where it began, ran since).
        last: The last step that ran, and what it felt.
    """

    behind: list[str] = field(default_factory=list)
    passed: dict[str, int] = field(default_factory=dict)
    blocked: bool = False
    last: tuple[Step, tuple[Felt, ...]] | None = None

    def note(self, checked: CheckedStep, felt: Sequence[Felt], off_wall: bool) -> None:
        """A step succeeded, having felt ``felt``; ``off_wall``: a bend joint swung off
        the wall during it (an opening: a straight may drive through a tee's run)."""
        pab = checked.step.pab
        self.last = (checked.step, tuple(felt))
        passed = {"bend": "bend", "t-joint": "tee"}.get(pab)
        if pab == "straight" and checked.distance_m > 0 and off_wall:
            passed = "tee"  # crossed, or reached, an opening: never refuse backing through it
        if passed is not None:
            self.behind.append(passed)
            self.passed[passed] = self.passed.get(passed, 0) + 1
        elif pab in ("bend-back", "t-joint-back"):  # through the newest of its kind
            kind = "bend" if pab == "bend-back" else "tee"
            if kind in self.behind:  # and past whatever was passed after it
                del self.behind[len(self.behind) - 1 - self.behind[::-1].index(kind) :]
        if pab not in ("wait", "probe-turn"):  # those end where they began
            self.blocked = (
                pab == "straight"
                and checked.distance_m > 0
                and any(f.kind == "feature" and f.how == "blocked" for f in felt)
            )

    def check(self, step: Step, belief_m: float) -> None:
        """Refuse ``step`` before it moves when what it needs is not where the robot is.

        Raises:
            InvalidStep: ``probe-turn`` where no straight stopped blocked (in open pipe
                it finds a turn that is not there), ``bend-back`` with no bend behind
                the robot, ``t-joint-back`` with no tee (it backs the robot against
                the pipe's mouth while its wheels turn).
        """
        if step.pab == "probe-turn" and not self.blocked:
            raise InvalidStep(f"{step!r}: {self._not_blocked(belief_m)}")
        kind = {"bend-back": "bend", "t-joint-back": "tee"}.get(step.pab)
        if kind is None or kind in self.behind:
            return
        if not self.passed:
            raise InvalidStep(f"{step!r}: {_NOTHING_PASSED.format(at=belief_m)}")
        since = (
            f"it has passed no {kind} since it was put in"
            if kind not in self.passed
            else f"it has backed past every {kind} it passed since it was put in"
        )
        raise InvalidStep(
            f"{step!r}: no {kind} is behind the robot to back through (at {belief_m:.2f} m):"
            f" {since}"
        )

    def _not_blocked(self, belief_m: float) -> str:
        if self.last is None:
            where = (
                f"no straight has stopped blocked since the robot was put in (at {belief_m:.2f} m)"
            )
        else:
            step, felt = self.last
            where = (
                f"the robot is not where a straight stopped blocked (at {belief_m:.2f} m,"
                f" after {step!r}"
            )
            if any(f.kind == "feature" and f.how == "opening" for f in felt):
                where += ", which stopped over an opening: probe-tee finds its branch"
            where += ")"
        return (
            f"{where}: probe-turn finds the way on where a straight with stop_at_feature"
            " stopped blocked; in open pipe it would answer with a turn that is not there"
        )


def _quantity(step: Step, key: str, dimension: str, example: str) -> float:
    value = step.params.get(key)
    if value is None:
        raise InvalidStep(f"{step!r}: {step.pab} needs {key} (e.g. {key}={example!r})")
    if isinstance(value, bool):
        raise InvalidStep(f"{step!r}: {key} must be a {dimension}, not {value!r}")
    if isinstance(value, numbers.Real):  # a NumPy number too (np.float32(0.3))
        try:
            number = float(value)
        except OverflowError:  # an integer too large for a float
            raise InvalidStep(
                f"{step!r}: {key} must be a finite number, not {shown(value)}"
            ) from None
    else:
        try:
            number = parse_quantity(str(value), dimension)
        except UnitError as exc:
            raise InvalidStep(f"{step!r}: {key}: {exc}") from None
        except Exception:  # an object whose text cannot be had
            said = f"{step!r}: {key} must be a {dimension}, not {shown(value)}"
            raise InvalidStep(said) from None
    if not math.isfinite(number):
        raise InvalidStep(f"{step!r}: {key} must be a finite number, not {shown(value)}")
    return number


def _flag(step: Step, key: str) -> bool:
    value = step.params.get(key, False)
    kind = type(value)
    if kind.__module__ == "numpy" and kind.__name__ in ("bool", "bool_"):
        return bool(value)  # a NumPy comparison's answer, as a NumPy number is a distance
    if not isinstance(value, bool):
        raise InvalidStep(f"{step!r}: {key} must be true or false, not {shown(value)}")
    return value


def plain(step: Step) -> Step:
    """``step`` as a plain :class:`Step` of its own (a subclass's own ``__repr__``, a PAB
    name of a ``str`` subclass with its own ``__eq__``, are left behind: one that raised
    ended the navigation with a bare exception, out of ``navigate()``), with a copy of
    its parameters: a navigator that edits the step it gave (or one in ``obs.history``)
    changes nothing recorded (every decision read as the last edit)."""
    pab = str.__str__(step.pab) if isinstance(step.pab, str) else step.pab
    return Step(pab, **dict(step.params))


def check_step(step: object) -> CheckedStep:
    """Check a step's PAB and parameters; its values in SI units.

    Raises:
        InvalidStep: not a :class:`Step`, an unknown PAB or parameter, a missing or
            malformed value, or one out of range; the message names the step.
    """
    if not isinstance(step, Step):
        raise InvalidStep(f"a navigator returned {shown(step)}, not a Step (or None when done)")
    step = plain(step)
    if not isinstance(step.pab, str) or step.pab not in STEP_PABS:
        known = ", ".join(STEP_PABS)
        raise InvalidStep(f"{step!r}: unknown PAB {shown(step.pab)} (known: {known})")
    unknown = sorted(set(step.params) - set(_KNOWN[step.pab]))
    if unknown:
        raise InvalidStep(
            f"{step!r}: {step.pab} has no parameter {shown(unknown[0], 40)}"
            f" (it takes {', '.join(_KNOWN[step.pab])})"
        )
    if step.pab == "straight":
        distance = _quantity(step, "distance", "length", "1 m")
        if distance == 0 or abs(distance) > _MAX_DISTANCE_M:
            raise InvalidStep(
                f"{step!r}: distance must be non-zero and at most {_MAX_DISTANCE_M:.0f} m"
            )
        return CheckedStep(
            step,
            distance_m=distance,
            slow=_flag(step, "slow"),
            stop_at_feature=_flag(step, "stop_at_feature"),
            stop_at_change=_flag(step, "stop_at_change"),
        )
    if step.pab in ("bend", "bend-back"):
        direction = step.params.get("direction")
        if direction is not None and "roll" in step.params:
            raise InvalidStep(f"{step!r}: give direction or roll, not both")
        if direction is None and "roll" not in step.params and step.pab == "bend":
            return CheckedStep(step, roll_rad=math.nan)  # with a map: its next bend
        if direction is None:
            roll = _quantity(step, "roll", "angle", "90 deg")
            if abs(roll) > math.pi + 1e-9:
                raise InvalidStep(f"{step!r}: roll must be within -180 and 180 deg")
            return CheckedStep(step, roll_rad=roll)
        if not isinstance(direction, str) or direction not in _BEND_ROLL_DEG:
            raise InvalidStep(
                f"{step!r}: a bend turns up, down, left or right, not {shown(direction)}"
            )
        return CheckedStep(
            step, roll_rad=math.radians(_BEND_ROLL_DEG[direction]), direction=direction
        )
    if step.pab == "t-joint":
        direction = step.params.get("direction")
        if not isinstance(direction, str) or direction not in _TEE_WAYS:
            raise InvalidStep(
                f"{step!r}: a T-joint is left by {', '.join(_TEE_WAYS)}, not {shown(direction)}"
            )
        return CheckedStep(step, direction=str(direction))
    if step.pab == "t-joint-back":
        direction = step.params.get("direction")
        if not isinstance(direction, str) or direction not in _BACK_WAYS:
            raise InvalidStep(
                f"{step!r}: a T-joint is left backwards by the way it was passed"
                f" ({', '.join(_BACK_WAYS)}), not {shown(direction)}"
            )
        return CheckedStep(step, direction=str(direction))
    if step.pab in ("probe-turn", "probe-tee"):
        return CheckedStep(step)
    seconds = _quantity(step, "time", "time", "2 s")
    if not 0 < seconds <= _MAX_WAIT_S:
        raise InvalidStep(f"{step!r}: time must be positive and at most {_MAX_WAIT_S:.0f} s")
    return CheckedStep(step, time_s=seconds)


@dataclass(frozen=True)
class Decision:
    """One answer of the navigator, as recorded.

    Attributes:
        index: 1 for the first decision.
        observation: What the navigator was told.
        step: What it answered (``None``: done, or it failed).
        seconds: Wall time it took to answer.
        error: Why the answer was refused (it raised, was late, or was invalid).
        outcome: How the step ended (``success``, ``failure``...), once it ran.
    """

    index: int
    observation: Observation
    step: Step | None
    seconds: float
    error: str | None = None
    outcome: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "index": self.index,
            "observation": self.observation.to_json(),
            "step": self.step.to_json()
            if isinstance(self.step, Step)
            else (None if self.step is None else shown(self.step, 200)),
            "seconds": round(self.seconds, 6),
            "error": self.error,
            "outcome": self.outcome,
            # an answer that ran no step (done, raised, late, invalid) has no step trace,
            # and its why is its error; a step run overwrites both
            "trace": None,
            "why": self.error,
        }


@runtime_checkable
class Navigator(Protocol):
    """Planner code that chooses the robot's next step from what it felt.

    It may also have ``check_map(map: Network | None) -> None``, called by
    :func:`~pirate_bt.api.navigation.navigate` (and a campaign) before anything
    connects: a ``ValueError`` it raises refuses a map it cannot use as bad input.
    """

    def next_step(self, obs: Observation) -> Step | None:
        """The next step, or ``None`` when the navigation is done."""
        ...
