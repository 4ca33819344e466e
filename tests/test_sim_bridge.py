"""The simulated bridge behind the real wire protocol, in process on a shared SimClock."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest
import serial

from pirate_bt.clock import SimClock
from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.link import (
    Ack,
    AckStatus,
    BridgeFlags,
    EStop,
    EStopReset,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    Nack,
    NackCode,
    Setpoint,
    State,
    open_link,
)
from pirate_bt.pipes import network_from_data
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import CommandCodec, MotorCommand
from pirate_bt.robot.description import ControlMode, Half
from pirate_bt.sim import SensorNoise, Simulator, format_fault, parse_fault

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)


@pytest.fixture
def clock() -> SimClock:
    return SimClock()


@pytest.fixture
def sim(clock: SimClock) -> Iterator[Simulator]:
    with Simulator("straight", ROBOT, clock=clock, seed=1) as simulator:
        yield simulator


class RawHost:
    """Talks bytes to a simulator through the sim:// URL, with the link's codec."""

    def __init__(self, url: str, clock: SimClock) -> None:
        self.port = serial.serial_for_url(url, timeout=0)
        self.clock = clock
        self.decoder = FrameDecoder(CODEC)
        self.seq = 1

    def send(self, msg: Message) -> None:
        self.port.write(CODEC.encode(msg))

    def receive(self) -> list[Message]:
        out: list[Message] = []
        for item in self.decoder.feed(self.port.read(100_000)):
            assert isinstance(item, Message.__args__)  # type: ignore[attr-defined]
            out.append(item)  # type: ignore[arg-type]
        return out

    def replies(self) -> list[Message]:
        return [m for m in self.receive() if not isinstance(m, State)]


def test_host_link_drives_the_simulated_robot(sim: Simulator, clock: SimClock) -> None:
    link = open_link(sim.url, ROBOT, clock)
    try:
        clamp = [MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.6) for i in (3, 4)]
        link.send(clamp)
        for _ in range(150):
            clock.advance(0.01)
            link.poll()
        state = link.state()
        assert state is not None
        contact = ROBOT.clamp.contact_angle(0.063)
        assert state.joint_angle_rad["bend_3"] == pytest.approx(contact, abs=0.01)
        assert state.clamp_force_n["bend_3"] == pytest.approx(0.6 / 0.04, abs=0.1)
        start = sim.truth().front_m
        link.send([MotorCommand(m.name, ControlMode.VELOCITY, 0.08) for m in ROBOT.drive_motors()])
        for _ in range(500):
            clock.advance(0.01)
            link.poll()
        assert sim.truth().front_m - start == pytest.approx(0.4, abs=0.03)
        state = link.state()
        assert state is not None
        assert state.mean_drive_velocity_mps() == pytest.approx(0.08, abs=0.002)
        counters = sim.counters()
        assert counters.frames_received > 0
        assert counters.commands_executed >= 8
        assert counters.frames_rejected == 0
        assert counters.state_frames_sent == pytest.approx(650, abs=5)
    finally:
        link.close()


def test_watchdog_stops_drives_and_holds_clamps(sim: Simulator, clock: SimClock) -> None:
    link = open_link(sim.url, ROBOT, clock)
    clamp = [MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.6) for i in (3, 4)]
    link.send(clamp)
    link.send([MotorCommand(m.name, ControlMode.VELOCITY, 0.08) for m in ROBOT.drive_motors()])
    for _ in range(200):
        clock.advance(0.01)
        link.poll()
    assert sim.counters().watchdog_trips == 0
    clock.advance(0.2)  # silent, but within the watchdog
    assert sim.counters().watchdog_trips == 0
    moving = sim.truth().front_m
    clock.advance(1.0)  # the host went silent
    truth = sim.truth()
    assert sim.counters().watchdog_trips == 1
    assert truth.front_m < moving + 0.08 * 0.35
    assert truth.velocity_mps == 0.0
    assert truth.halves[Half.REAR].clamped  # clamps held
    link.close()


def test_no_watchdog_while_the_host_polls(sim: Simulator, clock: SimClock) -> None:
    link = open_link(sim.url, ROBOT, clock)
    for _ in range(300):
        clock.advance(0.01)
        link.poll()  # sends heartbeats when idle
    assert sim.counters().watchdog_trips == 0
    link.close()


