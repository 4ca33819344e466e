"""How a navigation ended: :class:`NavigationResult`, and the words of its end.

Split out of :mod:`pirate_bt.task.navigate` (the loop), which fills it in.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from pirate_bt.errors import LinkError
from pirate_bt.safety.tally import Counters
from pirate_bt.task.mission import MissionResult
from pirate_bt.task.navigation import Decision
from pirate_bt.task.outcome import PabOutcome

__all__ = ["NavigationResult", "steps_text"]


@dataclass
class NavigationResult:
    """How a navigation went, step by step.

    Attributes:
        navigator: The navigator's name.
        status: ``"success"`` (the navigator said it was done, every step succeeded)
            or ``"failure"``.
        why: The first cause of the end, for people: the failing step's own cause,
            the map disagreement, or the navigator's error (named).
        failing_node: Path of the node where a step failed, if one did.
        decisions: Every answer of the navigator, with its observation.
        pabs: Every PAB run, in order (a turn step runs its approach and the turn).
        steps: Steps run.
        ticks: Ticks of every step's tree, summed.
        distance_m: Distance driven, forwards and back (by the truth when simulated,
            else by the belief).
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
        error: The exception that ended it, if one did (a lost link: ``LinkError``).
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

    @property
    def succeeded(self) -> bool:
        """True when the navigator finished and every step succeeded."""
        return self.status == "success"

    @property
    def exit_code(self) -> int:
        """The command line's exit code: 0 success, 3 link error, 1 failure."""
        if self.succeeded:
            return 0
        return 3 if isinstance(self.error, LinkError) else 1

    def summary(self) -> str:
        """One line for people."""
        verb = "SUCCESS" if self.succeeded else "FAILURE"
        truth = "" if self.truth_m is None else f", truly {self.truth_m:.2f} m"
        return (
            f"navigator {self.navigator}: {verb} - {self.why} ({self.steps} steps,"
            f" {len(self.pabs)} PABs, {self.sim_time_s:.1f} s clock, {self.wall_s:.1f} s wall;"
            f" believed at {self.belief_m:.2f} m{truth})"
        )


def steps_text(n: int) -> str:
    """``1 step``, ``3 steps``."""
    return f"{n} step" if n == 1 else f"{n} steps"
