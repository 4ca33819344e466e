"""The allow-list of node types a YAML tree may name.

A tree file names node types (``wait``, ``clamp``, ``is_clamped``); this module
maps each name to a class that follows the node contract of
:mod:`pirate_bt.behaviours.base`. The table holds ``"module:Class"`` strings and
imports a class only when a tree uses it (python-can's backend table works the
same way), so listing the names is cheap and a broken optional module breaks
only the trees that use it.

Third-party packages add node types through the entry-point group
``pirate_bt.nodes``; each entry point's name is the YAML name and its value is
``module:Class``. Planner code may also call :meth:`Registry.register` with a
class. A YAML file itself can never name a module: only names in this table work.

Composites (``sequence``, ``selector``, ``parallel``), ``subtree`` and
``eternal_guard`` are structural and built by the loader, so their names are
reserved here.

Rows for other issues' nodes are added here with a one-line edit each:
the guards of :mod:`pirate_bt.behaviours.guards` (``is_clamped``, ``link_healthy``,
``state_fresh``, ``mode_is``, ``skip_if``, ``failure_if``, ``while``) and the
motion primitives (``clamp``, ``unclamp``, ``drive``, ``bend``, ``rotate``).
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Iterator
from importlib.metadata import entry_points
from typing import Any, Final

from pirate_bt.behaviours.base import NodeMixin
from pirate_bt.errors import reduce_error
from pirate_bt.yamlvalidate import close_matches

__all__ = [
    "BUILTIN_NODES",
    "ENTRY_POINT_GROUP",
    "RESERVED",
    "Registry",
    "UnknownNode",
    "default_registry",
]

_log = logging.getLogger(__name__)

ENTRY_POINT_GROUP: Final = "pirate_bt.nodes"

# Names the loader builds itself.
RESERVED: Final = frozenset({"sequence", "selector", "parallel", "subtree", "eternal_guard"})

_BASIC = "pirate_bt.behaviours.basic"

# YAML name -> "module:Class". Keep sorted within each group.
BUILTIN_NODES: Final[dict[str, str]] = {
    # generic leaves
    "check_blackboard": f"{_BASIC}:CheckBlackboard",
    "failure": f"{_BASIC}:Failure",
    "log": f"{_BASIC}:Log",
    "running": f"{_BASIC}:Running",
    "scripted": f"{_BASIC}:Scripted",
    "set_blackboard": f"{_BASIC}:SetBlackboard",
    "success": f"{_BASIC}:Success",
    "wait": f"{_BASIC}:Wait",
    # decorators from py_trees (timeout on the injected clock)
    "failure_is_running": f"{_BASIC}:FailureIsRunning",
    "failure_is_success": f"{_BASIC}:FailureIsSuccess",
    "inverter": f"{_BASIC}:Inverter",
    "oneshot": f"{_BASIC}:OneShot",
    "repeat": f"{_BASIC}:Repeat",
    "retry": f"{_BASIC}:Retry",
    "running_is_failure": f"{_BASIC}:RunningIsFailure",
    "running_is_success": f"{_BASIC}:RunningIsSuccess",
    "success_is_failure": f"{_BASIC}:SuccessIsFailure",
    "success_is_running": f"{_BASIC}:SuccessIsRunning",
    "timeout": f"{_BASIC}:Timeout",
    # guards (pirate_bt.behaviours.guards) — added by the safety layer
    "failure_if": "pirate_bt.behaviours.guards:FailureIf",
    "is_clamped": "pirate_bt.behaviours.guards:IsClamped",
    "link_healthy": "pirate_bt.behaviours.guards:LinkHealthy",
    "mode_is": "pirate_bt.behaviours.guards:ModeIs",
    "skip_if": "pirate_bt.behaviours.guards:SkipIf",
    "state_fresh": "pirate_bt.behaviours.guards:StateFresh",
    "while": "pirate_bt.behaviours.guards:While",
    # motion primitives — added by the primitives issue
    "align_roll": "pirate_bt.behaviours.primitives:AlignRoll",
    "bend": "pirate_bt.behaviours.primitives:Bend",
    "clamp": "pirate_bt.behaviours.primitives:Clamp",
    "confirm": "pirate_bt.behaviours.primitives:Confirm",
    "drive": "pirate_bt.behaviours.primitives:Drive",
    "move_front_clear": "pirate_bt.behaviours.primitives:MoveFrontClear",
    "rotate": "pirate_bt.behaviours.primitives:Rotate",
    "safe_state": "pirate_bt.behaviours.primitives:SafeState",
    "unclamp": "pirate_bt.behaviours.primitives:Unclamp",
}


class UnknownNode(KeyError):
    """A node type that is not in the registry; ``suggestions`` lists close names."""

    def __init__(self, name: str, suggestions: list[str]) -> None:
        self.name = name
        self.suggestions = suggestions
        hint = f"; did you mean {' or '.join(repr(s) for s in suggestions)}?" if suggestions else ""
        if len(suggestions) == 1:  # 'wаit' (Cyrillic а) for 'wait': shown alike
            from pirate_bt.treefile.names import alike_note

            hint += alike_note(name, suggestions[0])
        shown = repr(name) if len(name) <= 60 else repr(name[:57] + "...")
        super().__init__(f"unknown node type {shown}{hint}")

    def __str__(self) -> str:
        return str(self.args[0])

    def __reduce__(self) -> tuple[Any, ...]:  # across processes (pools, Dask) intact
        return reduce_error(self)


class Registry:
    """Name → node class, resolved lazily.

    Args:
        table: ``name -> "module:Class"`` rows (default :data:`BUILTIN_NODES`).
        entry_point_group: Group to read third-party rows from (``None`` to skip).
    """

    def __init__(
        self,
        table: dict[str, str] | None = None,
        entry_point_group: str | None = ENTRY_POINT_GROUP,
    ) -> None:
        self._refs: dict[str, str] = dict(BUILTIN_NODES if table is None else table)
        self._classes: dict[str, type[NodeMixin]] = {}
        if entry_point_group:
            for ep in entry_points(group=entry_point_group):
                if ep.name in self._refs or ep.name in RESERVED:
                    _log.warning("entry point %r ignored: the name is taken", ep.name)
                    continue
                self._refs[ep.name] = ep.value

    def names(self) -> list[str]:
        """Every registered node type, sorted (without the structural names)."""
        return sorted(set(self._refs) | set(self._classes))

    def __contains__(self, name: object) -> bool:
        return name in self._refs or name in self._classes

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def register(self, name: str, node: type[NodeMixin] | str, *, replace: bool = False) -> None:
        """Add a node type (a class, or a ``"module:Class"`` string) from Python code.

        Raises:
            ValueError: the name is reserved, malformed, or taken (unless ``replace``).
        """
        if name in RESERVED or not name.isidentifier():
            raise ValueError(f"cannot register node type {name!r}")
        if name in self and not replace:
            raise ValueError(f"node type {name!r} is already registered")
        self._classes.pop(name, None)
        self._refs.pop(name, None)
        if isinstance(node, str):
            self._refs[name] = node
        else:
            self._classes[name] = node

    def suggest(self, name: str) -> list[str]:
        """Registered or structural names close to ``name`` (for error messages)."""
        return close_matches(name, [*self.names(), *RESERVED], n=3, cutoff=0.6)

    def get(self, name: str) -> type[NodeMixin]:
        """The class registered as ``name``, importing it on first use.

        Raises:
            UnknownNode: ``name`` is not registered.
            ImportError: the registered module or class cannot be imported.
        """
        cls = self._classes.get(name)
        if cls is not None:
            return cls
        ref = self._refs.get(name)
        if ref is None:
            raise UnknownNode(name, self.suggest(name))
        module_name, _, attr = ref.partition(":")
        module = importlib.import_module(module_name)
        found = getattr(module, attr, None)
        if not (isinstance(found, type) and issubclass(found, NodeMixin)):
            raise ImportError(f"{ref} (node type {name!r}) is not a pirate_bt node class")
        self._classes[name] = found
        return found


_DEFAULT: Registry | None = None


def default_registry() -> Registry:
    """The process-wide registry: built-in rows plus the entry-point group."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = Registry()
    return _DEFAULT
