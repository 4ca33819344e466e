"""The motion primitives' common base: ask the supervisor, watch the sensors, fail safe.

:class:`Primitive` holds what every primitive of :mod:`pirate_bt.behaviours.primitives`
and :mod:`pirate_bt.behaviours.drive` shares: the supervisor acquired in ``setup()``,
a timeout on the injected clock, the failure reason, re-sending a command until the
supervisor passes it unclipped, and stopping motion when interrupted.
"""

from __future__ import annotations

import logging
import math
from typing import Any, ClassVar

import py_trees
from py_trees.common import Status

from pirate_bt.behaviours.base import BuildContext, Leaf, NodeParams, Outcome
from pirate_bt.errors import ConfigurationError, shown
from pirate_bt.robot.description import RobotDescription
from pirate_bt.robot.state import RobotState

__all__ = ["Primitive"]

_log = logging.getLogger("pirate_bt.behaviours.primitives")

_SUCCESS_FAILURE: frozenset[Outcome] = frozenset({"success", "failure", "running"})
_SETTLE_TICKS = 2
"""Consecutive ticks a condition must hold before a primitive believes it."""


def _wrap(angle_rad: float) -> float:
    return math.remainder(angle_rad, 2 * math.pi)


def _deg(angle_rad: float) -> str:
    return f"{math.degrees(angle_rad):.1f}°"


def _near(text: str, value: float) -> bool:
    return abs(float(text) - value) <= 1e-12 * max(abs(value), 1.0)


def _exact_deg(angle_rad: float) -> str:
    """An angle as :func:`_deg` shows it, with more places where one would hide that it
    is past a limit (``110.001°``, not ``110.0°``, beyond a range up to ``110.0°``)."""
    degrees = math.degrees(angle_rad)
    text = f"{degrees:.1f}"
    for places in (3, 6, 9):
        if _near(text, degrees):
            break
        text = f"{degrees:.{places}f}"
    return f"{text}°"


def _exact(value: float) -> str:
    """A number as ``:g`` shows it, with more digits where six would round it onto a
    limit (``100.0001``, not ``100``, above a limit of ``100``)."""
    text = f"{value:g}"
    for digits in (9, 12, 17):
        if _near(text, value):
            break
        text = f"{value:.{digits}g}"
    return text