def test_lossy_line_keeps_the_drives_running() -> None:
    """drop 5 %/corrupt 1 % on the host link: the bridge's watchdog never trips.

    The rear half clamped and every drive commanded, then a long idle stretch with
    the host polling every 10 ms; four seeds x 40 s.
    """
    for seed in range(4):
        clock = SimClock()
        with Simulator("straight", ROBOT, clock=clock, seed=seed) as sim:
            link = open_link(sim.url, ROBOT, clock, faults=f"drop=0.05,corrupt=0.01,seed={seed}")
            link.send([MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.6) for i in (3, 4)])
            for _ in range(50):
                clock.advance(0.01)
                link.poll()
            drive = [MotorCommand(m.name, ControlMode.VELOCITY, 0.02) for m in ROBOT.drive_motors()]
            link.send(drive)
            start_m = sim.truth().front_m
            for _ in range(4000):
                clock.advance(0.01)
                link.poll()
            assert sim.counters().watchdog_trips == 0, f"seed {seed}"
            assert sim.truth().front_m > start_m + 0.5, f"seed {seed}"
            link.close()


def test_raw_protocol_answers(sim: Simulator, clock: SimClock) -> None:
    host = RawHost(sim.url, clock)
    host.send(Hello(1, CODEC.layout.digest))
    (reply,) = host.replies()
    assert isinstance(reply, HelloReply)
    assert reply.layout_digest == ROBOT.layout_digest()
    assert reply.flags & BridgeFlags.ESTOP and reply.sessions == 1  # booted latched
    host.send(EStopReset(2))
    assert host.replies() == [Ack(2, 0x06, AckStatus.APPLIED)]
    raw = CommandCodec(ROBOT).to_raw(MotorCommand("bend_1_joint", ControlMode.POSITION, 0.5))
    setpoint = Setpoint(3, raw.board, raw.slot, raw.mode, raw.raw_value)
    host.send(setpoint)
    host.send(setpoint)  # a retry after a lost ack
    host.send(Setpoint(4, 99, 0, ControlMode.POSITION, 0))
    host.send(Setpoint(5, raw.board, 0, ControlMode.VELOCITY, 0))
    host.send(Heartbeat(5))  # untracked: its own counter, never filtered
    assert host.replies() == [
        Ack(3, 0x02, AckStatus.APPLIED),
        Ack(3, 0x02, AckStatus.DUPLICATE),
        Nack(4, 0x02, NackCode.BAD_BOARD),
        Nack(5, 0x02, NackCode.BAD_MODE),
        Ack(5, 0x04, AckStatus.APPLIED),
    ]
    clock.advance(1.0)
    assert sim.truth().joint_angle_rad["bend_1_joint"] == pytest.approx(0.5, abs=0.002)
    wire = bytearray(CODEC.encode(Heartbeat(6)))
    wire[3] ^= 0x40  # corrupt a byte: CRC error
    host.port.write(bytes(wire))
    host.send(EStop(7))
    host.send(Setpoint(8, raw.board, raw.slot, raw.mode, raw.raw_value))
    assert host.replies() == [Ack(7, 0x05), Nack(8, 0x02, NackCode.ESTOP_LATCHED)]
    clock.advance(0.02)
    states = [m for m in host.receive() if isinstance(m, State)]
    assert states and states[-1].flags & BridgeFlags.ESTOP
    # the e-stop held the bend joint where it was (the clamps keep holding)
    assert sim.truth().joint_angle_rad["bend_1_joint"] == pytest.approx(0.5, abs=0.002)
    counters = sim.counters()
    assert counters.frames_rejected == 4  # two NACKs, a CRC error, the NACK under e-stop
    assert counters.commands_executed == 1


def test_board_reset_and_sensor_faults(clock: SimClock) -> None:
    faults = ["board_reset:22@0.5s", "sensor_stuck:rotation_angle@0.1s", "link_loss@3s+0.5s"]
    with Simulator("straight", ROBOT, clock=clock, faults=faults) as sim:
        host = RawHost(sim.url, clock)
        host.send(Hello(1, CODEC.layout.digest))
        clock.advance(0.6)
        states = [m for m in host.receive() if isinstance(m, State)]
        last = states[-1].readings()
        names = [c.name for c in ROBOT.state_channels()]
        assert last[names.index("bend_1_angle")] is None  # board 22 is rebooting
        assert last[names.index("bend_3_angle")] is not None
        clock.advance(1.6)  # reset_time 1.5 s has passed
        host.send(Heartbeat(2))
        last = [m for m in host.receive() if isinstance(m, State)][-1].readings()
        assert last[names.index("bend_1_angle")] is not None
        before = sim.counters().state_frames_sent
        host.receive()
        clock.advance(1.0)  # 0.2 s into the link loss
        host.receive()
        host.send(Heartbeat(3))
        assert host.receive() == []
        assert sim.counters().frames_dropped == 1
        assert sim.counters().state_frames_sent == pytest.approx(before + 80, abs=1)
        clock.advance(0.5)
        assert host.receive()
        kinds = [e.detail for e in sim.events()]
        assert "start board_reset 22" in kinds and "end link_loss" in kinds


