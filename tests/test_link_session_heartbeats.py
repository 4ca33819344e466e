"""Heartbeats and the bridge's watchdog: the session keeps it fed whatever the line does.

Split from ``test_link_session.py`` (its ``connect`` and ``applied_of`` helpers are
shared): a clean, a lossy and a setpoint-eating line, a bridge whose watchdog is
shorter than the description's, and the derived timing.
"""

from __future__ import annotations

import pytest
from test_link_session import CODEC, ROBOT, applied_of, connect

from pirate_bt.clock import SimClock
from pirate_bt.link import (
    ByteLink,
    FrameDecoder,
    MsgType,
    Outcome,
    SessionConfig,
    Setpoint,
    wrap_link,
)
from pirate_bt.link.testing import memory_pair
from pirate_bt.robot import ControlMode, MotorCommand
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for


def test_heartbeats_keep_the_watchdog_fed() -> None:
    link, bridge, clock = connect()
    for _ in range(100):
        clock.sleep(0.01)
        link.poll()
    assert not bridge.bridge.watchdog_tripped
    assert link.session.stats().watchdog is False
    assert link.health().silent_for(clock.now()) < 0.02


LOSSY = "drop=0.05,corrupt=0.01"
SLOW_STATE = ROBOT.model_copy(
    update={"bridge": ROBOT.bridge.model_copy(update={"state_period": 0.05})}
)


def test_a_lossy_line_never_trips_the_watchdog() -> None:
    """5 % loss and 1 % corruption each way never silence the host for a watchdog period.

    The bridge trips only when every host frame of a whole watchdog period is lost,
    handshake included; 12 seeds x 60 s idle with a drive commanded, the host polling
    every 10 ms like a tree runner.
    """
    for seed in range(12):
        clock = SimClock()
        host, far = memory_pair()
        bridge = BridgeOnPort(far, bridge_for(SLOW_STATE))  # STATE rate is beside the point
        clock.add_listener(bridge.step)
        link = wrap_link(host, ROBOT, clock, faults=f"{LOSSY},seed={seed}")
        link.send([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.08)])
        for _ in range(6000):
            clock.sleep(0.01)
            link.poll()
        assert bridge.bridge.watchdog_trips == 0, f"seed {seed}"
        assert any(k == MsgType.BULK_SETPOINTS for k, _ in applied_of(bridge)), f"seed {seed}"
        assert link.health().connected


class _NoSetpoints:
    """A byte link that loses every host SETPOINT frame (and its retries) on the way out."""

    def __init__(self, inner: ByteLink) -> None:
        self.inner = inner
        self.baud = inner.baud
        self.lost = 0

    def read_available(self) -> bytes:
        return self.inner.read_available()

    def write(self, data: bytes) -> None:
        if any(isinstance(m, Setpoint) for m in FrameDecoder(CODEC).feed(data)):
            self.lost += 1
            return
        self.inner.write(data)

    def drain_input(self) -> int:
        return self.inner.drain_input()

    def close(self) -> None:
        self.inner.close()


def test_retried_setpoints_do_not_starve_heartbeats() -> None:
    """Requests retried to the end of their budget, back to back, never hold heartbeats back.

    Each setpoint is lost with all its retries (4 tries over about 240 ms); only the
    heartbeats reach the bridge, and they must keep coming meanwhile.
    """
    clock = SimClock()
    host, far = memory_pair()
    bridge = BridgeOnPort(far, bridge_for(ROBOT))
    clock.add_listener(bridge.step)
    lossy = _NoSetpoints(host)
    session = wrap_link(lossy, ROBOT, clock).session
    for i in range(8):
        req = session.wait(session.send_setpoint(22, 1, ControlMode.VELOCITY, i))
        assert req.outcome is Outcome.FAILED and req.tries == session.config.max_retries + 1
    assert clock.now() > 8 * session.config.give_up_s
    assert lossy.lost == 8 * (session.config.max_retries + 1)
    assert bridge.bridge.watchdog_trips == 0
    assert MsgType.SETPOINT not in [kind for kind, _ in applied_of(bridge)]


def test_heartbeats_follow_a_bridge_with_a_shorter_watchdog() -> None:
    # a bridge built with a 20 ms watchdog, a host whose description says 250 ms: the
    # host hears the bridge's own watchdog in HELLO_REPLY and heartbeats often enough
    # (every 30 ms, the description's pace at 10 ms polls, would trip it)
    quick = ROBOT.model_copy(update={"bridge": ROBOT.bridge.model_copy(update={"watchdog": 0.02})})
    clock = SimClock()
    host, far = memory_pair()
    bridge = BridgeOnPort(far, bridge_for(quick))
    clock.add_listener(bridge.step)
    link = wrap_link(host, ROBOT, clock)
    assert link.session.config.heartbeat_period_s == pytest.approx(0.002)
    for _ in range(100):
        clock.sleep(0.01)
        link.poll()
    assert bridge.bridge.watchdog_trips == 0
    assert link.session.stats().watchdog is False
    # a bridge with a longer watchdog than the description's changes nothing
    assert SessionConfig.from_robot(ROBOT).heeding(1000).heartbeat_period_s == 0.025


def test_heartbeat_period_is_well_inside_the_watchdog() -> None:
    cfg = SessionConfig.from_robot(ROBOT)
    assert cfg.heartbeat_period_s <= ROBOT.bridge.watchdog / 8
    # a retried request never spans the watchdog with heartbeats held back either
    assert cfg.heartbeat_period_s < cfg.ack_timeout_s
