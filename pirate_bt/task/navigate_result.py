"""How a navigation ended: :class:`NavigationResult`, and the words of its end.

Split out of :mod:`pirate_bt.task.navigate` (the loop), which fills it in.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pirate_bt.error_chain import portable_chained, same_values
from pirate_bt.errors import LinkError, said_of
from pirate_bt.safety.tally import Counters
from pirate_bt.task.mission import MissionResult
from pirate_bt.task.mission_result import belief_and_truth, pabs_counted
from pirate_bt.task.navigation import Decision, OffWall, Step
from pirate_bt.task.outcome import PabOutcome, counted

__all__ = [
    "FailedStep",
    "NavigationResult",
    "counted",
    "done_after_failures",
    "first_then",
    "steps_text",
    "unrecovered",
    "went_on",
]


@dataclass
class NavigationResult:
    """How a navigation went, step by step.

    Attributes:
        navigator: The navigator's name.
        status: ``"success"`` (the navigator said it was done, and every step
            succeeded, or every failed one was a map disagreement that a later step
            recovered from on a fix, with nothing unsafe on the way: see
            docs/navigators.md) or ``"failure"``.
        why: The first cause of the end, for people: the failing step's own cause,
            the map disagreement (the first, when the navigator went on after it), or
            the navigator's error (named); a success the simulator judged unsafe
            says so.
        failing_node: Path of the node where the step named first in ``why`` failed,
            if one did.
        decisions: Every answer of the navigator, with its observation.
        pabs: Every PAB run, in order (a turn step runs its approach and the turn).
        steps: Steps run.
        ticks: Ticks of every step's tree, summed.
        distance_m: Distance travelled along the pipe, forwards and back: simulated,
            the simulator's own odometer (the truth, a slide included); on a robot,
            where there is no truth, the belief's (how far each step moved it, a
            fix's correction included).
        belief_m: Final belief (metres along the way taken).
        truth_m: Final truth on the same scale, when simulated.
        counters: Refusals, clips, link figures and, when simulated, violations and
            damage, over the whole navigation.
        safe_state: The robot was left in its safe state.
        sim_time_s: Clock time the navigation took.
        wall_s: Wall time it took.
        missions: With a map: each step's one-step mission result.
        sim: Final simulator counters, when simulated.
        trace_dir: Where the navigation's records and per-step traces were written.
        error: The exception that ended it, if one did (a lost link: ``LinkError``;
            the navigator's own, with its traceback).
        navigator_raised: ``error`` is the navigator's own exception (a failure, exit
            1, even when it is a ``LinkError`` of its own making).
        close_error: Set when closing the link, after the navigation, could not make
            sure the robot stopped (its closing stop and the e-stop after it never
            acknowledged): the navigation is then a failure, exit 3, and ``why`` says so.
    """

    navigator: str
    status: str
    why: str
    failing_node: str | None = None
    decisions: list[Decision] = field(default_factory=list)
    pabs: list[PabOutcome] = field(default_factory=list)
    steps: int = 0
    ticks: int = 0
    distance_m: float = 0.0
    belief_m: float = 0.0
    truth_m: float | None = None
    counters: Counters = field(default_factory=Counters)
    safe_state: bool = False
    sim_time_s: float = 0.0
    wall_s: float = 0.0
    missions: list[MissionResult] = field(default_factory=list)
    sim: Mapping[str, float] = field(default_factory=dict)
    trace_dir: Path | None = None
    error: BaseException | None = None
    navigator_raised: bool = False
    close_error: LinkError | None = None
    notes: list[str] = field(default_factory=list)
    """What was done after the end: a half a failed step left free in a steep pipe
    clamped (:func:`pirate_bt.task.secure.hold_both`)."""
    off_wall: tuple[OffWall, ...] = ()
    """With no map: every time a bend joint swung off the wall during the last step
    run, oldest first (what ``obs.off_wall`` holds after a step; a failed step's too,
    though no navigator is asked after it): where a step stopped over an opening."""

    def __repr__(self) -> str:
        """A short summary (what ``print(result)`` shows), as a mission's result gives:
        the outcome, its first cause and the counts; the whole data is :meth:`as_dict`
        (the dataclass's own repr, every decision with its observation, grew by some
        thousand characters a step)."""
        return (
            f"{type(self).__name__}(navigator={self.navigator!r}, status={self.status!r},"
            f" why={self.why!r}, failing_node={self.failing_node!r}, steps={self.steps},"
            f" {pabs_counted(self.pabs)}, ticks={self.ticks}, sim_time_s={self.sim_time_s:.2f},"
            f" {belief_and_truth(self.belief_m, self.truth_m)}, safe_state={self.safe_state})"
        )

    def __eq__(self, other: object) -> bool:
        """Equal values, an ``error`` by its type, message and causes
        (:func:`~pirate_bt.error_chain.same_values`): one read back from another process
        equals its original."""
        if type(other) is not type(self):
            return NotImplemented
        return same_values(self, other)

    def __getstate__(self) -> object:
        """Pickled with a stand-in for an ``error`` that cannot be pickled and read back
        (a navigator's own exception class whose ``__init__`` takes two arguments broke
        a process pool, and the result that says why with it)."""
        state = dict(self.__dict__)
        state["error"] = portable_chained(self.error)
        return state

    @property
    def succeeded(self) -> bool:
        """True when the navigator finished and every step succeeded."""
        return self.status == "success"

    @property
    def exit_code(self) -> int:
        """The command line's exit code: 0 success, 3 link error, 1 failure."""
        if self.succeeded:
            return 0
        if self.close_error is not None:
            return 3
        return 3 if isinstance(self.error, LinkError) and not self.navigator_raised else 1

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON values (your own reports), as :meth:`MissionResult.as_dict
        <pirate_bt.MissionResult.as_dict>` gives a mission's: the outcome and its first
        cause, every decision and PAB, each step's mission with a map, the counters."""

        def metres(value: float | None) -> float | None:
            return None if value is None else round(value, 4)

        return {
            "navigator": self.navigator,
            "status": self.status,
            "why": self.why,
            "failing_node": self.failing_node,
            "steps": self.steps,
            "ticks": self.ticks,
            "distance_m": metres(self.distance_m),
            "belief_m": metres(self.belief_m),
            "truth_m": metres(self.truth_m),
            "safe_state": self.safe_state,
            "sim_time_s": round(self.sim_time_s, 3),
            "wall_s": round(self.wall_s, 3),
            "notes": list(self.notes),
            "off_wall": [o.to_json() for o in self.off_wall],
            "decisions": [d.to_json() for d in self.decisions],
            "pabs": [p.as_dict() for p in self.pabs],
            "missions": [m.as_dict() for m in self.missions],
            "counters": self.counters.as_dict(),
            "sim": dict(self.sim),
            "trace_dir": str(self.trace_dir) if self.trace_dir is not None else None,
            "error": None if self.error is None else said_of(self.error),
            "close_error": None if self.close_error is None else said_of(self.close_error),
        }

    def summary(self) -> str:
        """One line for people."""
        verb = "SUCCESS" if self.succeeded else "FAILURE"
        truth = "" if self.truth_m is None else f", truly {self.truth_m:.2f} m"
        return (
            f"navigator {self.navigator}: {verb} - {self.why} ({steps_text(self.steps)},"
            f" {counted(len(self.pabs), 'PAB')},"
            f" {self.sim_time_s:.1f} s clock, {self.wall_s:.1f} s wall;"
            f" believed at {self.belief_m:.2f} m{truth})"
        )


