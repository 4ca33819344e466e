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
    ``params`` is checked first, exactly as the YAML loader checks a node (see
    :meth:`NodeMixin.checked_params`), also when a subclass overrides
    ``from_params``: the override is wrapped so that it always receives a
    checked instance of ``Params``.
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

Planner code builds nodes in Python with the same checks as a file::

    clamp = Clamp.build("clamp front", context, half="front", torque="0.5 N*m")

Numbers are SI, text with a unit is parsed (``"90 deg"``), and every problem -
an unknown key, a wrong unit, a quantity beyond :data:`~pirate_bt.units.MAGNITUDE_LIMITS`
as in a file, a torque beyond the robot's limit (when ``context.robot`` is set) -
raises :class:`~pirate_bt.errors.ValidationFailed` located at the caller's line:
``planner.py:12:1: clamp front: torque: 50 N*m is above the bend joints' limit 0.8
N*m``. A node constructed from a ``Params`` instance (``Drive("d", DriveParams(...),
context)``, which no loader checked) has its quantities bounded the same way, an
:class:`~pirate_bt.errors.ArgumentValueError` naming the node and the parameter.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal

import py_trees
from pydantic import (
    AllowInfNan,
    BaseModel,
    ConfigDict,
    Strict,
    StrictBool,
    StrictInt,
    StrictStr,
    ValidationError,
    model_validator,
)

from pirate_bt.clock import Clock, WallClock
from pirate_bt.errors import (
    ArgumentTypeError,
    ArgumentValueError,
    LocatedError,
    SourceLocation,
    ValidationFailed,
    caller_location,
    shown,
)
from pirate_bt.safety.verdict import enter_issuer, issuing, leave_issuer
from pirate_bt.units import plain_number

if TYPE_CHECKING:
    from pirate_bt.robot.description import RobotDescription

__all__ = [
    "ALL_OUTCOMES",
    "COMPARISONS",
    "BuildContext",
    "GuardDecorator",
    "Leaf",
    "NoParams",
    "NodeKind",
    "NodeMixin",
    "NodeParams",
    "Outcome",
    "Scalar",
    "params_problems",
]

NodeKind = Literal["leaf", "decorator"]

# A float is finite: every comparison with NaN is false ('!=' would always hold)
Scalar = StrictBool | StrictInt | Annotated[float, Strict(), AllowInfNan(False)] | StrictStr
"""A constant a node compares with or writes (check_blackboard, set_blackboard, guards)."""

COMPARISONS: dict[str, Callable[[Any, Any], bool]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}
"""The comparisons a node's ``op`` names."""
Outcome = Literal["success", "failure", "running"]
ALL_OUTCOMES: frozenset[Outcome] = frozenset({"success", "failure", "running"})

_RUNNING = py_trees.common.Status.RUNNING
_INVALID = py_trees.common.Status.INVALID
_STATUS = py_trees.common.Status
_STATUSES = list(py_trees.common.Status)
"""What py_trees' ``tick()`` accepts from ``update()``; it builds the list on every tick,
the ticks below look at it only for a value that is not a ``Status``."""


