"""Session and RobotLink against the reference bridge: in memory on a SimClock, and over a pty."""

from __future__ import annotations

import collections
import os
from pathlib import Path

import pytest

from pirate_bt.clock import SimClock, WallClock
from pirate_bt.errors import LinkError, LinkLost, LinkTimeout, ProtocolMismatch
from pirate_bt.link import (
    ByteLink,
    EStop,
    FrameCodec,
    MsgType,
    Outcome,
    RobotLink,
    open_link,
    wrap_link,
)
from pirate_bt.link.closing import RequestsFailed
from pirate_bt.link.inbound import STATE_REFUSALS
from pirate_bt.link.testing import FdPort, memory_pair
from pirate_bt.robot import ControlMode, MotorCommand, RobotPort, load_robot
from pirate_bt.robot.port import LinkHealth
from pirate_bt.sim.bridge_port import BridgeOnPort, bridge_for

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
FAULTS = "drop=0.1,corrupt=0.03,dup=0.05,reorder=0.03,delay=2ms,jitter=3ms"


def connect(faults: str | None = None, seed: int = 0) -> tuple[RobotLink, BridgeOnPort, SimClock]:
    clock = SimClock()
    host, far = memory_pair()
    bridge = BridgeOnPort(far, bridge_for(ROBOT))
    clock.add_listener(bridge.step)
    spec = f"{faults},seed={seed}" if faults else None
    return wrap_link(host, ROBOT, clock, faults=spec), bridge, clock


def check_exactly_once(link: RobotLink, bridge: BridgeOnPort, n: int) -> collections.Counter[str]:
    session = link.session
    requests = []
    for i in range(n):
        req = session.send_setpoint(22, 1, ControlMode.VELOCITY, i)
        session.wait(req)
        requests.append(req)
    applied = collections.Counter(
        seq for kind, seq in applied_of(bridge) if kind == MsgType.SETPOINT
    )
    outcomes: collections.Counter[str] = collections.Counter()
    for req in requests:
        assert req.done, req  # never silently dropped
        outcomes[req.outcome.value] += 1
        assert applied[req.seq] <= 1  # never twice
        if req.outcome is Outcome.ACKED:
            assert applied[req.seq] == 1  # acked means applied, exactly once
        else:
            assert req.outcome is Outcome.FAILED
    assert set(applied) <= {r.seq for r in requests}
    return outcomes


def applied_of(bridge: BridgeOnPort) -> list[tuple[MsgType, int]]:
    applied = bridge.bridge.applied
    assert applied is not None
    return applied


def test_robot_link_is_a_robot_port() -> None:
    link, _, _ = connect()
    assert isinstance(link, RobotPort)
    assert link.robot is ROBOT
    assert link.health().connected


def test_state_arrives_in_si_units() -> None:
    link, _bridge, clock = connect()
    link.send_and_wait([MotorCommand("bend_1_joint", ControlMode.POSITION, 0.5)])
    clock.sleep(1.0)
    link.poll()
    state = link.state()
    assert state is not None
    assert state.value("bend_1_angle") == pytest.approx(0.5, abs=0.01)
    assert state.stamp_s == pytest.approx(clock.now(), abs=0.011)


def test_send_becomes_one_bulk_frame_with_keep_for_the_rest() -> None:
    link, bridge, _ = connect()
    motor = ROBOT.drive_motors()[0].name
    executed = bridge.bridge.commands_executed
    link.send_and_wait([MotorCommand(motor, ControlMode.VELOCITY, 0.02)])
    bulks = [seq for kind, seq in applied_of(bridge) if kind == MsgType.BULK_SETPOINTS]
    assert len(bulks) == 1
    assert bridge.bridge.commands_executed == executed + 1  # every other motor: keep
    assert link.health().rtt_s > 0