def steps_text(n: int) -> str:
    """``1 step``, ``3 steps``."""
    return counted(n, "step")


@dataclass(frozen=True)
class FailedStep:
    """A step that failed, kept for the words of the end.

    Attributes:
        index: 1 for the first step.
        step: The step.
        why: Its cause.
        failing_node: Where it failed.
    """

    index: int
    step: Step
    why: str
    failing_node: str | None

    def named(self) -> str:
        """``step 2, Step('bend', direction='right')``."""
        return f"step {self.index}, {self.step!r}"


def went_on(disagreements: Sequence[FailedStep]) -> str:
    """The clause that keeps the map disagreements a navigation went on after: the
    first, and the last when there were more (``""`` when there were none)."""
    if not disagreements:
        return ""
    first, last = disagreements[0], disagreements[-1]
    if first is last:
        return f"; it went on after a map disagreement: {first.why}"
    return (
        f"; it went on after {len(disagreements)} map disagreements, the first: {first.why};"
        f" the last: {last.why}"
    )


def first_then(name: str, failures: Sequence[FailedStep], later: str) -> str:
    """The end of a navigation that went on after failed steps (map disagreements) and
    then ended on ``later``, the navigator's own error: the first failed step's cause
    first, as everywhere a navigation ends failed (docs/navigators.md), then ``later``
    (``later`` alone when no step had failed)."""
    if not failures:
        return later
    first, last = failures[0], failures[-1]
    more = "" if first is last else f", and after step {last.index} failed too: {last.why}"
    went = f"navigator {name!r} went on from it{more}"
    return f"{first.why} ({first.named()}); {went}, and then: {later}"


