"""What a mission hands back: :class:`MissionResult` with its timeline, legs and samples.

The result types of :func:`~pirate_bt.task.mission.run_mission` (which builds them),
kept apart from the running so that each stays readable; ``pirate_bt.task.mission``
exports them as before.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from pirate_bt.error_chain import portable_chained, same_values
from pirate_bt.errors import LinkError
from pirate_bt.runner import RunResult
from pirate_bt.safety.tally import Counters
from pirate_bt.task.localise import Disagreement, Fix
from pirate_bt.task.outcome import PabOutcome
from pirate_bt.task.plan import MissionPlan
from pirate_bt.trace.coverage import Coverage

__all__ = [
    "Leg",
    "MissionResult",
    "Sample",
    "TimelineEntry",
    "belief_and_truth",
    "pabs_counted",
]


@dataclass(frozen=True, slots=True)
class TimelineEntry:
    """A PAB of the chain starting (or the mission ending).

    Attributes:
        time_s: Clock time since the start of the run.
        label: The PAB's node name (``03 bend right (bend-a) (line 6)``).
        belief_m: Belief when it started.
        truth_m: Simulator truth then, when known.
    """

    time_s: float
    label: str
    belief_m: float
    truth_m: float | None


@dataclass(frozen=True, slots=True)
class Leg:
    """A straight leg as run: its distance re-computed from the belief when it started.

    Attributes:
        label: The PAB's node name.
        planned_m: The distance the plan had (negative backwards).
        driven_m: The distance it was given when it started, from the belief.
        belief_m: The belief when it started.
        why: Why the two differ, for people (empty when they do not).
    """

    label: str
    planned_m: float
    driven_m: float
    belief_m: float
    why: str = ""


@dataclass(frozen=True, slots=True)
class Sample:
    """Belief and truth at one tick (for the report's plot)."""

    time_s: float
    belief_m: float
    truth_m: float | None


@dataclass
class MissionResult:
    """How a mission went.

    Attributes:
        plan: The plan that ran.
        run: The runner's result.
        reason: Why it ended, for people (the localiser's reason on a mismatch).
        fixes: Feature fixes of the localiser.
        timeline: When each PAB started.
        samples: Belief and truth over time (every tick with a new state).
        belief_m: Final belief.
        truth_m: Final truth, when simulated.
        odometry_m: Distance driven, by odometry.
        sim: Final simulator counters, when simulated.
        trace_path: The trace written, if any.
        tree: The mission tree (for diagrams).
    """

    plan: MissionPlan
    run: RunResult
    reason: str
    fixes: list[Fix]
    timeline: list[TimelineEntry]
    samples: list[Sample]
    belief_m: float
    truth_m: float | None
    odometry_m: float
    sim: Mapping[str, float] = field(default_factory=dict)
    trace_path: Path | None = None
    tree: Any = field(default=None, compare=False, repr=False)
    mismatch: str | None = None
    """The map disagreement that stopped the mission, whoever found it: the localiser
    (then :attr:`disagreement` holds its evidence) or a PAB's own sensing (a search
    that met no turn, a drive blocked where the map has clear pipe); ``None`` when
    pipe and map agreed as far as the robot went."""
    start_s: float = 0.0
    """Clock time at the start of the run (fix times are clock times)."""
    disagreement: Disagreement | None = None
    """Where belief and map parted, when they did (the mission then stopped safe)."""
    legs: list[Leg] = field(default_factory=list)
    """The straight legs as run, with the distances re-computed from the belief."""
    replans: list[str] = field(default_factory=list)
    """Where the mission re-planned after a disagreement with one clear meaning."""
    map_notes: list[str] = field(default_factory=list)
    """Where the pipe was felt to differ from the map without stopping the mission: a
    straight whose slope differs from the drawn one by more than 10 degrees
    (:mod:`pirate_bt.task.slope_watch`), one line each."""
    returned: MissionResult | None = None
    """The way back to the start after a stop, when it was asked for."""
    pabs: list[PabOutcome] = field(default_factory=list)
    """One entry per step of the plan: its outcome, start and end, and why it failed."""
    why: str = ""
    """The first cause of the end, for people: the failing PAB's own cause (``stall:
    bend_3_drive draws 1.50 A ...``), or the map disagreement that stopped the mission."""
    failing_node: str | None = None
    """Path of the node where the mission failed (``None`` on success)."""
    counters: Counters = field(default_factory=Counters)
    """Refusals, clips, link figures and, when simulated, violations and damage."""
    wall_s: float = 0.0
    """Wall time the run took."""
    safe_state: bool = False
    """The robot was left in its safe state (drives stopped, clamps held)."""
    coverage: Coverage | None = None
    """Per node of the mission's tree, what it did (ticks, transitions, successes,
    failures, halts, skips), counted as BehaviorTree.CPP's ``TreeObserver`` does."""

    close_error: LinkError | None = None
    """Set when closing the link, after the mission, could not make sure the robot
    stopped (its closing stop and the e-stop after it never acknowledged): the mission
    is then a failure, exit 3, whatever its PABs did, and :attr:`why` says so."""

    def __repr__(self) -> str:
        """A short summary (what ``print(result)`` shows): the outcome, its first cause
        and the counts; the whole data is :meth:`as_dict` (the dataclass's own repr,
        every sample and coverage record of the run, was some 70,000 characters)."""
        returned = "" if self.returned is None else f", returned={self.returned.status!r}"
        return (
            f"{type(self).__name__}(route={self.plan.route.name!r}, status={self.status!r},"
            f" why={self.why!r}, failing_node={self.failing_node!r},"
            f" {pabs_counted(self.pabs)}, fixes={len(self.fixes)}, ticks={self.ticks},"
            f" sim_time_s={self.sim_time_s:.2f}, {belief_and_truth(self.belief_m, self.truth_m)},"
            f" safe_state={self.safe_state}{returned})"
        )

    def __eq__(self, other: object) -> bool:
        """Equal values, an ``error`` by its type, message and causes
        (:func:`~pirate_bt.error_chain.same_values`): one read back from another process
        equals its original."""
        if type(other) is not type(self):
            return NotImplemented
        return same_values(self, other)

    def __getstate__(self) -> object:
        """Pickled without the py_trees tree (its generators do not pickle): a result
        sent back from a process pool keeps everything else."""
        state = dict(self.__dict__)
        state["tree"] = None
        # whatever a planner's node raised: one that cannot be pickled and read back (a
        # class whose __init__ takes two arguments) broke the pool, the result with it
        error = portable_chained(self.run.error)
        if error is not self.run.error:
            state["run"] = replace(self.run, error=error)
        return state

    @property
    def succeeded(self) -> bool:
        """True when every PAB of the plan succeeded and the close stopped the robot."""
        return self.run.succeeded and self.close_error is None

    @property
    def status(self) -> str:
        """``"success"`` or ``"failure"``."""
        return "failure" if self.close_error is not None else self.run.outcome

    @property
    def ticks(self) -> int:
        """Ticks the mission tree ran."""
        return self.run.ticks

    @property
    def tee_fallbacks(self) -> int:
        """Straight-through T-joints whose rear half crossed released, by distance: the
        fault path of ``trees/lib/tee-straight.yaml`` when the rear half cannot press
        across sensing the opening (0 without a fault; ``None`` coverage counts 0)."""
        if self.coverage is None:
            return 0
        return sum(1 for n in self.coverage if n.path.endswith("/rear across released") and n.ran)

    @property
    def error(self) -> BaseException | None:
        """The exception that ended the run, if one did (a lost link: ``LinkError``)."""
        return self.run.error

    @property
    def exit_code(self) -> int:
        """The command line's exit code for this mission: 0 success, 3 link error, 1
        failure (as :attr:`RunResult.exit_code <pirate_bt.RunResult.exit_code>`)."""
        if self.succeeded:
            return 0
        return 3 if isinstance(self.error, LinkError) or self.close_error is not None else 1

    @property
    def sim_time_s(self) -> float:
        """Clock time the mission took (simulated time on the simulator)."""
        return self.run.sim_time_s

    @property
    def failed_pab(self) -> PabOutcome | None:
        """The PAB that failed or was stopped, if one was."""
        return next((p for p in self.pabs if p.outcome in ("failure", "stopped")), None)

    @property
    def final_error_m(self) -> float | None:
        """Belief minus truth at the end (``None`` without a simulator)."""
        return None if self.truth_m is None else self.belief_m - self.truth_m

    @property
    def max_fix_error_m(self) -> float | None:
        """Largest belief error right after a fix (``None`` without truth or fixes)."""
        errors = [abs(f.error_after_m) for f in self.fixes if f.error_after_m is not None]
        return max(errors) if errors else None

    @property
    def max_error_m(self) -> float | None:
        """Largest belief error over the whole run."""
        errors = [abs(s.belief_m - s.truth_m) for s in self.samples if s.truth_m is not None]
        return max(errors) if errors else None

    def summary(self, wall_s: float | None = None) -> str:
        """One line for people, as ``pirate-bt mission`` prints it (``wall_s``: the wall
        time to show, default :attr:`wall_s`)."""
        node = self.failing_node
        where = f" at {node}" if node and not self.succeeded and node not in self.why else ""
        truth = f", truly {self.truth_m:.2f} m" if self.truth_m is not None else ""
        wall = self.wall_s if wall_s is None else wall_s
        return (
            f"mission {self.plan.route.name}: {'SUCCESS' if self.succeeded else 'FAILED'}"
            f" - {self.why}{where} ({self.run.ticks} ticks, {self.run.sim_time_s:.1f} s clock,"
            f" {wall:.1f} s wall; believed at {self.belief_m:.2f} m{truth})"
        )

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON values (your own reports), as :meth:`RunResult.as_dict
        <pirate_bt.RunResult.as_dict>` gives a tree run's: the outcome and its first
        cause, every PAB's, every fix, the belief against the truth, the counters."""

        def metres(value: float | None) -> float | None:
            return None if value is None else round(value, 4)

        return {
            "route": self.plan.route.name,
            "status": self.status,
            "why": self.why,
            "failing_node": self.failing_node,
            "mismatch": self.mismatch,
            "replans": list(self.replans),
            "map_notes": list(self.map_notes),
            "sim_time_s": round(self.sim_time_s, 3),
            "wall_s": round(self.wall_s, 3),
            "ticks": self.ticks,
            "safe_state": self.safe_state,
            "belief_m": metres(self.belief_m),
            "truth_m": metres(self.truth_m),
            "odometry_m": metres(self.odometry_m),
            "max_fix_error_m": metres(self.max_fix_error_m),
            "pabs": [p.as_dict() for p in self.pabs],
            "fixes": [
                {
                    "time_s": round(f.time_s, 3),
                    "feature": f.feature,
                    "how": f.how,
                    "before_m": metres(f.before_m),
                    "after_m": metres(f.after_m),
                    "truth_m": metres(f.truth_m),
                    "confidence": round(f.confidence, 4),
                }
                for f in self.fixes
            ],
            "trace": str(self.trace_path) if self.trace_path is not None else None,
            "counters": self.counters.as_dict(),
            "coverage": self.coverage.as_dict() if self.coverage is not None else None,
            "returned": self.returned.as_dict() if self.returned is not None else None,
        }


def pabs_counted(pabs: Sequence[Any]) -> str:
    """``pabs=3 (2 success, 1 failed_safe)``: a result's PABs counted by outcome, for the
    short reprs of a mission's and a navigation's result."""
    outcomes = Counter(p.outcome for p in pabs)
    tally = ", ".join(f"{n} {outcome}" for outcome, n in outcomes.items())
    return f"pabs={len(pabs)}" + (f" ({tally})" if tally else "")


def belief_and_truth(belief_m: float, truth_m: float | None) -> str:
    """``belief_m=1.234, truth_m=1.240`` (the truth only where it is known)."""
    truth = "" if truth_m is None else f", truth_m={truth_m:.3f}"
    return f"belief_m={belief_m:.3f}{truth}"
