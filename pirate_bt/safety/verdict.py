"""Verdicts: what the supervisor decided about one command, and where they are kept.

A :class:`Verdict` is pass, clip or refuse. A refusal carries a machine-readable
:class:`Reason` (a string enum, stable across versions, safe to match in code
and in traces) and a sentence for people. A clip carries the commands as they
were actually sent. Every verdict is logged on the ``pirate_bt.safety`` logger
and appended to a bounded :class:`VerdictLog`, which the trace reads with
:meth:`VerdictLog.since` or by subscribing a listener.

A verdict on a tree's command names the node that asked for it: the behaviour
layer runs each node's own code inside :func:`issuing` (a context variable, so
no primitive passes anything by hand), and the supervisor stamps the node's
path onto the verdict.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from contextvars import ContextVar, Token
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from pirate_bt.robot.commands import MotorCommand
from pirate_bt.safety.commands import Command, describe

__all__ = [
    "Outcome",
    "Reason",
    "Source",
    "Verdict",
    "VerdictListener",
    "VerdictLog",
    "current_issuer",
    "enter_issuer",
    "issuing",
    "leave_issuer",
    "node_path",
]

log = logging.getLogger("pirate_bt.safety")

_ISSUER: ContextVar[Any] = ContextVar("pirate_bt_issuer", default=None)


class issuing:  # lower case: it reads as a function, ``with issuing(node):``
    """Run a block on behalf of ``node``: verdicts given inside it name the node.

    Nests (a decorator's child runs inside its parent's block) and is per thread
    and per task, as a :class:`~contextvars.ContextVar` is. A class rather than a
    ``@contextmanager`` generator: every node's tick enters it (twice for a leaf),
    and this costs a third of what the generator did.
    """

    __slots__ = ("_node", "_token")

    def __init__(self, node: Any) -> None:
        self._node = node

    def __enter__(self) -> None:
        self._token = _ISSUER.set(self._node)

    def __exit__(self, *exc: object) -> None:
        _ISSUER.reset(self._token)


enter_issuer: Callable[[Any], Token[Any]] = _ISSUER.set
"""``token = enter_issuer(node)`` ... ``leave_issuer(token)``: :class:`issuing` without
the ``with`` block, for the hottest path (every node's tick); always pair them in a
``try``/``finally``."""
leave_issuer: Callable[[Token[Any]], None] = _ISSUER.reset
"""Ends what :data:`enter_issuer` began (see there)."""


def current_issuer() -> Any:
    """The node whose code is running now (see :func:`issuing`), or ``None``."""
    return _ISSUER.get()


def node_path(node: Any) -> tuple[str, str]:
    """``(path id, path of names)`` of a py_trees behaviour, e.g. ``("0.2.1", "a/b/c")``.

    The path id is the one traces use (``0`` for the root, then child indices).
    Duck-typed on ``name``, ``parent`` and ``children``, so this layer does not
    import py_trees.
    """
    ids: list[str] = []
    names: list[str] = []
    while node is not None:
        names.append(str(node.name))
        parent = getattr(node, "parent", None)
        if parent is None:
            ids.append("0")
        else:
            ids.append(str(next(i for i, c in enumerate(parent.children) if c is node)))
        node = parent
    return ".".join(reversed(ids)), "/".join(reversed(names))


class Outcome(StrEnum):
    """The three verdicts."""

    PASS = "pass"
    CLIP = "clip"
    REFUSE = "refuse"


class Source(StrEnum):
    """Who asked for a command."""

    TREE = "tree"
    """A behaviour tree, a motion primitive or planner code (autonomy)."""
    OPERATOR = "operator"
    """A person: teleop or a scripted operator."""
    SUPERVISOR = "supervisor"
    """The supervisor itself (safe state, takeover stop)."""


class Reason(StrEnum):
    """Machine-readable reasons for clip and refuse verdicts (see docs/safety.md)."""

    # authority
    ESTOP_LATCHED = "estop_latched"
    SAFE_STATE = "safe_state"
    TREE_PAUSED = "tree_paused"
    NOT_CONFIRMED = "not_confirmed"
    OPERATOR_NOT_IN_CONTROL = "operator_not_in_control"
    # link and data
    LINK_DOWN = "link_down"
    LINK_SILENT = "link_silent"
    BOARD_FAULT = "board_fault"
    BUS_FAULT = "bus_fault"
    LINK_ERROR = "link_error"
    NO_STATE = "no_state"
    STALE_STATE = "stale_state"
    # static limits
    UNKNOWN_TARGET = "unknown_target"
    MODE_NOT_ALLOWED = "mode_not_allowed"
    NOT_FINITE = "not_finite"
    ANGLE_LIMIT = "angle_limit"
    TORQUE_LIMIT = "torque_limit"
    VELOCITY_LIMIT = "velocity_limit"
    ANGULAR_RATE_LIMIT = "angular_rate_limit"
    ACCELERATION_LIMIT = "acceleration_limit"
    RAW_RANGE = "raw_range"
    CLAMP_TORQUE_TOO_LOW = "clamp_torque_too_low"
    # state invariants
    OTHER_HALF_NOT_CLAMPED = "other_half_not_clamped"
    ROTATE_NEEDS_ONE_CLAMPED = "rotate_needs_one_clamped"
    HALF_TRANSITIONING = "half_transitioning"
    FRONT_NOT_CLEAR = "front_not_clear"
    STEEP_PIPE_UNCLAMPED = "steep_pipe_unclamped"
    JOINT_STALLED = "joint_stalled"
    MOTOR_CONFLICT = "motor_conflict"


@dataclass(frozen=True, slots=True)
class Verdict:
    """The supervisor's decision on one command.

    Attributes:
        outcome: pass, clip or refuse.
        command: The command as asked for.
        source: Who asked.
        sent: The motor commands actually sent (empty for a refusal or a dry run).
        reason: Why it was clipped or refused; ``None`` for a plain pass.
        detail: One sentence for people.
        stamp_s: Clock time of the decision.
        tick: The supervisor's tick counter at the decision.
        seq: Position in the supervisor's verdict sequence (starts at 1).
        clips: Every limit that clipped the command (the first one is ``reason``).
        node: Path id (``0.2.1``, as in traces) of the tree node that asked, when a
            node asked (see :func:`issuing`).
        node_name: The same node as a path of names from the root.
    """

    outcome: Outcome
    command: Command
    source: Source
    sent: tuple[MotorCommand, ...] = ()
    reason: Reason | None = None
    detail: str = ""
    stamp_s: float = 0.0
    tick: int = 0
    seq: int = 0
    clips: tuple[Reason, ...] = field(default_factory=tuple)
    node: str | None = None
    node_name: str | None = None

    @property
    def ok(self) -> bool:
        """True for pass and clip: the command (or its clipped form) went out."""
        return self.outcome is not Outcome.REFUSE

    @property
    def refused(self) -> bool:
        return self.outcome is Outcome.REFUSE

    def to_record(self) -> dict[str, object]:
        """A JSON-ready dict for traces."""
        return {
            "seq": self.seq,
            "tick": self.tick,
            "t": self.stamp_s,
            "source": self.source.value,
            "command": describe(self.command),
            "outcome": self.outcome.value,
            "reason": self.reason.value if self.reason else None,
            "detail": self.detail,
            "sent": [[c.motor, c.mode.value, c.value] for c in self.sent],
            "node": self.node,
        }

    def __str__(self) -> str:
        who = f"{self.source}: {self.node_name}" if self.node_name else str(self.source)
        text = f"{self.outcome.upper()} {describe(self.command)} [{who}]"
        if self.reason is not None:
            text += f" {self.reason}: {self.detail}"
        return text


VerdictListener = Callable[[Verdict], None]


class VerdictLog:
    """The last ``maxlen`` verdicts, with listeners called on every new one.

    Args:
        maxlen: How many verdicts to keep.
    """

    def __init__(self, maxlen: int = 1000) -> None:
        self._items: deque[Verdict] = deque(maxlen=maxlen)
        self._listeners: list[VerdictListener] = []
        self._failed: set[int] = set()  # listeners whose error was logged

    def append(self, verdict: Verdict) -> None:
        self._items.append(verdict)
        level = logging.WARNING if verdict.refused else logging.INFO
        if verdict.source is Source.SUPERVISOR:
            level = logging.WARNING
        log.log(level, "%s", verdict)
        for listener in tuple(self._listeners):
            try:
                listener(verdict)
            except Exception as exc:
                # a listener's error is not the command's: it raised out of command()
                # after the command had gone out, and out of safe_state() and estop(),
                # which never raise (the protective hold's clamps after it not sent)
                self._listener_failed(listener, exc)

    def _listener_failed(self, listener: VerdictListener, exc: Exception) -> None:
        """Log a listener's error, once per listener (it is called again)."""
        first = id(listener) not in self._failed
        self._failed.add(id(listener))
        name = getattr(listener, "__qualname__", None) or repr(listener)[:80]
        text = (str(exc).splitlines() or [""])[0][:200]
        log.log(
            logging.ERROR if first else logging.DEBUG,
            "verdict listener %s raised %s: %s (the verdict stands; listeners are called on)",
            name,
            type(exc).__name__,
            text,
        )

    def add_listener(self, listener: VerdictListener) -> None:
        """Call ``listener(verdict)`` for every verdict from now on."""
        self._listeners.append(listener)

    def remove_listener(self, listener: VerdictListener) -> None:
        if listener in self._listeners:
            self._listeners.remove(listener)

    def since(self, *, tick: int | None = None, seq: int | None = None) -> list[Verdict]:
        """Verdicts from ``tick`` on (inclusive), or after sequence number ``seq``."""
        out: Sequence[Verdict] = self._items
        if tick is not None:
            out = [v for v in out if v.tick >= tick]
        if seq is not None:
            out = [v for v in out if v.seq > seq]
        return list(out)

    def last(self) -> Verdict | None:
        return self._items[-1] if self._items else None

    def __len__(self) -> int:
        return len(self._items)

    def __iter__(self) -> Iterator[Verdict]:
        return iter(tuple(self._items))