def test_clean_link_delivers_everything_once() -> None:
    link, bridge, _ = connect()
    outcomes = check_exactly_once(link, bridge, 50)
    assert outcomes == {"acked": 50}
    assert link.health().retries == 0


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_faulty_link_never_twice_never_silent(seed: int) -> None:
    link, bridge, _ = connect(FAULTS, seed)
    outcomes = check_exactly_once(link, bridge, 150)
    health = link.health()
    assert outcomes["acked"] >= 140
    assert health.retries > 0 and health.crc_errors > 0


def test_bulk_setpoints_supersede_and_are_acked_by_state() -> None:
    link, bridge, clock = connect(FAULTS, 5)
    motor = ROBOT.drive_motors()[0].name
    for i in range(200):
        link.send([MotorCommand(motor, ControlMode.VELOCITY, 0.001 * i)])
        clock.sleep(0.01)
        link.poll()
    link.send_and_wait([MotorCommand(motor, ControlMode.VELOCITY, 0.0)])
    seqs = [seq for kind, seq in applied_of(bridge) if kind == MsgType.BULK_SETPOINTS]
    assert len(seqs) == len(set(seqs))  # never applied twice
    assert seqs == sorted(seqs)  # never an older one after a newer one
    stats = link.session.stats()
    assert stats.failed == 0 and stats.superseded + stats.sent > 0


def test_link_loss_detected_in_time() -> None:
    link, bridge, clock = connect()
    clock.sleep(0.05)
    link.poll()
    bridge.silent = True
    silent_from = clock.now()
    with pytest.raises(LinkLost):
        while True:
            link.poll()
            clock.sleep(0.001)
    timeout = link.session.config.link_timeout_s
    assert clock.now() - silent_from <= timeout + 0.02
    assert not link.health().connected
    with pytest.raises(LinkLost):
        link.send([])


def test_estop_skips_the_queue_and_cancels_it() -> None:
    link, bridge, clock = connect()
    session = link.session
    queued = [session.send_setpoint(22, 1, ControlMode.VELOCITY, i) for i in range(5)]
    link.estop()
    assert [r.outcome for r in queued] == [Outcome.CANCELLED] * 5
    clock.sleep(0.05)
    link.poll()
    kinds = [kind for kind, _ in applied_of(bridge)]
    # the boot latch's release, then the first setpoint (already on the wire), then the
    # e-stop; the four queued ones never went out
    assert kinds == [MsgType.ESTOP_RESET, MsgType.SETPOINT, MsgType.ESTOP]
    assert link.health().estopped
    assert session.take_failures() == []  # cancelled by the caller's own e-stop
    with pytest.raises(LinkError, match="ESTOP_LATCHED"):
        link.send_and_wait([])
    link.reset_estop()
    clock.sleep(0.02)
    link.poll()
    assert not link.health().estopped


def test_estop_cancels_a_reset_in_flight() -> None:
    link, _bridge, clock = connect()
    session = link.session
    link.estop()
    session.wait(link.session.estop_reset())  # the operator resets...
    reset = session.estop_reset()  # ...and resets again, but an e-stop overtakes it
    link.estop()
    assert reset.outcome is Outcome.CANCELLED
    clock.sleep(0.1)
    link.poll()
    assert link.health().estopped  # the newer e-stop stands


def test_waits_are_bounded() -> None:
    link, bridge, clock = connect()
    bridge.silent = True
    session = link.session
    req = session.send_setpoint(22, 1, ControlMode.VELOCITY, 1)
    start = clock.now()
    with pytest.raises(LinkTimeout):
        session.wait(req, timeout_s=0.01)
    assert clock.now() - start <= 0.01 + 1e-9
    session.wait(req)
    assert req.outcome is Outcome.FAILED and req.tries == session.config.max_retries + 1
    assert clock.now() - start <= session.config.give_up_s + 0.01


def test_duplicate_state_frames_are_counted() -> None:
    link, _, clock = connect("dup=0.5,direction=rx", 4)
    for _ in range(50):
        clock.sleep(0.01)
        link.poll()
    assert link.health().duplicates > 10


