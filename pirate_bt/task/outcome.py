"""Why a run or a mission ended, and how each PAB of a mission went.

A failed tree says ``tree failed after 2012 ticks``; what a planner needs is the
first cause (``stall: bend_3_drive draws 1.50 A at 0 mm/s for 0.55 s``) and where
it happened. :func:`explain_run` finds it from the run's result, the tree (the
failures its behaviours recorded, :mod:`pirate_bt.behaviours.cause`) and the
supervisor's first safe-state entry (:class:`~pirate_bt.safety.tally.VerdictTally`):

1. a behaviour that raised: its exception, at its node;
2. the supervisor stopping the robot on its own (link lost, stale data, refused
   commands in a row, an e-stop): its reason, at the node running then;
3. a behaviour that failed (the latest one at or before the robot was stopped):
   its reason, at its node;
4. a time limit: the limit, and the node still running;
5. otherwise the runner's own line.

For a mission, :func:`pab_outcomes` gives one :class:`PabOutcome` per step of the
plan, and :func:`map_cause` names a map disagreement as the cause of a stop, what
ever gave it away: the localiser's mismatch (a turn or an opening where the map
has none, a feature missing), or a PAB blocked by the pipe where the map said it
could go on.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import py_trees

from pirate_bt.behaviours.cause import failure_cause, path_of
from pirate_bt.runner import RunResult, StopReason
from pirate_bt.safety.tally import SafeStateEntry
from pirate_bt.task.fixes import roll_name

__all__ = [
    "END_OF_RUN",
    "FOUND_TEE",
    "PAST_END_M",
    "PabOutcome",
    "counted",
    "explain_run",
    "link_cause",
    "map_cause",
    "pab_outcomes",
    "unsafe_note",
]

END_OF_RUN = "tree run ended without success"
"""The safe-state reason a runner gives when nothing gave one before it (followed by
``: `` and the run's own stop message, a time limit or an exception, when it has one,
so that the next run's refusal on the same connection names it)."""

_GENERIC = (END_OF_RUN, "mission ended without success")


@dataclass(frozen=True, slots=True)
class PabOutcome:
    """How one step of a mission's plan went.

    Attributes:
        label: The PAB's node name (``03 bend right (bend) (line 5)``).
        kind: ``straight``, ``bend``, ``t-joint`` or ``pause``.
        outcome: ``success``, ``failure`` (it ended the mission), ``stopped`` (it was
            running when something above it ended the mission: a map disagreement,
            a time limit, an operator) or ``not run``.
        start_s: Clock time it started, since the start of the mission (``None``
            if it never ran).
        end_s: Clock time it ended (``None`` if it never ran).
        why: Why it failed or was stopped (empty when it succeeded or never ran).
        failing_node: Path of the node inside it that failed, if one did.

    Example::

        mission = pirate_bt.simulate_mission("scenarios/bend-right.route")
        for pab in mission.pabs:
            print(pab.label, pab.kind, pab.outcome, pab.start_s, pab.end_s, pab.why)
        # 03 bend right (bend) (line 5) bend success 18.05 39.8
    """

    label: str
    kind: str
    outcome: str
    start_s: float | None
    end_s: float | None
    why: str = ""
    failing_node: str | None = None

    @property
    def duration_s(self) -> float | None:
        """Clock time it ran (``None`` if it never ran)."""
        if self.start_s is None or self.end_s is None:
            return None
        return self.end_s - self.start_s

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON values, as a mission's and a navigation's ``as_dict`` give them."""
        return {
            "label": self.label,
            "kind": self.kind,
            "outcome": self.outcome,
            "start_s": self.start_s,
            "end_s": self.end_s,
            "why": self.why,
            "failing_node": self.failing_node,
        }


def _find(root: py_trees.behaviour.Behaviour, path: str) -> py_trees.behaviour.Behaviour | None:
    for node in root.iterate():
        if path_of(node) == path:
            return node
    return None


def _tree_stop(root: py_trees.behaviour.Behaviour, safe: SafeStateEntry | None) -> bool:
    """True when the safe state came from the tree itself (a recovery's safe-state leaf)."""
    if safe is None or safe.node is None:
        return False
    from pirate_bt.behaviours.primitives import SafeState

    return isinstance(_find(root, safe.node), SafeState)


def link_cause(loop: Any, supervisor: Any) -> BaseException | None:
    """The link error a failed run ended on, when the supervisor's first cause was one
    (the link lost or silent: the robot was stopped by the supervisor, no behaviour
    raised), so that the run exits as a link error (3), as DESIGN.md says."""
    if loop.succeeded or supervisor is None:
        return None
    error: BaseException | None = getattr(supervisor, "safe_state_error", None)
    return error


def unsafe_note(counters: Any) -> str:
    """For a run that succeeded: what the simulator judged unsafe on the way, as a
    clause for its ``why`` (``""`` when nothing; always ``""`` on a robot, whose
    counters have no violations). A tree can end in success while the robot slid for a
    moment (a half at a tee's opening on a slow link): the success is the tree's, the
    violations the simulator's, and the result says both."""
    kinds = dict(getattr(counters, "violation_kinds", None) or {})
    damage = dict(getattr(counters, "damage_kinds", None) or {})
    if not kinds and not damage:
        return ""
    parts = [f"{n} {k} violation{'s' if n != 1 else ''}" for k, n in sorted(kinds.items())]
    parts += [f"{n} damage ({k})" for k, n in sorted(damage.items())]
    return f"; but the simulator counted {', '.join(parts)}: the robot did not stay safe"


def explain_run(
    run: RunResult,
    root: py_trees.behaviour.Behaviour,
    safe: SafeStateEntry | None = None,
) -> tuple[str, str | None]:
    """The first cause of a run's end and the node it happened at.

    Args:
        run: The runner's result.
        root: The tree's root (or the subtree to explain).
        safe: The supervisor's first safe-state entry during the run, if any.

    Returns:
        ``(why, failing_node)``; for a success ``(run.message, None)``.
    """
    if run.reason is StopReason.SUCCESS:
        return run.message, None
    if run.reason is StopReason.EXCEPTION:
        return run.message, run.failing_node
    if safe is not None and safe.reason.startswith(_GENERIC):
        safe = None  # the runner's own stop at the end: no cause of its own
    if safe is not None and not _tree_stop(root, safe):
        # the supervisor stopped the robot on its own: that came first
        return safe.reason, safe.node
    cause = failure_cause(root, before_s=safe.time_s if safe is not None else None)
    if (
        cause is not None
        and cause.time_s is not None
        and safe is None
        and run.reason is StopReason.TIME_LIMIT
        and cause.node not in run.stopped_nodes
    ):
        # failed, and the tree went on past it (a selector's next way): the limit
        # stopped a tree still running, not this failure (a node retried until the
        # limit is running again, and its failure stays the cause)
        cause = None
    if cause is not None and cause.time_s is not None:
        return cause.reason, cause.node
    if safe is not None:
        return safe.reason, safe.node
    if run.reason is StopReason.TIME_LIMIT:
        running = max(run.stopped_nodes, key=lambda p: p.count("/"), default=None)
        if running is not None:
            return f"{run.message}; {running} was still running", running
        return run.message, None
    if cause is not None:
        return cause.reason, cause.node
    return run.message, None


def pab_outcomes(
    route_node: py_trees.behaviour.Behaviour,
    kinds: dict[str, str],
    starts: Sequence[tuple[str, float]],
    end_s: float,
    *,
    run: RunResult,
    safe: SafeStateEntry | None,
    stopped_by: str | None = None,
) -> list[PabOutcome]:
    """One outcome per child of the mission's route sequence.

    Args:
        route_node: The sequence whose children are the PABs.
        kinds: PAB kind by label.
        starts: ``(label, start time)`` in the order the PABs started.
        end_s: When the mission ended (same clock origin as ``starts``).
        run: The runner's result.
        safe: The supervisor's first safe-state entry.
        stopped_by: Why the mission stopped from above the PABs (a map
            disagreement), if it did.
    """
    started = dict(starts)
    order = [label for label, _ in starts]
    out: list[PabOutcome] = []
    last = order[-1] if order else None
    for child in route_node.children:
        label = child.name
        kind = kinds.get(label, "")
        if label not in started:
            out.append(PabOutcome(label, kind, "not run", None, None))
            continue
        start = round(started[label], 4)
        later = [started[x] for x in order[order.index(label) + 1 :]]
        end = round(later[0] if later else end_s, 4)
        if label != last or run.succeeded:
            out.append(PabOutcome(label, kind, "success", start, end))
            continue
        if stopped_by is not None:
            out.append(PabOutcome(label, kind, "stopped", start, end, stopped_by))
            continue
        why, node = explain_run(run, child, safe)
        if (
            run.reason is StopReason.EXCEPTION
            and node is not None
            and not node.startswith(path_of(child))
        ):
            node = None
        outcome = (
            "failure" if run.reason in (StopReason.FAILURE, StopReason.EXCEPTION) else "stopped"
        )
        out.append(PabOutcome(label, kind, outcome, start, end, why, node))
    return out


FOUND_TEE = "found-tee-"
"""How a re-plan names a tee nobody drew that it put on the map (``found-tee-1``)."""

PAST_END_M = 0.1
"""A bend or T-joint PAB blocked this far beyond where it was to leave the robot drove
its search on past the feature the map has: said so, with how far (it read "at what the
map has as bend 'top'" for a block 1.3 m up a riser that has no bend at its top)."""


def map_cause(pab: PabOutcome, planned: Any, belief_m: float) -> str | None:
    """A PAB's failure named as a map disagreement, when the pipe blocked the robot where
    the map said it could go on (``None`` when the failure says nothing about the map).

    A drive *blocked* (every wheel at stall current, no progress) is the pipe in the
    way: a turn the map does not have, a tee's branch where it has a bend, a bend
    that is not the one drawn. A bend or T-joint PAB whose sensing drove its whole
    search without meeting the feature (``no feature (...) within 3 m``) is the pipe
    not turning, or a branch not on the map's side; so is a T-joint PAB turning into a
    branch in a steep pipe whose holding half drove onto the opening (the protective
    hold's *steep_pipe_unclamped: ... over an opening*: on the level the drive names
    the slip, there the hold acts first). One motor drawing stall current alone is a
    motor's trouble, not the map's.

    Args:
        pab: The PAB that failed.
        planned: The plan's :class:`~pirate_bt.task.plan.PlannedPab` for it, if known.
        belief_m: Where the robot believed it was.
    """
    if pab.outcome != "failure":
        return None
    feature = getattr(planned, "feature", None)
    if pab.why.startswith("no feature (") and feature and pab.kind in ("bend", "t-joint"):
        # the PAB's sensing drove its whole search without meeting the feature
        drawn = "bend" if pab.kind == "bend" else "T-joint"
        params = getattr(planned, "params", None) or {}
        way = params.get("direction")
        if not isinstance(way, str) and isinstance(params.get("roll"), int | float):
            way = roll_name(float(params["roll"]))
        toward = f" ({way})" if isinstance(way, str) else ""
        met = (  # it slipped over an opening it met, no half holding (SlipWatch)
            "met no turn: the robot slipped over an opening (a branch on another side than drawn?)"
            if "before slipping" in pab.why
            else "met no turn or opening there"
        )
        return (
            f"map disagreement at {belief_m:.2f} m (believed): the pipe is not as drawn at"
            f" {drawn} {feature!r}{toward}: the PAB's search {met} ({pab.label}: {pab.why})"
        )
    if (
        pab.why.startswith("steep_pipe_unclamped:")
        and "over an opening" in pab.why
        and feature
        and pab.kind == "t-joint"
    ):
        way = (getattr(planned, "params", None) or {}).get("direction")
        if way in ("left", "right"):  # the holding half drove onto the opening: no turn met
            return (
                f"map disagreement at {belief_m:.2f} m (believed): the pipe is not as drawn"
                f" at T-joint {feature!r} ({way}): the PAB's search met no turn: the holding"
                " half reached an opening in a steep pipe and let go of the wall (a branch on"
                f" another side than drawn?) ({pab.label}: {pab.why})"
            )
    if pab.why.startswith("no wall:") and feature and pab.kind == "t-joint":
        way = (getattr(planned, "params", None) or {}).get("direction")
        if way in ("left", "right"):  # a clamp in the turn into the branch met no wall
            return (
                f"map disagreement at {belief_m:.2f} m (believed): the pipe is not as drawn"
                f" at T-joint {feature!r} ({way}): a clamp turning into its branch met no"
                " wall (a tee nearer than drawn, with the front half over its opening, or a"
                f" branch capped or not as drawn?) ({pab.label}: {pab.why})"
            )
    if not pab.why.startswith("blocked"):
        return None
    where = f"map disagreement at {belief_m:.2f} m (believed): the pipe blocked the robot"
    if planned is not None and feature and pab.kind in ("bend", "t-joint"):
        drawn = "bend" if pab.kind == "bend" else "T-joint"
        what = f" at what the map has as {drawn} {feature!r}: the pipe there is not as drawn"
        past = belief_m - float(planned.end_m)
        if past > PAST_END_M:  # its search drove on past the feature: none was there
            what = (
                f", {past:.2f} m beyond where the PAB through what the map has as {drawn}"
                f" {feature!r} was to leave it ({planned.end_m:.2f} m): the pipe there is"
                " not as drawn"
            )
            if str(feature).startswith(FOUND_TEE):  # the re-plan's own tee, not drawn
                what += (
                    f"; {feature!r} is no tee of the drawing: an opening felt there was taken"
                    " for a tee nobody drew, and no far side of it was met: is the pipe"
                    " there wider than the map has it?"
                )
    elif planned is not None:
        what = (
            f" where the map has clear pipe from {planned.start_m:.2f} m to {planned.end_m:.2f} m"
        )
    else:
        what = " where the map has it pass"
    return f"{where}{what} ({pab.label}: {pab.why})"


def counted(n: int, word: str) -> str:
    """``1 step``, ``3 steps`` (``word`` with an ``s`` unless ``n`` is 1)."""
    return f"{n} {word}" if n == 1 else f"{n} {word}s"
