"""Guard nodes: conditions on the robot and pre-conditions on subtrees (the nodes
themselves; :mod:`pirate_bt.behaviours.guards` adds their Python builders and is the
module users and the tree files' registry name).

A trace's header calls every node class of a ``pirate_bt.behaviours.guards*``
module a guard (:mod:`pirate_bt.trace.structure`).

Two kinds of node keep a tree out of trouble before the supervisor has to say no.

**Conditions** are leaves that succeed or fail at once: ``is_clamped`` (a half
holds the pipe, as the supervisor classifies it), ``link_healthy`` (connected,
heard from recently, no e-stop), ``state_fresh`` (the safety readings are
recent) and ``mode_is`` (who is in charge).

**Pre-condition decorators**, after BehaviorTree.CPP's ``_skipIf``,
``_failureIf`` and ``_while``, wrap one child and look at a *declarative*
condition - a comparison, or a list of comparisons that must all hold - before
the child runs:

``skip_if``
    Checked when the child is about to start; true: succeed without ticking the
    child (BT.CPP's "skipped").
``failure_if``
    Checked when the child is about to start; true: fail without ticking it.
``while``
    Checked every tick. False before the child starts: skip (succeed); false
    while it runs: the child is halted and the node *fails*, because a motion
    cut short has not done its job and must not look like success.

If a condition cannot be evaluated (no robot state yet, an unset blackboard key)
the decorator fails: a guard never lets a child through on a guess.

A comparison names a value and compares it with a constant::

    {state: imu.pitch, op: ">", value: 10 deg}
    {state: half.front, op: "==", value: clamped}
    {blackboard: roll, op: "==", value: 90 deg, unit: angle}

State values are a fixed vocabulary (see :data:`STATE_VALUES`); there is no
expression language and nothing is evaluated. A state value's unit is known, so
``value`` carries a unit in files (numbers are SI in Python).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator, Sequence
from typing import Annotated, Any, ClassVar, Literal

import py_trees
from py_trees.common import Status
from pydantic import Field, ValidationInfo, model_validator

from pirate_bt.behaviours.base import (
    COMPARISONS,
    BuildContext,
    GuardDecorator,
    Leaf,
    NodeParams,
    Outcome,
    Scalar,
)
from pirate_bt.behaviours.guard_names import channel_problems, state_problems
from pirate_bt.errors import UnitError, shown
from pirate_bt.robot.description import Half, RobotDescription, SensorKind
from pirate_bt.robot.state import RobotState, wheel_fresh_window_s
from pirate_bt.safety import ClampState, Mode, Supervisor
from pirate_bt.safety.checks import front_tilt_channel, stale_channels
from pirate_bt.safety.supervisor_hold import half_channels
from pirate_bt.units import DIMENSIONS, parse_in_context

__all__ = [
    "STATE_VALUES",
    "Comparison",
    "FailureIf",
    "IsClamped",
    "LinkHealthy",
    "ModeIs",
    "SkipIf",
    "StateFresh",
    "While",
]

_log = logging.getLogger("pirate_bt.behaviours")


STATE_VALUES: dict[str, str | None] = {
    "imu.roll": "angle",
    "imu.pitch": "angle",
    "imu.yaw": "angle",
    "joint_angle.<bend module>": "angle",
    "clamp_force.<bend module>": "force",
    "rotation": "angle",
    "front_tilt": "angle",
    "drive_velocity": "velocity",
    "drive_velocity.<drive motor>": "velocity",
    "motor_current.<motor>": "current",
    "half.front": None,
    "half.rear": None,
    "mode": None,
    "link.healthy": None,
}
"""State values a comparison may name, with their dimension (``None``: a word or a boolean)."""

_WORDS = frozenset(k for k, dim in STATE_VALUES.items() if dim is None)
"""State values that are a word or a boolean: equal or not, never less or more."""

_MISSING = object()


def _dimension(path: str) -> str | None:
    if path in STATE_VALUES:
        return STATE_VALUES[path]
    prefix, dot, rest = path.partition(".")  # pragma: no mutate (every state value has one dot)
    if dot and rest:
        for key, dim in STATE_VALUES.items():
            if key.startswith(prefix + ".<"):
                return dim
    import difflib

    close = difflib.get_close_matches(path, [k for k in STATE_VALUES if "<" not in k], n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise ValueError(
        f"unknown state value {shown(path)}; use one of: {', '.join(sorted(STATE_VALUES))}{hint}"
    )


def _parse(raw: Scalar, dimension: str | None, info: ValidationInfo | None = None) -> Scalar:
    """``raw`` in SI units when it is a quantity; bounded by
    :data:`~pirate_bt.units.MAGNITUDE_LIMITS` where the validation context asks for it
    (a tree file's node, as its other quantities are)."""
    if dimension is None or isinstance(raw, bool):
        return raw
    try:
        context = info.context if info is not None else None
        return parse_in_context(
            raw,
            dimension,
            context,
            require_unit=isinstance(raw, str),  # pragma: no mutate (None acts as False)
        )
    except UnitError as exc:
        raise ValueError(str(exc)) from None


class Comparison(NodeParams):
    """One declarative comparison of a state value or a blackboard key with a constant."""

    state: str | None = Field(None, description="a state value, e.g. imu.pitch or half.front")
    blackboard: str | None = Field(
        None, pattern=r"^/?[A-Za-z_][A-Za-z0-9_./]*$", description="a blackboard key"
    )
    op: Literal["==", "!=", "<", "<=", ">", ">="] = Field("==", description="comparison")
    value: Scalar = Field(description="the constant; a quantity carries its unit in files")
    unit: str | None = Field(
        None, description="for blackboard keys: parse value as a quantity of this dimension"
    )

    @model_validator(mode="before")
    @classmethod
    def _no_is_set(cls, data: Any) -> Any:
        # check_blackboard's op, written without a value: one line, not also 'value'
        if isinstance(data, dict) and data.get("op") == "is_set":
            raise ValueError(
                "op: 'is_set' is check_blackboard's; a guard compares with a value (==, !=,"
                " <, <=, >, >=): to test whether a key is set, use a check_blackboard with"
                " op: is_set"
            )
        return data

    @model_validator(mode="after")
    def _check(self, info: ValidationInfo) -> Comparison:
        if (self.state is None) == (self.blackboard is None):
            raise ValueError("give exactly one of 'state' or 'blackboard'")
        if self.unit is not None and self.unit not in DIMENSIONS:  # not 'dimension: ...'
            raise ValueError(f"unit: {shown(self.unit)} is not one of {', '.join(DIMENSIONS)}")
        dimension = _dimension(self.state) if self.state is not None else self.unit
        if dimension is not None and isinstance(self.value, bool):  # True == 1.0 rad
            raise ValueError(
                f"value: {str(self.value).lower()} is a boolean, but a quantity"
                f" ({dimension.replace('_', ' ')}) is compared: write it with its unit"
            )
        _parse(self.value, dimension, info)
        if self.state == "link.healthy" and not isinstance(self.value, bool):
            raise ValueError(f"value: link.healthy is true or false, not {shown(self.value)}")
        if self.state in _WORDS and self.op not in ("==", "!="):
            raise ValueError(
                f"op: {self.op!r} orders numbers; {self.state} is compared with == or !="
            )
        if self.state in ("half.front", "half.rear") and str(self.value) not in {
            s.value for s in ClampState
        }:
            raise ValueError(f"value: a half is one of {', '.join(s.value for s in ClampState)}")
        if self.state == "mode" and str(self.value) not in {m.value for m in Mode}:
            raise ValueError(f"value: a mode is one of {', '.join(m.value for m in Mode)}")
        return self

    @property
    def si_value(self) -> Scalar:
        """The constant in SI units."""
        dimension = _dimension(self.state) if self.state is not None else self.unit
        return _parse(self.value, dimension)

    @property
    def key(self) -> str | None:
        """The blackboard key without a leading slash (``None`` for state values)."""
        return None if self.blackboard is None else self.blackboard.lstrip("/")

    def __str__(self) -> str:
        what = self.state if self.state is not None else f"blackboard {self.blackboard}"
        return f"{what} {self.op} {self.value}"


def _state_channels(path: str, sup: Supervisor) -> tuple[str, ...]:
    """The state channels whose readings ``path``'s value is made of (none for the mode
    and the link's health; the drives' mean speed is made of the fresh ones)."""
    robot = sup.robot
    prefix, _, rest = path.partition(".")  # pragma: no mutate (every state value has one dot)
    try:
        if prefix == "half":
            return half_channels(robot)[Half(rest)]
        if prefix == "imu":
            imu = robot.imu()
            return () if imu is None else (f"{imu.name}.{rest}",)
        if prefix == "joint_angle":
            return (robot.sensor_of(rest, SensorKind.ANGLE).name,)
        if prefix == "clamp_force":
            return (robot.sensor_of(rest, SensorKind.SPRING).name,)
        if path == "rotation":
            return (robot.sensor_of(robot.rotational_module().name, SensorKind.ANGLE).name,)
        if path == "front_tilt":
            tilt = front_tilt_channel(robot)
            return () if tilt is None else (tilt,)
        if prefix == "drive_velocity" and rest:
            return (f"{rest}.velocity",)
        if prefix == "motor_current":
            return (f"{rest}.current",)
    except (KeyError, ValueError, StopIteration):
        return ()
    return ()


def _stale(path: str, sup: Supervisor) -> str | None:
    """Why ``path``'s reading cannot be believed now (stale), or ``None``.

    A stale reading keeps its last value: a guard that compared it went on a guess (an
    IMU that dropped out kept ``while: imu.pitch < 10 deg`` holding as the robot
    climbed; ``is_clamped`` succeeded on the readings of a board that had gone away).
    """
    state = sup.state()
    if state is None:
        return None
    now = sup.clock.now()
    if path == "drive_velocity":
        names = tuple(f"{m.name}.velocity" for m in sup.robot.drive_motors())
        stale = stale_channels(sup.robot, state, names, now)
        return None if len(stale) < len(names) or not names else _stale_text(stale)
    stale = stale_channels(sup.robot, state, _state_channels(path, sup), now)
    return _stale_text(stale) if stale else None


def _stale_text(stale: list[tuple[str, float]]) -> str:
    return "stale: " + ", ".join(
        f"{name} ({'never' if age == float('inf') else f'{age:.3f} s'})" for name, age in stale
    )


def _fresh_mean_speed(sup: Supervisor, state: RobotState) -> float:
    """The drives' mean measured speed over the wheels that read fresh (odometry's rule)."""
    return state.mean_drive_velocity_mps(
        fresh_since_s=sup.clock.now() - wheel_fresh_window_s(sup.robot)
    )


def _state_value(path: str, sup: Supervisor) -> object:
    if path == "mode":
        return sup.mode.value
    if path == "link.healthy":
        return sup.link_problem() is None
    if path.startswith("half."):
        return sup.half_states()[Half(path.removeprefix("half."))].value
    state: RobotState | None = sup.state()
    if state is None:
        return _MISSING
    prefix, _, rest = path.partition(".")  # pragma: no mutate (every state value has one dot)
    table: Any
    if path == "rotation":
        return _MISSING if state.rotation_rad is None else state.rotation_rad
    if path == "front_tilt":
        return _MISSING if state.front_tilt_rad is None else state.front_tilt_rad
    if path == "drive_velocity":
        return _fresh_mean_speed(sup, state)
    table = {
        "imu": state.imu_rad,
        "joint_angle": state.joint_angle_rad,
        "clamp_force": state.clamp_force_n,
        "drive_velocity": state.drive_velocity_mps,
        "motor_current": state.motor_current_a,
    }.get(prefix)
    if table is None:
        return _MISSING
    return table.get(rest, _MISSING)


class _Evaluator:
    """Evaluates comparisons for one node (owns its blackboard client)."""

    def __init__(self, node: py_trees.behaviour.Behaviour, comparisons: Sequence[Comparison]):
        self.comparisons = list(comparisons)
        self.values = [c.si_value for c in self.comparisons]
        # name=None would name it after the node as well (its first client)
        self.client = node.attach_blackboard_client(
            name=node.name,  # pragma: no mutate (None names a first client the same)
        )
        for c in self.comparisons:
            if c.key is not None:
                self.client.register_key(key=c.key, access=py_trees.common.Access.READ)

    def evaluate(self, sup: Supervisor | None) -> tuple[bool | None, str]:
        """``(all hold, message)``; ``None`` when a value is missing."""
        pairs = zip(
            self.comparisons,
            self.values,
            strict=True,  # pragma: no mutate (one list is made from the other)
        )
        for comparison, constant in pairs:
            if comparison.key is not None:
                if not self.client.exists(comparison.key):
                    return None, f"blackboard {comparison.key} is not set"
                current: object = self.client.get(comparison.key)
            else:
                assert comparison.state is not None
                if sup is None:
                    return None, "no robot attached"
                current = _state_value(comparison.state, sup)
                if current is _MISSING:
                    return None, f"{comparison.state} has no reading"
                stale = _stale(comparison.state, sup)
                if stale is not None:
                    return None, f"{comparison.state} cannot be read: {stale}"
            try:
                ok = COMPARISONS[comparison.op](current, constant)
            except TypeError:
                return None, f"cannot compare {shown(current)} {comparison.op} {shown(constant)}"
            if not ok:
                return False, f"not ({comparison}): it is {shown(current)}"
        return True, " and ".join(str(c) for c in self.comparisons)


def _supervisor(context: BuildContext) -> Supervisor | None:
    sup = context.supervisor
    return sup if isinstance(sup, Supervisor) else None


# -- conditions -------------------------------------------------------------------


class _Condition(Leaf):
    needs_robot: ClassVar[bool] = True

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({"success", "failure"})

    def update(self) -> Status:
        sup = _supervisor(self.context)
        if sup is None:
            self.feedback_message = "no robot attached"
            return Status.FAILURE
        ok, self.feedback_message = self.holds(sup)
        return Status.SUCCESS if ok else Status.FAILURE

    def holds(self, sup: Supervisor) -> tuple[bool, str]:
        raise NotImplementedError


class IsClampedParams(NodeParams):
    half: Half = Field(description="front or rear")


class IsClamped(_Condition):
    """Succeeds when ``half`` is clamped (as the supervisor's invariants see it)."""

    Params = IsClampedParams

    def holds(self, sup: Supervisor) -> tuple[bool, str]:
        half = self.params.half  # type: ignore[attr-defined]
        state = sup.half_states()[half]
        stale = _stale(f"half.{half}", sup)
        if stale is not None:  # the clamp it read may be long gone (a board away)
            return False, f"{half} half {state} by readings that are {stale}"
        return state is ClampState.CLAMPED, f"{half} half {state}"


class LinkHealthy(_Condition):
    """Succeeds when the link is connected, recently heard and not e-stopped."""

    def holds(self, sup: Supervisor) -> tuple[bool, str]:
        problem = sup.link_problem()
        return problem is None, "link healthy" if problem is None else problem.detail


class StateFreshParams(NodeParams):
    channels: list[str] = Field(
        default_factory=list,
        description="channels to check; empty: every reading the safety checks rely on",
    )


class StateFresh(_Condition):
    """Succeeds when the readings are recent (``safety.stale_after_periods`` sensor periods)."""

    Params = StateFreshParams

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        return channel_problems(params.channels, robot)

    def holds(self, sup: Supervisor) -> tuple[bool, str]:
        wanted: list[str] = self.params.channels  # type: ignore[attr-defined]
        if wanted:
            state = sup.state()
            if state is None:
                return False, "no state yet"
            stale = stale_channels(sup.robot, state, tuple(wanted), sup.clock.now())
        else:
            stale = sup.stale_channels()
        if stale:
            return False, "stale: " + ", ".join(name for name, _ in stale)
        return True, "fresh"


class ModeIsParams(NodeParams):
    mode: Mode = Field(description="autonomous, supervised, manual or estop")


class ModeIs(_Condition):
    """Succeeds when the supervisor is in ``mode``."""

    Params = ModeIsParams

    def holds(self, sup: Supervisor) -> tuple[bool, str]:
        mode = self.params.mode  # type: ignore[attr-defined]
        return sup.mode is mode, f"mode {sup.mode}"


# -- pre-condition decorators ------------------------------------------------------


class PreconditionParams(NodeParams):
    condition: Comparison | Annotated[list[Comparison], Field(min_length=1)] = Field(
        description="a comparison, or a list of comparisons that must all hold"
    )

    @property
    def comparisons(self) -> list[Comparison]:
        c = self.condition
        return list(c) if isinstance(c, list) else [c]


class _Precondition(GuardDecorator):
    """Checks a condition before (or while) the child runs; see the module docstring."""

    Params = PreconditionParams
    check_while_running: ClassVar[bool] = False
    needs_robot: ClassVar[bool] = True  # a state: comparison reads the robot

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        return state_problems(params.comparisons, robot)

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        params: PreconditionParams,
        context: BuildContext,
    ) -> None:
        super().__init__(name, child, params, context)
        self.evaluator = _Evaluator(self, params.comparisons)

    @classmethod
    def blackboard_reads(cls, params: Any) -> tuple[str, ...]:
        return tuple(c.key for c in params.comparisons if c.key is not None)

    def short_circuit(self, holds: bool, running: bool) -> Status | None:
        """The status to return instead of ticking the child, or ``None`` to tick it."""
        raise NotImplementedError

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        running = self.status == Status.RUNNING
        if not running:
            self.initialise()
        verdict: Status | None = None
        if not running or self.check_while_running:
            holds, message = self.evaluator.evaluate(_supervisor(self.context))
            self.feedback_message = message
            verdict = Status.FAILURE if holds is None else self.short_circuit(holds, running)
        if verdict is not None:
            self.stop(verdict)  # halts the child if it was running
            self.status = verdict
            yield self
            return
        yield from self.decorated.tick()
        new_status = self.decorated.status
        if new_status != Status.RUNNING:
            self.stop(new_status)
        self.status = new_status
        yield self

    def update(self) -> Status:
        return self.decorated.status


class SkipIf(_Precondition):
    """Succeeds without running the child when the condition holds as it is about to start."""

    def short_circuit(self, holds: bool, running: bool) -> Status | None:
        return Status.SUCCESS if holds else None


class FailureIf(_Precondition):
    """Fails without running the child when the condition holds as it is about to start."""

    def short_circuit(self, holds: bool, running: bool) -> Status | None:
        return Status.FAILURE if holds else None


class While(_Precondition):
    """Runs the child only while the condition holds: skip before, fail (halting it) during."""

    check_while_running: ClassVar[bool] = True

    def short_circuit(self, holds: bool, running: bool) -> Status | None:
        if holds:
            return None
        return Status.FAILURE if running else Status.SUCCESS
