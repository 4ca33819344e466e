"""The counters of a run, one type everywhere: protective layer, link and simulator.

:class:`Counters` is what a tree run, a mission, a campaign row and the command
line report as "what happened on the way": commands the supervisor refused or
clipped, the link's retries and errors, and - on the simulator - the safety
violations and damage it judged. :class:`VerdictTally` counts a supervisor's
verdicts from the moment it is attached, and its first safe-state entry (when
and why), so a run's result can tell the first cause from what followed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from pirate_bt.safety.verdict import Outcome, Reason, Source, Verdict

__all__ = ["Counters", "SafeStateEntry", "VerdictTally"]


def _empty() -> dict[str, int]:
    return {}


@dataclass(frozen=True, slots=True)
class Counters:
    """What a run counted, with the same names and types in every result.

    Attributes:
        violations: Safety violations the simulator judged (sliding, uncontrolled
            rotation...); always 0 on a real robot, which has no judge.
        damage: Damage events the simulator judged (over-torque, a pressed front).
        refusals: Commands the supervisor refused.
        clips: Commands the supervisor clipped to a limit and sent.
        safe_states: Times the robot entered its safe state (a stop repeated while
            already in it counts once).
        estops: E-stops (the operator's, the bridge's input, the ROS graph's).
        retries: Link requests sent again after an acknowledgement timeout.
        link_failures: Link requests given up on after every retry.
        crc_errors: Frames rejected for a bad CRC or framing.
        duplicates: Duplicate or out-of-date frames ignored.
        frames_dropped: Host frames the simulator's bridge lost (a simulator fault such
            as ``link_loss@3s+1s`` or a resetting board). Link byte faults injected on
            the host side (``drop=0.05``) show as ``retries`` and ``crc_errors`` instead.
        overruns: Ticks that took longer than their budget (wall time).
        violation_kinds: ``violations`` by kind.
        damage_kinds: ``damage`` by kind.

    Example::

        result = pirate_bt.simulate_tree("straight", params={"distance": "0.2 m"},
                                         faults="drop=0.1")
        c = result.counters
        print(c.violations, c.refusals, c.clips, c.retries)
        print(c.as_dict())                  # plain JSON values
    """

    violations: int = 0
    damage: int = 0
    refusals: int = 0
    clips: int = 0
    safe_states: int = 0
    estops: int = 0
    retries: int = 0
    link_failures: int = 0
    crc_errors: int = 0
    duplicates: int = 0
    frames_dropped: int = 0
    overruns: int = 0
    violation_kinds: Mapping[str, int] = field(default_factory=_empty)
    damage_kinds: Mapping[str, int] = field(default_factory=_empty)

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON values (for rows, reports and ``--json`` output)."""
        out = asdict(self)
        out["violation_kinds"] = dict(sorted(self.violation_kinds.items()))
        out["damage_kinds"] = dict(sorted(self.damage_kinds.items()))
        return out

    def __add__(self, other: Counters) -> Counters:
        """The counters of two runs in a row (a mission and its re-plan)."""

        def merged(a: Mapping[str, int], b: Mapping[str, int]) -> dict[str, int]:
            out = dict(a)
            for k, v in b.items():
                out[k] = out.get(k, 0) + v
            return out

        return Counters(
            **{
                name: getattr(self, name) + getattr(other, name)
                for name in (
                    "violations",
                    "damage",
                    "refusals",
                    "clips",
                    "safe_states",
                    "estops",
                    "retries",
                    "link_failures",
                    "crc_errors",
                    "duplicates",
                    "frames_dropped",
                    "overruns",
                )
            },
            violation_kinds=merged(self.violation_kinds, other.violation_kinds),
            damage_kinds=merged(self.damage_kinds, other.damage_kinds),
        )


@dataclass(frozen=True, slots=True)
class SafeStateEntry:
    """The supervisor putting the robot in its safe state (or an e-stop latching).

    Attributes:
        time_s: Clock time.
        reason: Why (as given to :meth:`~pirate_bt.safety.Supervisor.safe_state`).
        node: Path of the tree node whose code was running then, if any.
    """

    time_s: float
    reason: str
    node: str | None