class NodeParams(BaseModel):
    """Base of every node's parameter model: unknown keys are errors, values are frozen.

    A NumPy scalar or 0-d array given for a parameter is the Python value it stands
    for, however the model is made (``DriveParams(reverse=numpy.bool_(True))`` was
    refused *Input should be a valid boolean*, ``RetryParams(attempts=numpy.int64(3))``
    *a valid integer*)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _plain_values(cls, data: Any) -> Any:
        if isinstance(data, dict):
            return {key: _plain(value) for key, value in data.items()}
        return data


_BOUNDED: dict[str, Any] = {"magnitude_limits": True}
"""The validation context of a node's parameters however the node is built: every
quantity bounded by :data:`~pirate_bt.units.MAGNITUDE_LIMITS`, as a tree file's are.
Built in Python they were not (``Drive.build("d", velocity=0.08, distance=1e300)``
ran a drive of 1e300 m)."""


def _bound_problems(params: NodeParams) -> list[str]:
    """The problems of a ``Params`` instance that nothing validated with the bounds:
    its values validated again, with them (an instance made with ``model_construct``,
    which validates nothing, has its ``nan`` found too)."""
    data = params.model_dump(exclude_unset=True)
    try:
        type(params).model_validate(data, context=dict(_BOUNDED))
    except ValidationError as exc:
        return params_problems(exc, data, type(params))
    return []


def _check_bounded(node: object, name: str, params: object) -> None:
    """Refuse ``params`` of a node constructed directly beyond the bounds a file has,
    in one line naming the node and the parameter."""
    if not isinstance(params, NodeParams):
        return  # not this contract's (the node's own code reads what it was given)
    problems = _bound_problems(params)
    if problems:
        raise ArgumentValueError(f"{type(node).__name__}({name!r}): {'; '.join(problems)}")


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

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # A class that writes its own from_params still gets checked parameters.
        own = cls.__dict__.get("from_params")
        if isinstance(own, classmethod):
            cls.from_params = classmethod(_checking(own.__func__))  # type: ignore[method-assign,assignment]

    @classmethod
    def from_params(
        cls,
        name: str,
        params: Any,
        context: BuildContext,
        child: py_trees.behaviour.Behaviour | None = None,
    ) -> py_trees.behaviour.Behaviour:
        """Build the behaviour from parameters, checked exactly as the YAML loader checks them.

        Args:
            name: The node's name in the tree.
            params: An instance of ``cls.Params``, or a mapping of its keys (numbers
                are SI, text with a unit is parsed: ``{"torque": "0.5 N*m"}``);
                ``None`` is no keys.
            context: Robot, clock and supervisor; with ``context.robot`` set the
                parameters are also checked against the robot's limits.
            child: The decorated child (decorators only).

        Returns:
            The behaviour.

        Raises:
            ValidationFailed: the parameters are invalid or beyond the robot's
                limits, each problem located at the caller's line.
            ValueError: a decorator without a child.
        """
        _check_context(cls, context)
        _check_child(cls, name, child)
        checked = cls.checked_params(name, params, context.robot)
        factory: Callable[..., py_trees.behaviour.Behaviour] = cls  # type: ignore[assignment]
        if cls.kind == "decorator":
            if child is None:
                raise ValueError(f"decorator {name!r} needs a child")
            return factory(name, child, checked, context)
        return factory(name, checked, context)

    @classmethod
    def build(
        cls,
        name: str,
        context: BuildContext | None = None,
        *,
        child: py_trees.behaviour.Behaviour | None = None,
        **params: Any,
    ) -> py_trees.behaviour.Behaviour:
        """Build the behaviour from keyword parameters (planner code).

        ``Clamp.build("clamp front", ctx, half="front", torque="0.5 N*m")`` is
        ``Clamp.from_params("clamp front", {"half": "front", "torque": "0.5 N*m"},
        ctx)``: the same checks, the same errors.

        Args:
            name: The node's name in the tree.
            context: Robot, clock and supervisor (default: an offline
                ``BuildContext()``: no robot, so no limit checks, and the wall clock).
            child: The decorated child (decorators only).
            **params: The node's parameters, as in a file (numbers are SI).

        Raises:
            ValidationFailed: as :meth:`from_params`.
        """
        return cls.from_params(name, params, context or BuildContext(), child)

    @classmethod
    def checked_params(
        cls, name: str, params: Any, robot: RobotDescription | None = None
    ) -> NodeParams:
        """``params`` validated by ``cls.Params`` and checked against ``robot``'s limits.

        The same checks as a node in a YAML file, with the same messages, each
        prefixed with the node's name (a file prefixes the node type and points at
        the key instead) and located at the first caller outside ``pirate_bt``.

        Args:
            name: The node's name, for the messages.
            params: An instance of ``cls.Params`` (taken as it is, then checked
                against the robot), or a mapping of its keys (``None``: no keys).
            robot: The robot description; ``None`` skips the limit checks.

        Returns:
            The parameters as an instance of ``cls.Params`` (quantities in SI).

        Raises:
            ValidationFailed: every problem found.
        """
        from pirate_bt.robot.description import RobotDescription

        fn = f"{cls.__name__}.checked_params"
        if not isinstance(name, str):
            raise ArgumentTypeError(f"{fn}: name: give the node's name as text, not {shown(name)}")
        if robot is not None and not isinstance(robot, RobotDescription):
            raise ArgumentTypeError(
                f"{fn}: robot: give a RobotDescription (pirate_bt.load_robot) or None,"
                f" not {shown(robot)}"
            )
        checked: NodeParams | None = None
        problems: list[str] = []
        if isinstance(params, cls.Params):
            checked = params
        elif params is None or isinstance(params, Mapping):
            data = {key: _plain(value) for key, value in dict(params or {}).items()}
            try:
                checked = cls.Params.model_validate(data, context=dict(_BOUNDED))
            except ValidationError as exc:
                problems = params_problems(exc, data, cls.Params)
        else:
            problems = [
                f"parameters: expected {cls.Params.__name__} or a mapping of its keys,"
                f" got {type(params).__name__}"
            ]
        if checked is not None and robot is not None:
            problems = cls.check_limits(checked, robot)
        if problems or checked is None:
            where = caller_location() or SourceLocation("<python>")
            raise ValidationFailed(LocatedError(f"{name}: {p}", where) for p in problems)
        return checked

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


def _plain(value: Any) -> Any:
    """A parameter given in Python with a NumPy scalar (or a 0-d array) read as the
    number, boolean or text it stands for, also in a list of them: as SI numbers,
    ``numpy.float32(0.08)`` was "expected a velocity quantity" where ``numpy.float64``
    (a float) was taken, and ``numpy.bool_(True)`` no boolean."""
    if type(value) in (list, tuple):  # a subclass of either, as it is
        return type(value)(plain_number(item) for item in value)
    return plain_number(value)


def _checking(
    build: Callable[..., py_trees.behaviour.Behaviour],
) -> Callable[..., py_trees.behaviour.Behaviour]:
    """Wrap a class's own ``from_params`` so that it receives checked parameters."""

    @functools.wraps(build)
    def from_params(
        cls: type[NodeMixin],
        name: str,
        params: Any,
        context: BuildContext,
        child: py_trees.behaviour.Behaviour | None = None,
        **kwargs: Any,
    ) -> py_trees.behaviour.Behaviour:
        _check_context(cls, context)
        _check_child(cls, name, child)
        checked = cls.checked_params(name, params, context.robot)
        return build(cls, name, checked, context, child, **kwargs)

    return from_params


