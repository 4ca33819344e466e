"""Generic leaves and decorators that need no robot.

These make trees useful and testable before any hardware node exists: fixed
outcomes (``success``, ``failure``, ``running``), a ``wait`` and a ``timeout`` on the
injected clock (py_trees' own Timeout reads the wall clock, so it is replaced
here), declarative blackboard writes and checks (a key, an operator and a value;
never an expression), a ``log`` line, a ``scripted`` leaf that plays a list of
statuses (for tests and demos), and thin adapters that put py_trees'
decorators (retry, repeat, inverter, oneshot, status converters) under the node
contract of :mod:`pirate_bt.behaviours.base`.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable
from typing import Any, ClassVar, Literal

import py_trees
from py_trees.common import Status
from pydantic import Field, StrictInt, ValidationInfo, model_validator

from pirate_bt.behaviours.base import (
    ALL_OUTCOMES,
    COMPARISONS,
    BuildContext,
    GuardDecorator,
    Leaf,
    NodeKind,
    NodeMixin,
    NodeParams,
    NoParams,
    Outcome,
    Scalar,
)
from pirate_bt.errors import UnitError, shown
from pirate_bt.units import Duration, parse_in_context

__all__ = [
    "CheckBlackboard",
    "Failure",
    "FailureIsRunning",
    "FailureIsSuccess",
    "Inverter",
    "Log",
    "OneShot",
    "Repeat",
    "Retry",
    "Running",
    "RunningIsFailure",
    "RunningIsSuccess",
    "Scripted",
    "SetBlackboard",
    "Success",
    "SuccessIsFailure",
    "SuccessIsRunning",
    "Timeout",
    "Wait",
]

_log = logging.getLogger("pirate_bt.trees")

_STATUS: dict[str, Status] = {
    "success": Status.SUCCESS,
    "failure": Status.FAILURE,
    "running": Status.RUNNING,
}


# -- fixed outcomes -----------------------------------------------------------


class _Fixed(Leaf):
    RESULT: ClassVar[Outcome] = "success"

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({cls.RESULT})

    def update(self) -> Status:
        return _STATUS[self.RESULT]


class Success(_Fixed):
    """Always succeeds."""

    RESULT = "success"


class Failure(_Fixed):
    """Always fails."""

    RESULT = "failure"


class Running(_Fixed):
    """Always running (never finishes on its own)."""

    RESULT = "running"


# -- time -----------------------------------------------------------------------


class WaitParams(NodeParams):
    duration: Duration = Field(ge=0, description="how long to wait (e.g. '2 s', '250 ms')")


class Wait(Leaf):
    """Running until ``duration`` has passed on the injected clock, then success."""

    Params = WaitParams

    def __init__(self, name: str, params: WaitParams, context: BuildContext) -> None:
        super().__init__(name, params, context)
        self.duration_s = params.duration
        self._start_s = math.nan

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({"success", "running"})

    def initialise(self) -> None:
        self._start_s = self.context.clock.now()

    def update(self) -> Status:
        elapsed_s = self.context.clock.now() - self._start_s
        if elapsed_s >= self.duration_s:
            return Status.SUCCESS
        self.feedback_message = f"{elapsed_s:.3f}/{self.duration_s:.3f} s"
        return Status.RUNNING


class TimeoutParams(NodeParams):
    duration: Duration = Field(gt=0, description="fail if the child runs longer than this")


class Timeout(GuardDecorator):
    """Fails (and stops its child) when the child runs longer than ``duration``.

    Unlike ``py_trees.decorators.Timeout`` it reads the injected clock, so it
    behaves the same in simulated time.
    """

    Params = TimeoutParams

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        params: TimeoutParams,
        context: BuildContext,
    ) -> None:
        super().__init__(name, child, params, context)
        self.duration_s = params.duration
        self._finish_s = math.inf
        self.timed_out_at_s: float | None = None
        """Clock time the child was stopped for running too long (a run's why reads it)."""

    @classmethod
    def decorated_outcomes(
        cls, params: Any, child_outcomes: frozenset[Outcome]
    ) -> frozenset[Outcome]:
        return child_outcomes | {"failure"} if "running" in child_outcomes else child_outcomes

    def initialise(self) -> None:
        self._finish_s = self.context.clock.now() + self.duration_s
        self.timed_out_at_s = None

    def update(self) -> Status:
        status: Status = self.decorated.status
        now = self.context.clock.now()
        if status == Status.RUNNING and now >= self._finish_s:
            self.feedback_message = (
                f"timed out after {self.duration_s:g} s: {self.decorated.name} was still running"
            )
            self.timed_out_at_s = now
            return Status.FAILURE
        return status


# -- blackboard -------------------------------------------------------------------

Dimension = Literal[
    "length",
    "time",
    "angle",
    "velocity",
    "angular_velocity",
    "acceleration",
    "force",
    "torque",
    "frequency",
    "current",
    "dimensionless",
]


def _value(raw: Scalar, dimension: str | None, info: ValidationInfo | None = None) -> Scalar:
    """``raw`` in SI units when it is a quantity (``dimension``); bounded by
    :data:`~pirate_bt.units.MAGNITUDE_LIMITS` where the validation context asks for it
    (a tree file's node, as its other quantities are)."""
    if dimension is None:
        return raw
    try:
        context = info.context if info is not None else None
        return parse_in_context(raw, dimension, context, require_unit=isinstance(raw, str))
    except UnitError as exc:
        raise ValueError(str(exc)) from None


class SetBlackboardParams(NodeParams):
    key: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", description="key")
    value: Scalar = Field(description="the value; a quantity with its unit if 'unit' is given")
    unit: Dimension | None = Field(
        None, description="parse value as a quantity of this dimension, stored in SI"
    )

    @model_validator(mode="after")
    def _parse(self, info: ValidationInfo) -> SetBlackboardParams:
        _value(self.value, self.unit, info)
        return self

    @property
    def si_value(self) -> Scalar:
        return _value(self.value, self.unit)


class SetBlackboard(Leaf):
    """Writes ``value`` to blackboard ``key`` and succeeds."""

    Params = SetBlackboardParams

    def __init__(self, name: str, params: SetBlackboardParams, context: BuildContext) -> None:
        super().__init__(name, params, context)
        self.key = params.key
        self.value = params.si_value
        self.blackboard = self.attach_blackboard_client(name=name)
        self.blackboard.register_key(key=self.key, access=py_trees.common.Access.WRITE)

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({"success"})

    @classmethod
    def blackboard_writes(cls, params: Any) -> tuple[str, ...]:
        return (params.key,)

    def update(self) -> Status:
        self.blackboard.set(self.key, self.value, overwrite=True)
        return Status.SUCCESS


class CheckBlackboardParams(NodeParams):
    key: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", description="key")
    op: Literal["==", "!=", "<", "<=", ">", ">=", "is_set"] = Field(
        "==", description="comparison; 'is_set' only checks that the key has a value"
    )
    value: Scalar | None = Field(None, description="the value to compare with")
    unit: Dimension | None = Field(None, description="parse value as a quantity (SI)")

    @model_validator(mode="after")
    def _check(self, info: ValidationInfo) -> CheckBlackboardParams:
        if self.op != "is_set" and self.value is None:
            raise ValueError(f"op {self.op!r} needs a value")
        if self.value is not None:
            _value(self.value, self.unit, info)
        return self


class CheckBlackboard(Leaf):
    """Succeeds when ``key`` compares true with ``value``; fails otherwise or when unset."""

    Params = CheckBlackboardParams

    def __init__(self, name: str, params: CheckBlackboardParams, context: BuildContext) -> None:
        super().__init__(name, params, context)
        self.key = params.key
        self.op = params.op
        self.value = None if params.value is None else _value(params.value, params.unit)
        self.blackboard = self.attach_blackboard_client(name=name)
        self.blackboard.register_key(key=self.key, access=py_trees.common.Access.READ)

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({"success", "failure"})

    @classmethod
    def blackboard_reads(cls, params: Any) -> tuple[str, ...]:
        return (params.key,)

    def update(self) -> Status:
        if not self.blackboard.exists(self.key):
            self.feedback_message = f"{self.key} is not set"
            return Status.FAILURE
        if self.op == "is_set":
            return Status.SUCCESS
        current = self.blackboard.get(self.key)
        try:
            ok = COMPARISONS[self.op](current, self.value)
        except TypeError:
            # 5 < '9': a number compared with text (an XML value without json:) is
            # never true; the failure says why rather than only "False"
            hint = (
                " (a number written as text? write json:9 in XML, 9 in YAML)"
                if {type(current), type(self.value)} & {str}
                and {type(current), type(self.value)} & {int, float}
                else ""
            )
            self.feedback_message = (
                f"{self.key}={shown(current)} {self.op} {shown(self.value)}: cannot compare"
                f" {type(current).__name__} with {type(self.value).__name__}{hint}"
            )
            return Status.FAILURE
        self.feedback_message = f"{self.key}={current!r} {self.op} {self.value!r}: {ok}"
        return Status.SUCCESS if ok else Status.FAILURE


# -- messages and scripts -----------------------------------------------------------


# a log line is read by people: longer text is a mistake (or a hostile file), refused at
# load rather than logged, kept in the node and copied into every trace that shows it
LOG_MESSAGE_MAX = 10_000


class LogParams(NodeParams):
    message: str = Field(
        max_length=LOG_MESSAGE_MAX,
        description=f"text to log (at most {LOG_MESSAGE_MAX:,} characters)",
    )
    level: Literal["debug", "info", "warning", "error"] = Field("info", description="log level")


# the control characters shown as their escapes: all but a line break and a tab
_SHOWN_ESCAPED = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")


class Log(Leaf):
    """Logs ``message`` (logger ``pirate_bt.trees``) and succeeds."""

    Params = LogParams

    def __init__(self, name: str, params: LogParams, context: BuildContext) -> None:
        super().__init__(name, params, context)
        # a terminal shows what is logged: an escape sequence in a tree file's message
        # (clear the screen, colour, a carriage return over the line) is shown as text
        # (one pass over the text, not a string per character)
        self.message = _SHOWN_ESCAPED.sub(lambda m: repr(m.group())[1:-1], params.message)
        self.level = logging.getLevelName(params.level.upper())

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset({"success"})

    def update(self) -> Status:
        _log.log(self.level, "%s", self.message)
        self.feedback_message = self.message
        return Status.SUCCESS


class ScriptedParams(NodeParams):
    statuses: list[Literal["success", "failure", "running"]] = Field(
        min_length=1, description="statuses returned on successive ticks"
    )
    then: Literal["hold", "cycle"] = Field(
        "hold", description="after the list: keep returning the last status, or start again"
    )


class Scripted(Leaf):
    """Returns ``statuses`` one per tick over the whole run (for tests and demos)."""

    Params = ScriptedParams

    def __init__(self, name: str, params: ScriptedParams, context: BuildContext) -> None:
        super().__init__(name, params, context)
        self.script = [_STATUS[s] for s in params.statuses]
        self.cycle = params.then == "cycle"
        self._index = 0

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return frozenset(params.statuses)

    def update(self) -> Status:
        if self._index >= len(self.script):
            self._index = 0 if self.cycle else len(self.script) - 1
        status = self.script[self._index]
        self._index += 1
        return status


# -- py_trees decorators under the node contract ------------------------------------


def _child(child: py_trees.behaviour.Behaviour | None, name: str) -> py_trees.behaviour.Behaviour:
    if child is None:
        raise ValueError(f"decorator {name!r} needs a child")
    return child


class _Adapter(NodeMixin):
    kind: ClassVar[NodeKind] = "decorator"
    MAP: ClassVar[dict[Outcome, Outcome]] = {}

    @classmethod
    def from_params(
        cls,
        name: str,
        params: Any,
        context: BuildContext,
        child: py_trees.behaviour.Behaviour | None = None,
    ) -> py_trees.behaviour.Behaviour:
        factory: Callable[..., py_trees.behaviour.Behaviour] = cls  # type: ignore[assignment]
        return factory(name=name, child=_child(child, name), **cls._kwargs(params))

    @classmethod
    def _kwargs(cls, params: Any) -> dict[str, Any]:
        return {}

    @classmethod
    def decorated_outcomes(
        cls, params: Any, child_outcomes: frozenset[Outcome]
    ) -> frozenset[Outcome]:
        if not cls.MAP:
            return ALL_OUTCOMES
        return frozenset(cls.MAP.get(o, o) for o in child_outcomes)


class Inverter(_Adapter, py_trees.decorators.Inverter):
    """Success becomes failure and failure success."""

    Params = NoParams
    MAP: ClassVar[dict[Outcome, Outcome]] = {"success": "failure", "failure": "success"}


class SuccessIsFailure(_Adapter, py_trees.decorators.SuccessIsFailure):
    """Success becomes failure."""

    MAP: ClassVar[dict[Outcome, Outcome]] = {"success": "failure"}


class FailureIsSuccess(_Adapter, py_trees.decorators.FailureIsSuccess):
    """Failure becomes success."""

    MAP: ClassVar[dict[Outcome, Outcome]] = {"failure": "success"}


class FailureIsRunning(_Adapter, py_trees.decorators.FailureIsRunning):
    """Failure becomes running."""

    MAP: ClassVar[dict[Outcome, Outcome]] = {"failure": "running"}


class SuccessIsRunning(_Adapter, py_trees.decorators.SuccessIsRunning):
    """Success becomes running."""

    MAP: ClassVar[dict[Outcome, Outcome]] = {"success": "running"}


class RunningIsFailure(_Adapter, py_trees.decorators.RunningIsFailure):
    """Running becomes failure."""

    MAP: ClassVar[dict[Outcome, Outcome]] = {"running": "failure"}


class RunningIsSuccess(_Adapter, py_trees.decorators.RunningIsSuccess):
    """Running becomes success."""

    MAP: ClassVar[dict[Outcome, Outcome]] = {"running": "success"}


class RetryParams(NodeParams):
    attempts: StrictInt = Field(ge=1, le=1000, description="tries before the failure is passed on")


class Retry(_Adapter, py_trees.decorators.Retry):
    """Runs the child again after a failure, up to ``attempts`` tries in all."""

    Params = RetryParams

    @classmethod
    def _kwargs(cls, params: Any) -> dict[str, Any]:
        return {"num_failures": params.attempts}


class RepeatParams(NodeParams):
    times: StrictInt = Field(ge=1, le=1_000_000, description="successes needed; a failure stops")


class Repeat(_Adapter, py_trees.decorators.Repeat):
    """Runs the child until it has succeeded ``times`` times (a failure fails at once)."""

    Params = RepeatParams

    @classmethod
    def _kwargs(cls, params: Any) -> dict[str, Any]:
        return {"num_success": params.times}


class OneShotParams(NodeParams):
    on: Literal["success", "completion"] = Field(
        "completion", description="latch the result on success only, or on any completion"
    )


class OneShot(_Adapter, py_trees.decorators.OneShot):
    """Runs the child until it completes once, then keeps returning that result."""

    Params = OneShotParams

    @classmethod
    def _kwargs(cls, params: Any) -> dict[str, Any]:
        policy = (
            py_trees.common.OneShotPolicy.ON_SUCCESSFUL_COMPLETION
            if params.on == "success"
            else py_trees.common.OneShotPolicy.ON_COMPLETION
        )
        return {"policy": policy}
