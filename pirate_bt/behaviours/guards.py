"""Guard nodes: conditions on the robot and pre-conditions on subtrees, and their
Python builders for planner code.

The nodes are :mod:`pirate_bt.behaviours.guards_nodes` (conditions: ``is_clamped``,
``link_healthy``, ``state_fresh``, ``mode_is``; pre-condition decorators after
BehaviorTree.CPP's ``_skipIf``, ``_failureIf`` and ``_while``: ``skip_if``,
``failure_if``, ``while``; the comparisons they look at, :data:`STATE_VALUES`), named
here as the tree files' registry names them. The builders below make each one with
its parameters checked as a tree file's are (one located line for a bad one).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import py_trees

from pirate_bt.behaviours.base import BuildContext
from pirate_bt.behaviours.guards_nodes import (
    STATE_VALUES,
    Comparison,
    FailureIf,
    IsClamped,
    IsClampedParams,
    LinkHealthy,
    ModeIs,
    ModeIsParams,
    PreconditionParams,
    SkipIf,
    StateFresh,
    StateFreshParams,
    While,
    _Precondition,
)
from pirate_bt.robot.description import Half
from pirate_bt.safety import Mode, Supervisor

__all__ = [
    "STATE_VALUES",
    "Comparison",
    "FailureIf",
    "IsClamped",
    "IsClampedParams",
    "LinkHealthy",
    "ModeIs",
    "ModeIsParams",
    "PreconditionParams",
    "SkipIf",
    "StateFresh",
    "StateFreshParams",
    "While",
    "failure_if",
    "is_clamped",
    "link_healthy",
    "mode_is",
    "skip_if",
    "state_fresh",
    "while_",
]


# -- Python builders ----------------------------------------------------------------


def _context(supervisor: Supervisor | None) -> BuildContext:
    if supervisor is None:
        return BuildContext()
    return BuildContext(robot=supervisor.robot, clock=supervisor.clock, supervisor=supervisor)


def _comparisons(condition: Any) -> Any:
    # a text or None is judged by the parameters' checks (one line, the caller's line)
    return list(condition) if isinstance(condition, list | tuple) else condition


def is_clamped(supervisor: Supervisor | None, half: Half, name: str = "") -> IsClamped:
    """An ``is_clamped`` condition for planner code."""
    name = name or f"is_clamped({half})"
    return IsClamped(name, IsClamped.checked_params(name, {"half": half}), _context(supervisor))


def link_healthy(supervisor: Supervisor | None, name: str = "link healthy") -> LinkHealthy:
    """A ``link_healthy`` condition for planner code."""
    from pirate_bt.behaviours.base import NoParams

    return LinkHealthy(name, NoParams(), _context(supervisor))


def state_fresh(
    supervisor: Supervisor | None, channels: Sequence[str] = (), name: str = "state fresh"
) -> StateFresh:
    """A ``state_fresh`` condition for planner code."""
    wanted = {"channels": list(channels) if isinstance(channels, list | tuple) else channels}
    return StateFresh(name, StateFresh.checked_params(name, wanted), _context(supervisor))


def mode_is(supervisor: Supervisor | None, mode: Mode, name: str = "") -> ModeIs:
    """A ``mode_is`` condition for planner code."""
    name = name or f"mode_is({mode})"
    return ModeIs(name, ModeIs.checked_params(name, {"mode": mode}), _context(supervisor))


def _decorate(
    cls: type[_Precondition],
    child: py_trees.behaviour.Behaviour,
    condition: Any,
    supervisor: Supervisor | None,
    name: str,
) -> Any:
    name = name or f"{cls.__name__}({child.name})"
    params = cls.checked_params(name, {"condition": _comparisons(condition)})
    return cls(name, child, params, _context(supervisor))  # type: ignore[arg-type]


def skip_if(
    child: py_trees.behaviour.Behaviour,
    condition: Any,
    supervisor: Supervisor | None = None,
    name: str = "",
) -> SkipIf:
    """Wrap ``child`` in a ``skip_if`` guard (``condition``: comparison(s) or dict(s))."""
    node: SkipIf = _decorate(SkipIf, child, condition, supervisor, name)
    return node


def failure_if(
    child: py_trees.behaviour.Behaviour,
    condition: Any,
    supervisor: Supervisor | None = None,
    name: str = "",
) -> FailureIf:
    """Wrap ``child`` in a ``failure_if`` guard."""
    node: FailureIf = _decorate(FailureIf, child, condition, supervisor, name)
    return node


def while_(
    child: py_trees.behaviour.Behaviour,
    condition: Any,
    supervisor: Supervisor | None = None,
    name: str = "",
) -> While:
    """Wrap ``child`` in a ``while`` guard (``while`` is a Python keyword)."""
    node: While = _decorate(While, child, condition, supervisor, name)
    return node
