"""Random command and operator sequences never get a preventable violation past the supervisor.

A hypothesis state machine drives random commands (as the tree and as the
operator) and operator actions (takeover, hand-back, e-stop, reset, safe state)
through the supervisor into :class:`~pirate_bt.safety.testing.FakePort` in
physics mode, which counts the violations of DOMAIN.md's rules. The pipe's
slope changes at random too. Invariant: no violation is ever recorded.

This runs against the in-memory fake; the simulator-backed twin is added once
the simulator's bridge is in the tree (see docs/safety.md). ``ci`` profile: 1000
examples; ``HYPOTHESIS_PROFILE=long`` runs more.
"""

from __future__ import annotations

import math

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from pirate_bt.clock import SimClock
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import (
    Bend,
    Clamp,
    Command,
    Drive,
    Mode,
    MoveFrontClear,
    Rotate,
    Source,
    Stop,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()
BENDS = [m.name for m in ROBOT.all_bend_modules()]

halves = st.sampled_from(list(Half))
angles = st.floats(-math.pi, math.pi, allow_nan=False)
commands: st.SearchStrategy[Command] = st.one_of(
    st.builds(Clamp, halves, st.floats(0.0, 1.2)),
    st.builds(Unclamp, halves),
    st.builds(Drive, st.floats(-0.15, 0.15)),
    st.builds(Rotate, angles),
    st.builds(Bend, st.sampled_from(BENDS), angles),
    st.builds(Tilt, angles),
    st.builds(MoveFrontClear, st.sampled_from([1, -1])),
    st.just(Stop()),
)


class SupervisedRobot(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.clock = SimClock()
        self.port = FakePort(ROBOT, self.clock, physics=True)
        self.sup = Supervisor(self.port, self.clock)

    @rule(command=commands, by_operator=st.booleans())
    def send(self, command: Command, by_operator: bool) -> None:
        source = Source.OPERATOR if by_operator else Source.TREE
        verdict = self.sup.command(command, source=source)
        assert verdict.ok or not verdict.sent

    @rule(command=commands)
    def send_twice(self, command: Command) -> None:
        # the same command repeated over ticks walks through rate limits
        for _ in range(3):
            self.sup.command(command)
            self.clock.advance(0.1)

    @rule(pitch_deg=st.sampled_from([0.0, 5.0, -5.0, 20.0, -30.0]))
    def slope(self, pitch_deg: float) -> None:
        self.port.set_pitch(math.radians(pitch_deg))

    @rule(mode=st.sampled_from(list(Mode)))
    def set_mode(self, mode: Mode) -> None:
        self.sup.set_mode(mode)

    @rule()
    def reset_estop(self) -> None:
        self.sup.reset_estop()

    @rule()
    def safe_state(self) -> None:
        self.sup.safe_state("test")

    @rule()
    def resume(self) -> None:
        self.sup.resume()

    @rule(dt=st.sampled_from([0.01, 0.05, 0.1]))
    def tick(self, dt: float) -> None:
        self.clock.advance(dt)
        self.sup.tick()

    @invariant()
    def no_violation(self) -> None:
        assert not self.port.violations.events, self.port.violations.events

    @invariant()
    def estop_means_nothing_moves(self) -> None:
        if self.sup.mode is Mode.ESTOP:
            last = self.sup.verdicts.last()
            assert (
                last is None
                or last.outcome.value != "pass"
                or not last.sent
                or all(c.value == 0.0 for c in last.sent)
            )


SupervisedRobot.TestCase.settings = settings(
    max_examples=max(1000, settings.default.max_examples), stateful_step_count=15
)
test_supervised_robot = SupervisedRobot.TestCase
