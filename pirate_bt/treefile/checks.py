"""Static checks of a whole spec tree: outcomes, blackboard keys.

Step 2 of loading (see :mod:`pirate_bt.treefile.loader`): what each node can
return (to warn about children that can never run) and whether every
blackboard key read is written or declared.
"""

from __future__ import annotations

from collections.abc import Container, Iterator
from typing import Any

from pirate_bt.behaviours.base import Outcome
from pirate_bt.errors import LocatedError, SourceLocation, shown
from pirate_bt.treefile.params import SI_UNITS
from pirate_bt.treefile.spec import BlackboardDecl, NodeSpec

__all__ = []

# -- checks ----------------------------------------------------------------------------


def _describe_outcomes(outcomes: frozenset[Outcome]) -> str:
    if outcomes == frozenset({"success"}):
        return "always succeeds"
    if outcomes == frozenset({"failure"}):
        return "always fails"
    if outcomes == frozenset({"running"}):
        return "never finishes"
    return "/".join(sorted(outcomes))


def _outcomes(spec: NodeSpec, warnings: list[LocatedError]) -> frozenset[Outcome]:
    """Statuses ``spec`` can end a tick with; warns about children that never run."""
    if spec.cls is not None:
        if spec.cls.kind == "decorator":
            inner = _outcomes(spec.children[0], warnings)
            return spec.cls.decorated_outcomes(spec.params, inner)
        return spec.cls.outcomes(spec.params)
    child_out = [(c, _outcomes(c, warnings)) for c in spec.children]
    if spec.node_type == "eternal_guard":
        cond_ok = all("success" in _outcomes(c, warnings) for c in spec.conditions)
        out: set[Outcome] = set(child_out[0][1]) if cond_ok else set()
        return frozenset(out | {"failure"})
    if spec.node_type == "parallel":
        out = set()
        for _, o in child_out:
            out |= {x for x in o if x != "success"}
        policy = spec.params["policy"]
        # 'selected': the named children's successes are the parallel's (py_trees'
        # SuccessOnSelected); the others' outcomes but a failure do not end it
        needed = [
            o for c, o in child_out if policy != "selected" or c.name in spec.params["selected"]
        ]
        if (policy == "one" and any("success" in o for o in needed)) or (
            policy != "one" and all("success" in o for o in needed)
        ):
            out.add("success")
        if len(child_out) > 1 or "running" in out:
            out.add("running")
        return frozenset(out)
    go_on: Outcome = "success" if spec.node_type == "sequence" else "failure"
    result: set[Outcome] = set()
    blocker: tuple[NodeSpec, frozenset[Outcome]] | None = None
    for child, outs in child_out:
        if blocker is not None:
            warnings.append(
                LocatedError(
                    f"warning: {child.name!r} can never run: {blocker[0].name!r} before it in"
                    f" {spec.node_type} {spec.name!r} {_describe_outcomes(blocker[1])}",
                    child.called_at or child.location,  # a subtree: where it is called
                )
            )
            continue
        result |= outs - {go_on}
        if go_on not in outs:
            blocker = (child, outs)
    if blocker is None:
        result.add(go_on)
    return frozenset(result)


def _check_conditions(root: NodeSpec, errors: list[LocatedError]) -> None:
    """An ``eternal_guard``'s conditions answer in the tick: one that can be running (a
    drive, a wait) is started again each time it is done, as the guard re-checks its
    conditions every tick (a drive of 0.2 m there drove 2 m in 30 s, its child
    interrupted each time); its place is the child."""
    for spec in root.walk():
        if spec.node_type != "eternal_guard":
            continue
        for condition in spec.conditions:
            if "running" in _outcomes(condition, []):
                errors.append(
                    LocatedError(
                        f"eternal_guard: condition {condition.name!r} can be running: a"
                        " condition answers success or failure in the tick (once done, the"
                        " next tick would start it again); put it in the child",
                        condition.location,
                    )
                )


