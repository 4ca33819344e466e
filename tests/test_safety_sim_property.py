"""Random command and operator sequences through the supervisor into the real simulator.

The twin of ``test_safety_property.py`` with the in-process simulator
(:class:`pirate_bt.sim.Simulator`, reached over the link's ``sim://`` transport)
instead of the fake port: a hypothesis state machine starts the robot in a level
pipe or halfway up a vertical riser, in one of a few clamp configurations, then
drives random commands (as the tree and as the operator) and operator actions
(mode changes, e-stop and reset, safe state and resume) through the supervisor,
advancing the shared :class:`~pirate_bt.clock.SimClock` in 100 ms runner ticks so
the physics happens. Invariant: the simulator records no violation and no damage
event after the set-up that the supervisor could have prevented.

No event is excused: an e-stop stops the drives and the rotation and keeps the
bend joints holding (DESIGN.md, "Stops that do not drop the robot"), so not even
a slide during a latched e-stop is allowed.

``ci`` profile: 1000 examples of at most 10 steps; ``HYPOTHESIS_PROFILE=long``
runs more.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from pirate_bt.clock import SimClock
from pirate_bt.pipes import Network, load_network
from pirate_bt.robot import Half, RobotDescription, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode
from pirate_bt.robot.loader import default_robot_path
from pirate_bt.safety import (
    Bend,
    Clamp,
    Command,
    Drive,
    Mode,
    MoveFrontClear,
    Raw,
    Rotate,
    Source,
    Stop,
    Supervisor,
    Tilt,
    Unclamp,
)
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.sim import EventKind, SimEvent

TICK_S = 0.1  # a 10 Hz runner
SETTLE_S = 0.35  # longer than motion.over_torque_time: damage in the making shows


def _robot_at(state_period: str) -> RobotDescription:
    """The bundled robot with another bridge state period (a 50 Hz bridge)."""
    text = default_robot_path().read_text(encoding="utf-8")
    assert "state_period: 10 ms" in text
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "pirate-50hz.yaml"
        path.write_text(text.replace("state_period: 10 ms", f"state_period: {state_period}"))
        return load_robot(path)


# Loaded once: building a simulator from loaded objects costs about a millisecond. The
# simulator steps its physics (and sends a state frame) once per state period, which is
# what a test pays for; a 50 Hz bridge halves that and changes no rule or threshold.
ROBOT = _robot_at("20 ms")
BENDS = [m.name for m in ROBOT.all_bend_modules()]
JOINTS = [ROBOT.joint_motor(name).name for name in BENDS]
_riser = load_network("riser")
WORLDS: dict[str, Network] = {
    "level": load_network("straight"),
    # halfway up the vertical riser: a pipe far steeper than max_unclamped_slope
    "riser": Network(
        _riser.spec.model_copy(
            update={"start": _riser.spec.start.model_copy(update={"position": 2.6})}
        ),
        "riser (start 2.6 m)",
    ),
}
CLAMP_NM = 0.5
CLEAR = ROBOT.clamp.front_clear_angle

halves = st.sampled_from(list(Half))
# Joint targets near the interesting places: steering, the wall (1.30-1.78 rad), limits.
joint_angles = st.one_of(
    st.sampled_from([0.0, 0.6, -0.6, 1.2, -1.2, 1.5, -1.5, 1.9, -1.9]),
    st.floats(-2.0, 2.0, allow_nan=False),
)
torques = st.one_of(
    st.sampled_from([0.0, 0.2, 0.34, 0.35, 0.5, 0.8, -0.2, -0.5]),
    st.floats(-1.2, 1.2, allow_nan=False),
)
commands: st.SearchStrategy[Command] = st.one_of(
    st.builds(Clamp, halves, torques),
    st.builds(Unclamp, halves),
    st.builds(Drive, st.sampled_from([0.0, 0.05, -0.05, 0.1, -0.15])),
    st.builds(Rotate, st.sampled_from([0.0, 0.3, -0.3, 1.0, -3.2])),
    st.builds(Bend, st.sampled_from(BENDS), joint_angles),
    st.builds(Tilt, st.sampled_from([0.0, 0.5, -0.5, 1.2, -1.2, 1.9])),
    st.builds(MoveFrontClear, st.sampled_from([1, -1])),
    st.just(Stop()),
    st.builds(
        lambda motor, mode, value: Raw(MotorCommand(motor, mode, value)),
        st.sampled_from(JOINTS),
        st.sampled_from([ControlMode.TORQUE, ControlMode.POSITION]),
        st.one_of(torques, joint_angles),
    ),
)


def _tilt(sup: Supervisor) -> float:
    state = sup.state()
    tilt = state.front_tilt_rad if state is not None else None
    return tilt if tilt is not None else 0.0


class SimSupervisedRobot(RuleBasedStateMachine):
    """One simulated robot behind one supervisor per example."""

    def __init__(self) -> None:
        super().__init__()
        self.clock = SimClock()
        self.sup: Supervisor | None = None
        self.setup_end_s = math.inf  # until the set-up is done

    # -- set-up -----------------------------------------------------------------

    @initialize(
        world=st.sampled_from(sorted(WORLDS)),
        start=st.sampled_from(["free", "rear", "front", "both"]),
    )
    def start(self, world: str, start: str) -> None:
        self.sup = open_supervisor(ROBOT, clock=self.clock, network=WORLDS[world])
        sup = self.sup
        if world == "riser" and start == "free":
            start = "rear"  # a free robot halfway up a riser falls before anyone acts
        # Reach the start configuration through the supervisor, as a tree would: on the
        # riser the rear half clamps first (nothing else may move there before it holds).
        clamp = [h for h in Half if start in (h.value, "both")]
        if world == "riser" and Half.FRONT in clamp:
            clamp = [Half.REAR, Half.FRONT]
        for half in clamp:
            if half is Half.FRONT:
                self._until(lambda: bool(sup.command(MoveFrontClear(1))) and _tilt(sup) >= CLEAR)
            assert sup.command(Clamp(half, CLAMP_NM)).ok
            if world == "riser" or half is clamp[-1]:
                self._until(lambda h=half: sup.half_states()[h].value == "clamped")  # type: ignore[misc]
        self._tick()
        self.setup_end_s = self.clock.now()

    # -- helpers ----------------------------------------------------------------

    @property
    def s(self) -> Supervisor:
        assert self.sup is not None
        return self.sup

    def _tick(self, n: int = 1) -> None:
        for _ in range(n):
            self.clock.advance(TICK_S)
            self.s.tick()

    def _until(self, done: Callable[[], bool], limit_s: float = 3.0) -> None:
        deadline = self.clock.now() + limit_s
        while not done():
            assert self.clock.now() < deadline, self.s.half_states()
            self._tick()

    def _preventable(self) -> list[SimEvent]:
        sim = self.s.simulator
        assert sim is not None
        out = []
        for event in sim.events():
            if event.kind not in (EventKind.VIOLATION, EventKind.DAMAGE):
                continue
            if event.time_s <= self.setup_end_s:
                continue
            out.append(event)
        return out

    # -- rules ------------------------------------------------------------------

    @rule(
        command=commands,
        by_operator=st.booleans(),
        ticks=st.sampled_from([1, 2, 4, 10]),
    )
    def hold(self, command: Command, by_operator: bool, ticks: int) -> None:
        """Send a command and re-send it every tick, as a primitive does."""
        source = Source.OPERATOR if by_operator else Source.TREE
        for _ in range(ticks):
            verdict = self.s.command(command, source=source)
            assert verdict.ok or not verdict.sent
            if not verdict.ok:
                break
            self._tick()

    @rule(mode=st.sampled_from([Mode.AUTONOMOUS, Mode.SUPERVISED, Mode.MANUAL]))
    def set_mode(self, mode: Mode) -> None:
        self.s.set_mode(mode)

    @rule()
    def estop(self) -> None:
        self.s.estop("test")

    @rule()
    def reset_estop(self) -> None:
        self.s.reset_estop()

    @rule()
    def safe_state(self) -> None:
        self.s.safe_state("test")

    @rule()
    def resume(self) -> None:
        self.s.resume()

    @rule(ticks=st.sampled_from([1, 4]))
    def wait(self, ticks: int) -> None:
        self._tick(ticks)

    @invariant()
    def no_preventable_event(self) -> None:
        if self.sup is not None:
            assert not self._preventable(), self._preventable()

    def teardown(self) -> None:
        if self.sup is None:
            return
        try:
            self._tick(round(SETTLE_S / TICK_S))
            assert not self._preventable(), self._preventable()
        finally:
            self.sup.close()


SimSupervisedRobot.TestCase.settings = settings(
    max_examples=max(1000, settings.default.max_examples), stateful_step_count=10
)
test_supervisor_keeps_the_simulator_safe = SimSupervisedRobot.TestCase
# about 10 s: started first, so that it cannot be the last test left on a worker
test_supervisor_keeps_the_simulator_safe.pytestmark = [pytest.mark.slow]