def test_counters_request() -> None:
    link, _, _ = connect()
    req = link.session.wait(link.session.request_counters())
    assert req.reply is not None and req.reply.rx_frames >= 2
    assert len(req.reply.boards) == len(ROBOT.board_ids())


class _Answers:
    """A far end that answers every frame with the same bytes (a misbehaving bridge)."""

    def __init__(self, port: ByteLink, wire: bytes) -> None:
        self.port = port
        self.wire = wire

    def step(self, now_s: float) -> None:
        if self.port.read_available():
            self.port.write(self.wire)


def _with_version(wire: bytes, version: int) -> bytes:
    import binascii

    from pirate_bt.link.codec import cobs_decode, cobs_encode

    body = bytearray(cobs_decode(wire[:-1]))
    body[0] = version
    body[-2:] = binascii.crc_hqx(bytes(body[:-2]), 0).to_bytes(2, "little")
    return cobs_encode(bytes(body)) + b"\x00"


def test_handshake_refuses_other_layout_and_version() -> None:
    # a bridge built for another layout: NACK BAD_LAYOUT
    other = load_robot(Path(__file__).parents[1] / "hardware/variants/pirate-rear-imu.yaml")
    assert other.layout_digest() != ROBOT.layout_digest()
    clock = SimClock()
    host, far = memory_pair()
    clock.add_listener(BridgeOnPort(far, bridge_for(load_robot())).step)
    with pytest.raises(ProtocolMismatch, match="BAD_LAYOUT"):
        wrap_link(host, other, clock)
    # a bridge of another major version, and one of another minor version
    from pirate_bt.link import HelloReply

    lay = CODEC.layout
    reply = HelloReply(1, lay.digest, lay.n_channels, lay.n_motors, 250, 0x0100, 1, 7, 1)
    for wire, match in (
        (_with_version(CODEC.encode(reply), 2), "version"),
        # the host asked for 1.2 (its default) and is answered 1.1 without a refusal
        (CODEC.encode(HelloReply(1, lay.digest, lay.n_channels, lay.n_motors, 250, 0, 1)), "1.1"),
    ):
        clock = SimClock()
        host, far = memory_pair()
        clock.add_listener(_Answers(far, wire).step)
        with pytest.raises(ProtocolMismatch, match=match):
            wrap_link(host, ROBOT, clock)


def test_a_1_1_bridge_gets_a_1_1_session_and_another_layout_is_still_refused() -> None:
    clock = SimClock()
    host, far = memory_pair()
    bridge = bridge_for(ROBOT)
    bridge.max_minor = 1  # an older bridge: refuses a 1.2 HELLO like another layout
    clock.add_listener(BridgeOnPort(far, bridge).step)
    link = wrap_link(host, ROBOT, clock)
    try:
        assert link.session.last_hello_reply is not None
        assert link.session.last_hello_reply.minor == 1
        assert link.session.config.protocol_minor == 1  # a later re-HELLO asks for 1.1 too
        assert link.health().connected and not link.health().estop_input
    finally:
        link.close()
    other = load_robot(Path(__file__).parents[1] / "hardware/variants/pirate-rear-imu.yaml")
    clock = SimClock()
    host, far = memory_pair()
    bridge = bridge_for(load_robot())
    bridge.max_minor = 1
    clock.add_listener(BridgeOnPort(far, bridge).step)
    with pytest.raises(ProtocolMismatch, match=r"BAD_LAYOUT.*another robot description"):
        wrap_link(host, other, clock)


def test_a_host_speaks_1_2_by_default_and_hears_the_estop_input() -> None:
    link, bridge, clock = connect()
    try:
        assert link.session.last_hello_reply is not None
        assert link.session.last_hello_reply.minor == 2
        bridge.bridge.set_estop_input(True)
        deadline = clock.now() + 0.5
        while not link.health().estop_input and clock.now() < deadline:
            clock.sleep(0.01)
            link.poll()
        health = link.health()
        assert health.estopped and health.estop_input
    finally:
        link.close()