def _check_blackboard(
    root: NodeSpec,
    declared: dict[str, tuple[BlackboardDecl, SourceLocation]],
    errors: list[LocatedError],
    unsure: Container[str] = frozenset(),
) -> None:
    """Every key a node reads is declared and written (by a node, a default or the
    planner), every key written is declared; not checked: the keys in ``unsure``, whose
    declaration was refused (said where it is)."""
    writes: set[str] = {k for k, (d, _) in declared.items() if d.default is not None or d.external}
    reads: list[tuple[str, NodeSpec]] = []
    for spec in root.walk():
        if spec.cls is None or spec.params is None:
            continue
        for key in spec.cls.blackboard_writes(spec.params):
            if key not in declared and key not in unsure:
                errors.append(
                    LocatedError(
                        f"blackboard key {shown(key)} is written but not declared", spec.location
                    )
                )
            writes.add(key)
        reads.extend((key, spec) for key in spec.cls.blackboard_reads(spec.params))
        for key, value, verb in _compared(spec.params):
            decl = declared.get(key, (None,))[0]
            problem = None if decl is None else _kind_problem(key, value, decl.type, verb)
            if problem is not None:
                errors.append(LocatedError(f"{spec.node_type}: value: {problem}", spec.location))
    for key, spec in reads:
        if key in unsure:
            continue
        if key not in declared:
            errors.append(
                LocatedError(
                    f"blackboard key {shown(key)} is read but not declared under 'blackboard:'",
                    spec.location,
                )
            )
        elif key not in writes:
            errors.append(
                LocatedError(
                    f"blackboard key {shown(key)} is read but never written (no node writes it,"
                    " it has no default and is not marked external)",
                    spec.location,
                )
            )


def _has(params: Any, name: str) -> bool:
    """Whether ``params`` has a field or a class attribute (a property) ``name``."""
    kind = type(params)
    return name in getattr(kind, "model_fields", ()) or any(
        name in k.__dict__ for k in kind.__mro__
    )


def _kind_problem(key: str, value: object, declared: str, verb: str) -> str | None:
    """Why a value of ``value``'s kind never compares as meant with a key declared
    ``declared`` (text with a number, a number or a boolean with text or a boolean)."""
    of = f"blackboard key {shown(key)} is declared {declared}"
    if declared in (*SI_UNITS, "number", "integer"):
        if isinstance(value, str):  # the key holds a number: text never equals it
            unit = SI_UNITS.get(declared, ("",))[0]
            return (
                f"{shown(value)} is text, but {of} (text never equals a number and cannot"
                " be ordered with one)"
                + (f"; give 'unit: {unit}' to {verb} a quantity" if unit else "")
            )
        if isinstance(value, bool) and verb == "compare":  # true is the number 1
            return f"{str(value).lower()} is a boolean, but {of} (write a number)"
    if declared == "string" and not isinstance(value, str):  # 5 never equals '5'
        what = "a boolean" if isinstance(value, bool) else "a number"
        return f"{shown(value)} is {what}, but {of} (text never equals it; quote it for text)"
    if declared == "boolean" and not isinstance(value, bool):  # 1 == true, 'yes' never
        what = "text" if isinstance(value, str) else "a number"
        return f"{shown(value)} is {what}, but {of} (write true or false)"
    return None


def _compared(params: Any) -> Iterator[tuple[str, object, str]]:
    """The blackboard keys a node compares with, or writes, a value taken as written (no
    ``unit``): ``check_blackboard``'s and a guard's ``blackboard:`` comparisons, and
    ``set_blackboard``'s value."""
    # looked up by the class, not getattr with a default: a pydantic model raises and
    # catches an AttributeError for each missing one (two a node, every node of a tree)
    comparisons = params.comparisons if _has(params, "comparisons") else None
    verb = "compare"
    if comparisons is None and _has(params, "op") and params.op != "is_set":
        comparisons = [params]
    elif comparisons is None and _has(params, "key") and _has(params, "value"):
        comparisons, verb = [params], "write"  # set_blackboard: compared later
    for c in comparisons or ():
        key = getattr(c, "key", None)  # a guard's without its leading '/'
        value = getattr(c, "value", None)
        if isinstance(key, str) and value is not None and getattr(c, "unit", 1) is None:
            yield key, value, verb
