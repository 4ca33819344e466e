"""The node contract: what a behaviour needs so that YAML trees and planner code can use it.

A YAML tree names its leaves and decorators (``{type: wait, duration: 2 s}``).
The name is looked up in an explicit allow-list (:mod:`pirate_bt.treefile.registry`)
that maps it to a class following the contract below. The loader never imports
a module named in a file and never evaluates an expression: it validates the
node's keys against the class's pydantic :class:`NodeParams` model, checks them
against the robot description, and then asks the class to build itself.

The contract (mix :class:`NodeMixin` into a ``py_trees`` behaviour, or subclass
:class:`Leaf` / :class:`GuardDecorator`):

``Params``
    A :class:`NodeParams` subclass (pydantic, ``extra="forbid"``, frozen). Fields
    use the unit types of :mod:`pirate_bt.units` (``angle: Angle``); in files a
    unit is required (``90 deg``), in Python numbers are SI. Every field has a
    ``description``; the model also gives the node's JSON Schema.
``kind``
    ``"leaf"`` or ``"decorator"`` (a decorator gets exactly one ``child``).
``needs_robot``
    True when the node talks to the robot (through ``context.supervisor``).
    ``pirate-bt run`` refuses to run such a tree without a robot connection.
``from_params(name, params, context, child=None)``
    Build the behaviour. The default calls ``cls(name, params, context)`` for a
    leaf and ``cls(name, child, params, context)`` for a decorator.
    Acquire hardware in ``setup()``, never in ``__init__``: a tree must build and
    draw with no robot attached (``context.supervisor`` may be ``None``).
``check_limits(params, robot) -> list[str]``
    Problems with the parameters against the :class:`~pirate_bt.robot.RobotDescription`
    (for example an angle beyond a joint's limit). Start each message with the
    parameter's name and a colon (``"angle: 200 deg is beyond ..."``) so the
    loader can point at the right line. Default: no problems.
``blackboard_reads(params)`` / ``blackboard_writes(params)``
    Blackboard keys the node reads and writes (static check "read but never
    written"). Default: none.
``outcomes(params)``
    The statuses the node can end a tick with, for the "children that can never
    run" warning. Default: success, failure and running.

:class:`BuildContext` carries what builders may need: the robot description
(``robot``, may be ``None`` for a pure-logic tree), the injected ``clock``, and the
``supervisor`` (the :mod:`pirate_bt.safety` supervisor, the only road to the robot;
``None`` when building offline).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import py_trees
from pydantic import BaseModel, ConfigDict

from pirate_bt.clock import Clock, WallClock
from pirate_bt.safety.verdict import issuing

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription

__all__ = [
    "ALL_OUTCOMES",
    "BuildContext",
    "GuardDecorator",
    "Leaf",
    "NoParams",
    "NodeKind",
    "NodeMixin",
    "NodeParams",
    "Outcome",
]

NodeKind = Literal["leaf", "decorator"]
Outcome = Literal["success", "failure", "running"]
ALL_OUTCOMES: frozenset[Outcome] = frozenset({"success", "failure", "running"})


class NodeParams(BaseModel):
    """Base of every node's parameter model: unknown keys are errors, values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class NoParams(NodeParams):
    """For nodes that take no parameters."""


@dataclass(frozen=True)
class BuildContext:
    """What a node's builder may use.

    Attributes:
        robot: The robot description (``None`` when building a pure-logic tree).
        clock: The injected clock; every timeout and wait reads it.
        supervisor: The safety supervisor, the only object allowed to send
            commands (typed loosely so this layer never imports ``pirate_bt.safety``);
            ``None`` when building offline (to draw or validate a tree).
        extras: Free-form objects for third-party nodes (by agreed key).
    """

    robot: RobotDescription | None = None
    clock: Clock = field(default_factory=WallClock)
    supervisor: Any = None
    extras: Any = None


class NodeMixin:
    """The class-level contract; mix into a ``py_trees`` behaviour (see the module docstring)."""

    Params: ClassVar[type[NodeParams]] = NoParams
    kind: ClassVar[NodeKind] = "leaf"
    needs_robot: ClassVar[bool] = False

    @classmethod
    def from_params(
        cls,
        name: str,
        params: Any,
        context: BuildContext,
        child: py_trees.behaviour.Behaviour | None = None,
    ) -> py_trees.behaviour.Behaviour:
        """Build the behaviour from validated parameters.

        Args:
            name: The node's name in the tree.
            params: An instance of ``cls.Params``.
            context: Robot, clock and supervisor.
            child: The decorated child (decorators only).

        Returns:
            The behaviour.
        """
        factory: Callable[..., py_trees.behaviour.Behaviour] = cls  # type: ignore[assignment]
        if cls.kind == "decorator":
            if child is None:
                raise ValueError(f"decorator {name!r} needs a child")
            return factory(name, child, params, context)
        return factory(name, params, context)

    @classmethod
    def check_limits(cls, params: Any, robot: RobotDescription) -> list[str]:
        """Problems of ``params`` against the robot's limits, each ``"field: message"``."""
        return []

    @classmethod
    def blackboard_reads(cls, params: Any) -> tuple[str, ...]:
        """Blackboard keys read by a node with these parameters."""
        return ()

    @classmethod
    def blackboard_writes(cls, params: Any) -> tuple[str, ...]:
        """Blackboard keys written by a node with these parameters."""
        return ()

    @classmethod
    def outcomes(cls, params: Any) -> frozenset[Outcome]:
        """Statuses this node can end a tick with (used to find children that never run)."""
        return ALL_OUTCOMES

    @classmethod
    def decorated_outcomes(
        cls, params: Any, child_outcomes: frozenset[Outcome]
    ) -> frozenset[Outcome]:
        """For decorators: the statuses given the child's; default: anything."""
        return ALL_OUTCOMES


class Leaf(NodeMixin, py_trees.behaviour.Behaviour):
    """Convenient base for registered leaves: stores ``params`` and ``context``.

    Args:
        name: The node's name.
        params: Validated parameters (an instance of ``Params``).
        context: Robot, clock and supervisor.
    """

    def __init__(self, name: str, params: NodeParams, context: BuildContext) -> None:
        super().__init__(name=name)
        self.params = params
        self.context = context

    # Every verdict names the node that asked: the node's own code (initialise,
    # update, terminate) runs inside ``issuing(self)``, so the supervisor learns the
    # caller without any primitive passing it. The block is left at each yield, so
    # the rest of the tree never runs under this node's name.
    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        steps = super().tick()
        while True:
            with issuing(self):
                node = next(steps, None)
            if node is None:
                return
            yield node

    def stop(self, new_status: py_trees.common.Status = py_trees.common.Status.INVALID) -> None:
        with issuing(self):
            super().stop(new_status)


class GuardDecorator(NodeMixin, py_trees.decorators.Decorator):
    """Convenient base for registered decorators (guards override ``update()`` only).

    Args:
        name: The node's name.
        child: The decorated child.
        params: Validated parameters.
        context: Robot, clock and supervisor.
    """

    kind: ClassVar[NodeKind] = "decorator"

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        params: NodeParams,
        context: BuildContext,
    ) -> None:
        super().__init__(name=name, child=child)
        self.params = params
        self.context = context