def test_handshake_times_out_on_a_silent_bridge() -> None:
    clock = SimClock()
    host, far = memory_pair()
    bridge = BridgeOnPort(far, bridge_for(ROBOT))
    bridge.silent = True
    clock.add_listener(bridge.step)
    with pytest.raises(LinkTimeout):
        wrap_link(host, ROBOT, clock)
    assert clock.now() < 2.0


def test_close_stops_the_drives() -> None:
    link, bridge, clock = connect()
    drive = ROBOT.drive_motors()[0].name
    link.send_and_wait([MotorCommand(drive, ControlMode.VELOCITY, 0.05)])
    clock.sleep(0.5)
    link.close()
    assert applied_of(bridge)[-1][0] == MsgType.BULK_SETPOINTS
    clock.sleep(0.5)
    assert bridge.bridge.model.truth().velocity_mps == 0.0


# --- over a pty, with a bridge thread on the far end -----------------------------------------


def pty_link(faults: str | None) -> tuple[RobotLink, BridgeOnPort, int]:
    master, slave = os.openpty()
    path = os.ttyname(slave)
    clock = WallClock()
    bridge = BridgeOnPort(FdPort(master), bridge_for(ROBOT, start_s=clock.now()))
    bridge.start(clock)
    link = open_link(path, ROBOT, clock, faults=faults, reset_wait_s=0.0, threaded=True)
    return link, bridge, slave


def test_pty_with_faults_exactly_once() -> None:
    link, bridge, slave = pty_link(FAULTS + ",seed=11")
    try:
        outcomes = check_exactly_once(link, bridge, 60)
        assert outcomes["acked"] >= 55
        assert link.state() is not None
    finally:
        link.close()
        bridge.stop()
        os.close(slave)
        bridge.port.close()  # type: ignore[attr-defined]


def test_pty_link_loss_with_reader_thread() -> None:
    link, bridge, slave = pty_link(None)
    try:
        bridge.silent = True
        clock = WallClock()
        start = clock.now()
        with pytest.raises(LinkLost):
            while clock.now() - start < 2.0:
                link.poll()
                clock.sleep(0.005)
        assert clock.now() - start < link.session.config.link_timeout_s + 0.2
    finally:
        link.close()
        bridge.stop()
        os.close(slave)
        bridge.port.close()  # type: ignore[attr-defined]


def test_estop_message_type_is_out_of_band() -> None:
    assert EStop.TYPE < 0x80


def _same_figures(a: object, b: object) -> bool:
    """Dataclass field values equal, nan equal to nan."""
    from dataclasses import astuple

    return all(
        x == y or (isinstance(x, float) and x != x and y != y)
        for x, y in zip(astuple(a), astuple(b), strict=True)  # type: ignore[call-overload]
    )


def test_health_is_cached_until_a_figure_changes() -> None:
    link, bridge, clock = connect(FAULTS, seed=4)
    first = link.health()
    assert link.health() is first  # nothing happened in between
    moves = [MotorCommand("bend_3_joint", ControlMode.TORQUE, 0.1 * (i % 5)) for i in range(120)]
    seen = {id(first)}
    for command in moves:
        link.send([command])
        clock.advance(0.01)
        link.poll()
        health = link.health()
        # Never stale: always the figures the session reports, built under its lock.
        s = link.session.stats()
        expected = LinkHealth(
            connected=s.connected,
            last_heard_s=s.last_heard_s,
            rtt_s=s.rtt_s,
            loss_ratio=s.loss_ratio,
            crc_errors=s.crc_errors,
            retries=s.retries,
            failed=s.failed,
            duplicates=s.duplicates,
            estopped=s.estopped,
            # once a STATE was taken, every one refused since the last one taken
            states_refused=tuple(
                (why, n)
                for why, n in zip(STATE_REFUSALS, link.session.refused_states(), strict=True)
                if n
            ),
            line_noise=s.line_noise,
        )
        assert _same_figures(health, expected)
        assert link.health() is health
        seen.add(id(health))
    assert len(seen) > 1
    check_exactly_once(link, bridge, 60)  # requests that need retries: the loss ratio moves
    health = link.health()
    assert health.retries > 0 and health.loss_ratio == link.session.stats().loss_ratio > 0
    # A figure changed behind the cache's back is still seen.
    before = link.health()
    link.session.retries += 1
    link.session.crc_errors += 2
    after = link.health()
    assert after is not before
    assert (after.retries, after.crc_errors) == (before.retries + 1, before.crc_errors + 2)
    link.session.close()
    assert link.health().connected is False


