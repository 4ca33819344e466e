"""No command is lost silently, however long the session (issue 13): hours of virtual time.

The robot here is the bundled one with a 100 ms state period and a 500 ms watchdog,
so an hour of polling is 36 000 host cycles: more than the 32 768 heartbeats after
which a bridge that let heartbeats share its duplicate filter's counter refused
every setpoint as stale. Everything else (the supervisor, the link, the simulated
bridge and physics) is the real thing.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from pirate_bt.robot import load_robot
from pirate_bt.robot.description import Half
from pirate_bt.safety.commands import Bend, Clamp, Command, MoveFrontClear, Unclamp
from pirate_bt.safety.factory import open_supervisor
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.safety.verdict import Outcome

ROBOT = load_robot()
SLOW = ROBOT.model_copy(
    update={"bridge": ROBOT.bridge.model_copy(update={"state_period": 0.1, "watchdog": 0.5})}
)
POLL_S = SLOW.bridge.state_period


@pytest.fixture
def sup() -> Iterator[Supervisor]:
    supervisor = open_supervisor(SLOW, network="riser", seed=1)
    try:
        yield supervisor
    finally:
        supervisor.close()


def run(sup: Supervisor, seconds: float) -> None:
    """Tick the supervisor (which polls the link) for ``seconds`` of virtual time."""
    for _ in range(round(seconds / POLL_S)):
        sup.clock.sleep(POLL_S)
        sup.tick()


def idle(sup: Supervisor, seconds: float) -> None:
    """Poll the link only, as a paused tree runner does."""
    port = sup.port
    clock = sup.clock
    for _ in range(round(seconds / POLL_S)):
        clock.sleep(POLL_S)
        port.poll()


def repeat(sup: Supervisor, command: Command, seconds: float) -> None:
    """Send ``command`` every tick for ``seconds``, as a primitive does (rate limits clip)."""
    for _ in range(round(seconds / POLL_S)):
        verdict = sup.command(command)
        assert verdict.outcome in (Outcome.PASS, Outcome.CLIP), verdict
        sup.clock.sleep(POLL_S)
        sup.tick()


def clamp_both(sup: Supervisor) -> None:
    repeat(sup, MoveFrontClear(), 2.0)
    for half in (Half.FRONT, Half.REAR):
        repeat(sup, Clamp(half, 0.6), 1.0)
    run(sup, 1.0)
    truth = sup.simulator.truth()  # type: ignore[union-attr]
    assert truth.halves[Half.FRONT].clamped and truth.halves[Half.REAR].clamped


@pytest.mark.slow
def test_release_after_an_idle_hour_happens(sup: Supervisor) -> None:
    """Both halves clamped, an hour idle (the host only heartbeats), then the rear half
    is told to let go: it does (it stayed clamped in the bug of issue 13)."""
    sim = sup.simulator
    assert sim is not None
    clamp_both(sup)
    before = sim.counters().frames_received
    idle(sup, 3600.0)
    heard = sim.counters().frames_received - before
    assert heard > 32_768  # past the old bridge's wrap
    assert sim.counters().watchdog_trips == 0
    repeat(sup, Unclamp(Half.REAR), 3.0)
    truth = sim.truth()
    assert not truth.halves[Half.REAR].clamped  # the command happened
    assert truth.halves[Half.FRONT].clamped
    health = sup.port.health()
    assert health.connected and health.failed == 0
    assert sim.counters().violations == {}


@pytest.mark.slow
def test_long_session_every_command_applied_or_reported(sup: Supervisor) -> None:
    """Ten minutes of commands (a bend move every 30 s, heartbeats between): each one
    either moves the joint or is reported; none is lost silently."""
    sim = sup.simulator
    assert sim is not None
    clamp_both(sup)
    # the rear half holds; the front half lets go and bends its joints back and forth
    repeat(sup, Unclamp(Half.FRONT), 3.0)
    module = SLOW.bend_modules(Half.FRONT)[0].name
    joint = next(m.name for b in SLOW.boards if b.module == module for m in b.motors)
    applied = 0
    for i in range(20):
        target = 0.2 if i % 2 else -0.2
        repeat(sup, Bend(module, target), 2.0)
        angle = sim.truth().joint_angle_rad[joint]
        if angle == pytest.approx(target, abs=0.02):
            applied += 1
        else:  # not applied: then the link must have said so
            assert sup.port.health().failed > 0, f"move {i} lost silently"
        idle(sup, 28.0)
    assert applied == 20
    assert sim.counters().watchdog_trips == 0
    assert sup.port.health().failed == 0


@pytest.mark.slow
def test_a_long_mission_on_a_lossy_link_loses_no_command(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The whole lab mission (about 560 s, thousands of setpoints) over a link that drops
    5 % and corrupts 1 % of frames: every setpoint the host counts as acknowledged was
    applied by the bridge, and every other one ended as a reported failure or was
    superseded by a newer bulk."""
    from pathlib import Path

    from pirate_bt import simulate_mission
    from pirate_bt.link.messages import MsgType
    from pirate_bt.link.requests import Outcome as LinkOutcome
    from pirate_bt.link.session import Session
    from pirate_bt.sim.bridge import SimBridge

    applied: list[tuple[MsgType, int]] = []
    monkeypatch.setattr(
        SimBridge, "_record_applied", lambda _self, kind, seq: applied.append((kind, seq))
    )
    ended: list[tuple[str, int, LinkOutcome]] = []
    tries: list[int] = []
    finish = Session._finish

    def noting_finish(self: Session, req: object, outcome: LinkOutcome, now: float) -> None:
        if not req.done:  # type: ignore[attr-defined]
            ended.append((type(req.msg).__name__, req.seq, outcome))  # type: ignore[attr-defined]
            tries.append(req.tries)  # type: ignore[attr-defined]
        finish(self, req, outcome, now)  # type: ignore[arg-type]

    monkeypatch.setattr(Session, "_finish", noting_finish)
    route = Path(__file__).resolve().parent.parent / "scenarios" / "lab.route"
    result = simulate_mission(route, faults="drop=0.05,corrupt=0.01", seed=5)
    assert result.run.sim_time_s > 100  # a long run, whatever its outcome
    setpoints = [(name, seq, o) for name, seq, o in ended if name in ("Setpoint", "BulkSetpoints")]
    assert 300 < len(setpoints) < 65_536  # many, and no sequence wrap to confuse the check
    done = {seq for kind, seq in applied if kind in (MsgType.SETPOINT, MsgType.BULK_SETPOINTS)}
    acked = [seq for _, seq, o in setpoints if o is LinkOutcome.ACKED]
    assert acked and all(seq in done for seq in acked), "a setpoint acknowledged, not applied"
    others = {o for _, _, o in setpoints if o is not LinkOutcome.ACKED}
    reported = {LinkOutcome.FAILED, LinkOutcome.NACKED, LinkOutcome.STALE}
    assert others <= reported | {LinkOutcome.SUPERSEDED, LinkOutcome.CANCELLED}
    # The faults were real: requests were lost and sent again.
    assert max(tries) > 1