def _check_child(cls: type[NodeMixin], name: object, child: object) -> None:
    """A leaf given a child (which it would drop: the child never ran), or a child that
    is no behaviour, refused by the node's name."""
    if child is None:
        return
    if cls.kind != "decorator":
        raise ArgumentTypeError(
            f"{cls.__name__}({name}): child: a {cls.kind} takes no child (it would never"
            " run); put the two in a sequence"
        )
    if not isinstance(child, py_trees.behaviour.Behaviour):
        raise ArgumentTypeError(
            f"{cls.__name__}({name}): child: give a py_trees behaviour"
            f" (Success.build('s'), a tree's root), not {shown(child)}"
        )


def _check_context(cls: type, context: object) -> None:
    if not isinstance(context, BuildContext):
        raise ArgumentTypeError(
            f"{cls.__name__}: context: give a BuildContext (robot.context() on a connection,"
            f" or BuildContext(...)), not {shown(context)}"
        )


def params_problems(exc: ValidationError, data: Any, model: Any = None) -> list[str]:
    """A node's pydantic errors as the YAML loader words them, each naming its key.

    A file's message points at the key, so it need not name it (``Input should be
    greater than 0`` at ``torque:``); in Python the key is put in front
    (``torque: Input should be greater than 0``) unless the message already names
    it (``unknown key 'torq'``, ``half: Input should be 'front' or 'rear'``).

    Args:
        exc: The validation error of ``Params.model_validate(data)``.
        data: The validated mapping.
    """
    from pirate_bt.yamlvalidate import validation_problems  # only on the error path

    out: list[str] = []
    for path, message in validation_problems(exc, data, model):
        if path and not (message.startswith(f"{path[-1]}:") or f"key {str(path[-1])!r}" in message):
            where = "".join(
                f"[{p}]" if isinstance(p, int) else (f".{p}" if i else str(p))
                for i, p in enumerate(path)
            )
            message = f"{where}: {message}"
        out.append(message)
    return out


def _end_tick(node: py_trees.behaviour.Behaviour, new_status: Any) -> None:
    """The end of py_trees' ``tick()`` (2.6) once ``update()`` answered: an answer that
    is no status logged and taken as INVALID, a final one stopping the node, the
    status set. py_trees builds ``list(Status)`` for the check on every tick; here only
    an answer that is not a ``Status`` is looked up in it."""
    if type(new_status) is not _STATUS and new_status not in _STATUSES:
        node.logger.error(
            "A behaviour returned an invalid status, setting to INVALID "
            f"[{new_status}][{node.name}]"
        )
        new_status = _INVALID
    if new_status != _RUNNING:
        node.stop(new_status)
    node.status = new_status


class Leaf(NodeMixin, py_trees.behaviour.Behaviour):
    """Convenient base for registered leaves: stores ``params`` and ``context``.

    Args:
        name: The node's name.
        params: Validated parameters (an instance of ``Params``).
        context: Robot, clock and supervisor.
    """

    def __init__(self, name: str, params: NodeParams, context: BuildContext) -> None:
        _check_bounded(self, name, params)
        super().__init__(name=name)
        self.params = params
        self.context = context

    # Every verdict names the node that asked: the node's own code (initialise,
    # update, terminate) runs inside ``issuing(self)``, so the supervisor learns the
    # caller without any primitive passing it. The block is left before the yield, so
    # the rest of the tree never runs under this node's name. The steps are py_trees'
    # ``Behaviour.tick()``'s (2.6), in one generator instead of one wrapped in another
    # (tests/test_composites_fast.py compares them with py_trees' own).
    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        # ``with issuing(self)`` spelled out: this runs for every node on every tick
        token = enter_issuer(self)
        try:
            self.logger.debug(f"{self.__class__.__name__}.tick()")
            if self.status != _RUNNING:
                self.initialise()
            _end_tick(self, self.update())
        finally:
            leave_issuer(token)
        yield self

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
        _check_bounded(self, name, params)
        super().__init__(name=name, child=child)
        self.params = params
        self.context = context

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        """py_trees' ``Decorator.tick()`` (2.6), in one generator (see :class:`Leaf`)."""
        self.logger.debug(f"{self.__class__.__name__}.tick()")
        if self.status != _RUNNING:
            self.initialise()
        yield from self.decorated.tick()
        _end_tick(self, self.update())
        yield self