# --- sessions, bridge resets, stale answers (protocol 1.1) ------------------------------------


def test_a_bridge_reset_mid_session_is_seen_and_the_latch_kept() -> None:
    link, bridge, clock = connect()
    drive = ROBOT.drive_motors()[0].name
    link.send_and_wait([MotorCommand(drive, ControlMode.VELOCITY, 0.02)])
    bridge.bridge.reset()  # a brown-out: the bridge boots again, latched
    in_flight = link.session.send_bulk([None] * CODEC.layout.n_motors, [0] * CODEC.layout.n_motors)
    said = []
    for _ in range(20):
        clock.sleep(0.01)
        try:
            link.poll()
        except RequestsFailed as exc:  # the bulk in flight: said once, by a poll
            said.append(exc)
    assert len(said) == 1
    stats = link.session.stats()
    assert stats.bridge_resets == 1 and stats.sessions == 2
    assert in_flight.outcome in (Outcome.FAILED, Outcome.NACKED)  # never counted as delivered
    assert link.health().estopped  # the session does not release a latch it did not see set
    with pytest.raises(LinkError):
        link.send_and_wait([MotorCommand(drive, ControlMode.VELOCITY, 0.02)])
    link.reset_estop()
    link.send_and_wait([MotorCommand(drive, ControlMode.VELOCITY, 0.02)])
    assert link.state() is not None


def test_a_stale_answer_is_a_failure_never_an_ack() -> None:
    link, _, _ = connect()
    session = link.session
    session.wait(session.send_setpoint(22, 1, ControlMode.VELOCITY, 1))
    session._next_seq = 2  # white box: a request numbered below what the bridge has seen
    req = session.wait(session.send_setpoint(22, 1, ControlMode.VELOCITY, 2))
    assert req.outcome is Outcome.STALE
    assert session.take_failures() == [req]
    assert session.stats().stale == 1


def test_a_long_unanswered_stretch_starts_a_new_session() -> None:
    link, _, clock = connect()
    session = link.session
    session._next_seq = (session._answered + 16_384) & 0xFFFF  # white box: 16 384 lost
    req = session.wait(session.send_setpoint(22, 1, ControlMode.VELOCITY, 3))
    assert req.outcome is Outcome.FAILED  # queued when the session was renewed: reported
    assert session.take_failures() == [req]
    clock.sleep(0.02)
    link.poll()
    assert session.stats().sessions == 2
    req = session.wait(session.send_setpoint(22, 1, ControlMode.VELOCITY, 4))
    assert req.outcome is Outcome.ACKED


def test_connect_keeps_a_latch_left_by_an_earlier_session() -> None:
    clock = SimClock()
    sim_bridge = bridge_for(ROBOT)
    host, far = memory_pair()
    first = BridgeOnPort(far, sim_bridge)
    clock.add_listener(first.step)
    link = wrap_link(host, ROBOT, clock)
    assert not link.health().estopped  # the boot latch was released by the connect
    link.estop()
    clock.sleep(0.05)
    link.session.close()
    clock.remove_listener(first.step)
    host, far = memory_pair()
    second = BridgeOnPort(far, sim_bridge)  # another host process, the same bridge
    clock.add_listener(second.step)
    link = wrap_link(host, ROBOT, clock)
    clock.sleep(0.05)
    link.poll()
    assert link.health().estopped  # an operator's e-stop outlives the host that set it