class VerdictTally:
    """Counts a supervisor's verdicts from now on, and its first safe-state entry.

    Args:
        supervisor: The supervisor to listen to (``add_listener``).
        from_open: Count the link's and the simulator's figures from the moment the
            link opened (its handshake included), not from now.

    Use :meth:`counters` at the end of a run, :attr:`first_safe_state` for the
    first stop, and :meth:`detach` when done.
    """

    def __init__(self, supervisor: Any, *, from_open: bool = False) -> None:
        self.supervisor = supervisor
        self.refusals = 0
        self.clips = 0
        self.safe_states = 0
        self.estops = 0
        self.first_safe_state: SafeStateEntry | None = None
        self._in_safe_state = bool(supervisor.in_safe_state)
        self._entries = getattr(supervisor, "safe_state_entries", None)
        # link and simulator figures already counted before this tally started
        self._base: dict[str, Any] = {} if from_open else self._raw()
        supervisor.add_listener(self._on_verdict)

    def _on_verdict(self, verdict: Verdict) -> None:
        if not self.supervisor.in_safe_state:
            self._in_safe_state = False
        if verdict.outcome is Outcome.REFUSE:
            self.refusals += 1
        elif verdict.outcome is Outcome.CLIP:
            self.clips += 1
        if verdict.reason is Reason.ESTOP_LATCHED and verdict.outcome is Outcome.PASS:
            # the e-stop itself (a command refused under it is a REFUSE with this reason)
            self.estops += 1
            if self.first_safe_state is None:
                self.first_safe_state = SafeStateEntry(
                    verdict.stamp_s, verdict.detail or "e-stop", verdict.node_name
                )
        if verdict.reason is Reason.SAFE_STATE and verdict.source is Source.SUPERVISOR:
            # the supervisor's own count where it keeps one: a resume sends no verdict,
            # so a stop, a resume and a new stop looked like one entry (3 counted as 1)
            entries = getattr(self.supervisor, "safe_state_entries", None)
            new = not self._in_safe_state if entries is None else entries != self._entries
            if new:
                self.safe_states += 1
                self._in_safe_state = True
                self._entries = entries
            if self.first_safe_state is None:
                reason = self.supervisor.safe_state_reason or verdict.detail
                self.first_safe_state = SafeStateEntry(verdict.stamp_s, reason, verdict.node_name)

    def detach(self) -> None:
        """Stop listening."""
        self.supervisor.verdicts.remove_listener(self._on_verdict)

    def _raw(self) -> dict[str, Any]:
        health = self.supervisor.health()
        raw: dict[str, Any] = {
            "retries": health.retries,
            "link_failures": health.failed,
            "crc_errors": health.crc_errors,
            "duplicates": health.duplicates,
        }
        simulator = getattr(self.supervisor, "simulator", None)
        if simulator is not None:
            c = simulator.counters()
            raw.update(
                violation_kinds=dict(c.violations),
                damage_kinds=dict(c.damage),
                frames_dropped=c.frames_dropped,
            )
        return raw

    def counters(self, *, overruns: int = 0) -> Counters:
        """The counters since this tally started."""
        now, base = self._raw(), self._base

        def since(key: str) -> int:
            return int(now.get(key, 0)) - int(base.get(key, 0))

        def kinds(key: str) -> dict[str, int]:
            a, b = now.get(key, {}), base.get(key, {})
            out = {k: v - b.get(k, 0) for k, v in a.items()}
            return {k: v for k, v in out.items() if v}

        violation_kinds, damage_kinds = kinds("violation_kinds"), kinds("damage_kinds")
        return Counters(
            violations=sum(violation_kinds.values()),
            damage=sum(damage_kinds.values()),
            refusals=self.refusals,
            clips=self.clips,
            safe_states=self.safe_states,
            estops=self.estops,
            retries=since("retries"),
            link_failures=since("link_failures"),
            crc_errors=since("crc_errors"),
            duplicates=since("duplicates"),
            frames_dropped=since("frames_dropped"),
            overruns=overruns,
            violation_kinds=violation_kinds,
            damage_kinds=damage_kinds,
        )