def test_motor_stall_fault(clock: SimClock) -> None:
    with Simulator("straight", ROBOT, clock=clock, faults=["motor_stall:bend_3_joint@0s"]) as sim:
        sim.model.command(MotorCommand("bend_3_joint", ControlMode.POSITION, 1.0))
        sim.model.command(MotorCommand("bend_4_joint", ControlMode.POSITION, 1.0))
        clock.advance(2.0)
        angles = sim.truth().joint_angle_rad
        assert angles["bend_3_joint"] == 0.0
        assert angles["bend_4_joint"] == pytest.approx(1.0)


def test_faults_from_the_network_file(clock: SimClock) -> None:
    net = network_from_data(
        {
            "name": "faulty",
            "diameter": "63 mm",
            "segments": [{"type": "straight", "length": "2 m"}],
            "faults": [{"kind": "sensor_dropout", "target": "bend_3_spring", "at": "0.1 s"}],
        }
    )
    with Simulator(net, ROBOT, clock=clock) as sim:
        host = RawHost(sim.url, clock)
        clock.advance(0.2)
        last = [m for m in host.receive() if isinstance(m, State)][-1].readings()
        names = [c.name for c in ROBOT.state_channels()]
        assert last[names.index("bend_3_spring")] is None
        assert last[names.index("bend_4_spring")] is not None


def test_fault_text_and_checks() -> None:
    fault = parse_fault("motor_stall:bend_1_drive@3s+500ms")
    assert (fault.kind, fault.target, fault.at, fault.duration) == (
        "motor_stall",
        "bend_1_drive",
        3.0,
        0.5,
    )
    assert parse_fault(format_fault(fault)) == fault
    with pytest.raises(InputError):
        parse_fault("meteor@3s")
    with pytest.raises(InputError):
        parse_fault("board_reset@3s")
    # at 0 s is a time (the start); a negative one was "times must be positive" (probe 12)
    assert parse_fault("link_loss@0s").at == 0.0
    with pytest.raises(InputError, match=r"its time must not be negative$"):
        parse_fault("link_loss@-1s")
    with pytest.raises(InputError, match=r"its duration must be positive$"):
        parse_fault("motor_stall:bend_1_drive@1s+0s")
    with pytest.raises(ConfigurationError, match="unknown motor"):
        Simulator("straight", ROBOT, faults=["motor_stall:warp_drive@1s"])


def test_same_seed_same_bytes() -> None:
    def run(seed: int) -> bytes:
        clock = SimClock()
        with Simulator("bend-up", ROBOT, clock=clock, seed=seed, noise=SensorNoise.typical()) as s:
            host = RawHost(s.url, clock)
            host.send(Hello(1, CODEC.layout.digest))
            clock.advance(0.5)
            return bytes(host.port.read(1_000_000))

    assert run(5) == run(5)
    assert run(5) != run(6)


def test_unknown_simulator_name_is_refused() -> None:
    with pytest.raises(serial.SerialException, match="no simulator named"):
        serial.serial_for_url("sim://nobody")
    assert math.isfinite(ROBOT.bridge.watchdog)


def test_fast_state_encoding_matches_state_builder(clock: SimClock) -> None:
    with Simulator("bend-up", ROBOT, clock=clock, noise=SensorNoise.typical(), seed=2) as sim:
        sim.model.command(MotorCommand("bend_3_joint", ControlMode.TORQUE, 0.6))
        clock.advance(0.5)
        values = sim.model.reading_values()
        names = [c.name for c in ROBOT.state_channels()]
        expected = sim.bridge.encode_readings(dict(zip(names, values, strict=True)))
        assert sim.bridge._encode(values) == expected


def test_counters_are_cached_until_a_figure_changes(clock: SimClock) -> None:
    with Simulator("straight", ROBOT, clock=clock, seed=2) as sim:
        link = open_link(sim.url, ROBOT, clock, faults="drop=0.05,corrupt=0.05,seed=2")
        first = sim.counters()
        assert sim.counters() is first  # nothing happened in between
        link.send([MotorCommand(f"bend_{i}_joint", ControlMode.TORQUE, 0.6) for i in (3, 4)])
        drive = [MotorCommand(m.name, ControlMode.VELOCITY, 0.02) for m in ROBOT.drive_motors()]
        for n in range(300):
            if n == 50:
                link.send(drive)
            clock.advance(0.01)
            link.poll()
            counters = sim.counters()
            # Never stale: always what the bridge and model report now.
            assert counters == sim.bridge.counters()
            assert sim.counters() is counters
        assert counters.distance_m > 0 and counters.frames_rejected > 0
        # Figures changed without the clock moving are still seen.
        before = sim.counters()
        sim.bridge.nacks += 1
        sim.model._violation("sliding", "injected by the test")
        after = sim.counters()
        assert after is not before
        assert after.frames_rejected == before.frames_rejected + 1
        assert after.violations == {
            **before.violations,
            "sliding": before.violations.get("sliding", 0) + 1,
        }
        assert after == sim.bridge.counters()
        link.close()