class Primitive(Leaf):
    """Common machinery: supervisor, timeout, verdict handling, failure reasons.

    Subclasses implement :meth:`step` (one tick of work on a fresh state, returning
    a status) and may override :meth:`start` and :meth:`stop_motion`.
    """

    needs_robot: ClassVar[bool] = True
    verb: ClassVar[str] = "primitive"

    def __init__(self, name: str, params: NodeParams, context: BuildContext) -> None:
        super().__init__(name, params, context)
        self.supervisor: Any = None
        self.failed_at_s: float | None = None
        self.failure_reason = ""
        self._start_s = math.nan
        self._timeout_s: float = getattr(params, "timeout", 30.0)
        self._refusal: Any = None

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        return _SUCCESS_FAILURE

    # -- lifecycle ---------------------------------------------------------------

    def setup(self, **kwargs: Any) -> None:
        """Take the supervisor from the build context (the only road to the robot).

        Raises:
            ConfigurationError: the tree was built without a robot connection.
        """
        if self.context.supervisor is None:
            raise ConfigurationError(
                f"{self.name}: the {self.verb} primitive needs a robot (no supervisor)"
            )
        self.supervisor = self.context.supervisor

    @property
    def robot(self) -> RobotDescription:
        robot: RobotDescription = self.supervisor.robot
        return robot

    def now(self) -> float:
        return self.context.clock.now()

    def initialise(self) -> None:
        if self.supervisor is None:
            self.setup()
        self._start_s = self.now()
        self.failed_at_s = None
        self.failure_reason = ""
        self.feedback_message = ""
        self.start()

    def update(self) -> Status:
        safe_reason = self.supervisor.safe_state_reason
        if safe_reason is not None:
            # The supervisor has stopped the drives under this primitive (link lost,
            # stale data, ...) and refuses every tree command until an operator resumes:
            # the work cannot go on, and the last state it has may be frozen (a drive
            # would count its wheels' last speed as distance still driven).
            return self.fail(f"the robot is in its safe state: {safe_reason}")
        estop = getattr(self.supervisor, "estop_reason", None)
        if estop is not None:
            # latched: the bridge has stopped everything and takes no setpoint until an
            # operator resets it; a tree ticked now (no operator attached to wait for)
            # cannot go on either
            return self.fail(f"e-stop latched: {estop}")
        state: RobotState | None = self.supervisor.state()
        elapsed_s = self.now() - self._start_s
        if state is None:
            if elapsed_s > self._timeout_s:
                return self.fail(f"timeout: no robot state within {self._timeout_s:g} s")
            self.feedback_message = "waiting for the robot's state"
            return Status.RUNNING
        status = self.step(state)
        if status is Status.RUNNING and elapsed_s > self._timeout_s:
            return self.fail(
                f"timeout: not done after {self._timeout_s:g} s ({self.feedback_message})"
            )
        return status

    def terminate(self, new_status: Status) -> None:
        if new_status is not Status.SUCCESS and self.supervisor is not None:
            self.stop_motion()

    # -- hooks -------------------------------------------------------------------

    def start(self) -> None:
        """Called when the primitive starts (after the supervisor is known)."""

    def step(self, state: RobotState) -> Status:  # pragma: no cover - abstract
        """One tick of work on the latest state; returns the status."""
        raise NotImplementedError

    def stop_motion(self) -> None:
        """Leave the robot safe when interrupted: by default nothing moves on (joints
        hold their last setpoint, which the rate limit keeps close to where they are)."""

    # -- helpers -------------------------------------------------------------------

    def fail(self, reason: str) -> Status:
        """Record ``reason`` (``feedback_message``, log, :func:`last_failure`) and fail."""
        self.feedback_message = reason
        self.failure_reason = reason
        self.failed_at_s = self.now()
        if _in_fallback(self):  # one way of several: the fallback tries the next
            _log.info("%s failed: %s", self.name, reason)
        else:
            _log.warning("%s failed: %s", self.name, reason)
        return Status.FAILURE

    def send(self, command: Any) -> tuple[bool, bool]:
        """Ask the supervisor for ``command``.

        Returns:
            ``(ok, done)``: ``ok`` is False for a refusal (the reason is recorded by
            :meth:`refused`); ``done`` is True when it went out unclipped.
        """
        verdict = self.supervisor.command(command)
        if verdict.refused:
            self._refusal = verdict
            return False, False
        return True, verdict.outcome.value == "pass"

    def refused(self) -> Status:
        verdict = self._refusal
        reason = verdict.reason.value if verdict.reason is not None else "refused"
        return self.fail(f"refused {_describe(verdict.command)}: {reason}: {verdict.detail}")


def _describe(command: Any) -> str:
    from pirate_bt.safety.commands import describe

    return describe(command)


def _commands() -> Any:
    # Imported lazily: building or drawing a tree must not need the safety layer.
    from pirate_bt.safety import commands

    return commands


def _read_blackboard(key: str) -> Any:
    storage = py_trees.blackboard.Blackboard.storage
    name = key if key.startswith("/") else "/" + key
    return storage.get(name)


def _write_blackboard(key: str, value: Any) -> None:
    name = key if key.startswith("/") else "/" + key
    py_trees.blackboard.Blackboard.set(name, value)


def _read_metres(key: str) -> float | str:
    """The number the blackboard holds under ``key``, or why it is not one."""
    name = key if key.startswith("/") else "/" + key
    value = py_trees.blackboard.Blackboard.storage.get(name)
    if isinstance(value, int | float) and not isinstance(value, bool):
        if math.isfinite(value) and value >= 0:
            return float(value)
        # planner code writes what no tree file can (nan, inf); a negative distance
        # would end the drive at once as done, or add to one taken off
        return (
            f"blackboard {shown(key)} holds {shown(value)}, not metres (a finite number, 0 or more)"
        )
    return f"blackboard {shown(key)} holds {shown(value)}, not metres"


def _in_fallback(node: Any) -> bool:
    """Whether ``node`` is one way a selector (fallback) tries: its failure is the
    tree's flow (a survey's probe into each plane, say), not a warning. The run's
    result still names it when the whole selector fails."""
    parent = node.parent
    while parent is not None:
        if isinstance(parent, py_trees.composites.Selector):
            return True
        parent = parent.parent
    return False