def unrecovered(
    disagreements: Sequence[FailedStep], fixed_after: int, error: BaseException | None
) -> bool:
    """A step that failed on its own cause (not a disagreement) came after a map
    disagreement the navigation went on from, with no step since that succeeded on a fix
    on the map (``fixed_after``, the last such step's index): it failed where the pipe is
    not as the map says, so the disagreement is the first cause (docs/navigators.md). A
    lost link (``error`` a ``LinkError``) is its own cause whatever came before."""
    if not disagreements or isinstance(error, LinkError):
        return False
    return fixed_after < disagreements[-1].index


def done_after_failures(
    name: str,
    steps: int,
    failures: Sequence[FailedStep],
    *,
    fixed_after: int,
    unsafe: str,
) -> tuple[bool, str, str | None]:
    """The end of a navigation whose navigator said it was done (docs/navigators.md).

    A success when every step succeeded, or when every failed step was a map
    disagreement (any other failure ends the navigation at once) and a later step
    succeeded on a fix on the map (belief and map agree again: ``fixed_after`` is the
    last such step's index, 0 for none) with nothing unsafe on the way (``unsafe``:
    the simulator's note, ``""`` for none). Otherwise a failure whose ``why`` starts
    with the first failed step's cause and says the navigator was done after it.

    Returns:
        ``(succeeded, why, failing_node)``.
    """
    done = f"navigator {name!r} is done after {steps_text(steps)}"
    if not failures:
        return True, done + unsafe, None
    first, last = failures[0], failures[-1]
    recovered = fixed_after > last.index
    if recovered and not unsafe:
        return True, done + went_on(failures), None
    if recovered:
        why = f"{first.why} ({first.named()}); navigator {name!r} went on from it and was done"
        return False, f"{why} after {steps_text(steps)}{unsafe}", first.failing_node
    if last.index == steps and first is last:
        return (
            False,
            f"{first.why}; navigator {name!r} was done after it (step {steps})",
            (first.failing_node),
        )
    if last.index == steps:
        why = (
            f"{first.why} ({first.named()}); navigator {name!r} went on, and was done after"
            f" step {last.index} failed too: {last.why}"
        )
        return False, why, first.failing_node
    after = "it" if first is last else f"step {last.index} ({last.step!r}), which failed too"
    why = (
        f"{first.why} ({first.named()}); navigator {name!r} was done after"
        f" {steps_text(steps)}, with no step after {after} that succeeded on a fix on the map"
    )
    return False, why, first.failing_node
