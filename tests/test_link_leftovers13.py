"""Four leftovers of the host's link layer, each pinned by a test that failed before its fix.

1. A run whose closing stop, and the e-stop the close then sends, were never
   acknowledged ended with exit 0 and a log line: the robot may be left moving until
   the bridge's watchdog stops it. The link keeps the cause (``close_error``), and a
   run that opened its own connection is then a failure saying so, exit 3.
2. An ``ACK`` with a status the protocol does not have, answering the release of the
   boot latch, was dropped as a bad frame, and the connect ended on *did not
   acknowledge ... (failed; round trip too long?)*. It is a protocol mismatch now.
3. When STATE frames arrived but all were refused (bad CRC, another length, out of
   sequence), the connect ended on *no state from the robot within 5 s* and a run on
   *link_silent: no state frame from the bridge ...*: both now say the frames came and
   were refused, with the counts by reason.
4. ``ESTOP_INPUT`` without ``ESTOP`` (which docs/protocol.md rules out) was ignored; it
   is taken as latched now (the supervisor stops) and logged once.
"""

from __future__ import annotations

import binascii
import logging
import struct
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from session_wire import CODEC, CONFIG, Peer, Wire, state

import pirate_bt
from pirate_bt.api.connection import Connection
from pirate_bt.api.results import after_close
from pirate_bt.api.running import run_on
from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkError, LinkTimeout, ProtocolMismatch
from pirate_bt.link import framing
from pirate_bt.link.codec import (
    Ack,
    BridgeFlags,
    EStop,
    EStopReset,
    Heartbeat,
    Message,
    MsgType,
    State,
)
from pirate_bt.link.inbound import STATE_REFUSALS
from pirate_bt.link.opening import _release_boot_latch, wrap_link
from pirate_bt.link.robot_link import REFUSED_STATES_REPORTED, RobotLink
from pirate_bt.link.transport import Transport
from pirate_bt.robot import load_robot
from pirate_bt.safety.factory import wait_for_state
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.sim import Simulator
from pirate_bt.sim.bridge import SimBridge

ROBOT = load_robot()
STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"
MOVING = "the robot may still be moving until its bridge's watchdog stops it"
# a close whose frames are lost while the bridge's STATEs still come: they report its
# watchdog tripped by the end of the close (MOVING before tests/test_fix20_link.py's fix)
STOPPED = "the bridge reports its watchdog tripped, so its drives are stopped"
LOG = "pirate_bt.link.session"


def _heartbeats_only(msg: Message) -> list[Message]:
    """A bridge that keeps the link heard and answers nothing else."""
    return [Ack(msg.seq, MsgType.HEARTBEAT)] if isinstance(msg, Heartbeat) else []


def _raw_ack(seq: int, acked: int, status: int) -> bytes:
    """An ACK frame with any status byte (the codec encodes only the table's)."""
    body = struct.pack("<BBHB", 1, MsgType.ACK, seq, 0) + struct.pack("<BB", acked, status)
    return framing.cobs_encode(body + struct.pack("<H", binascii.crc_hqx(body, 0))) + b"\x00"


def _state_body(msg: State) -> bytearray:
    return bytearray(framing.cobs_decode(CODEC.encode(msg)[:-1]))


def _bad_crc(msg: State) -> bytes:
    body = _state_body(msg)
    body[-1] ^= 0xFF
    return framing.cobs_encode(bytes(body)) + b"\x00"


def _long_state(msg: State) -> bytes:
    """The STATE with one byte more than the layout's, its CRC good."""
    body = _state_body(msg)[:-2] + b"\x00"
    return framing.cobs_encode(bytes(body) + struct.pack("<H", binascii.crc_hqx(body, 0))) + b"\x00"


# -- 1. a close that could not stop the robot says so ------------------------------------------


def test_a_close_whose_stop_and_estop_are_never_answered_keeps_why() -> None:
    link = RobotLink(ROBOT, Peer(_heartbeats_only).session())
    link.close()  # never raises
    error = link.close_error
    assert isinstance(error, LinkError)
    assert str(error) == (
        f"the closing stop was never acknowledged, nor was the e-stop sent after it: {MOVING}"
    )
    assert link.session.stats().connected is False


def test_a_close_whose_estop_is_acknowledged_leaves_no_error() -> None:
    def bridge(msg: Message) -> list[Message]:
        if isinstance(msg, EStop):
            return [Ack(msg.seq, MsgType.ESTOP)]
        return _heartbeats_only(msg)  # the stop bulk is never acknowledged

    peer = Peer(bridge)
    link = RobotLink(ROBOT, peer.session())
    link.close()
    assert any(isinstance(m, EStop) for m in peer.seen) and link.close_error is None


def test_a_close_on_a_latched_bridge_sends_no_estop_and_leaves_no_error() -> None:
    peer = Peer(_heartbeats_only)
    session = peer.session()
    session._flags = BridgeFlags.ESTOP  # as the last STATE said
    link = RobotLink(ROBOT, session)
    link.close()
    assert not any(isinstance(m, EStop) for m in peer.seen) and link.close_error is None


def _deafen_at_the_end(runner: Any, connection: Any) -> None:
    """From the run's end on, the host's frames are lost on the way to the bridge."""

    def cut(_result: object) -> None:
        connection.supervisor._port.session.link.write = lambda data: None

    runner.add_finish(cut)


def test_a_run_whose_close_could_not_stop_the_robot_fails_with_exit_3() -> None:
    result = pirate_bt.simulate_tree(
        STRAIGHT, params={"distance": "0.2 m"}, observe=_deafen_at_the_end
    )
    assert result.loop is not None and result.loop.succeeded  # the tree itself succeeded
    assert result.status == "failure" and not result.succeeded
    assert (
        result.why.startswith("the closing stop was never acknowledged") and STOPPED in result.why
    )
    assert isinstance(result.close_error, LinkError)
    assert result.exit_code == 3
    assert "\n" not in result.summary() and "FAILURE - the closing stop" in result.summary()


def test_the_command_line_exits_3_naming_the_closing_stop(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    close = Connection.close

    def deaf_close(self: Connection) -> None:
        self.supervisor._port.session.link.write = lambda data: None
        close(self)

    monkeypatch.setattr(Connection, "close", deaf_close)
    argv = ["run", str(STRAIGHT), "--sim", "straight", "--param", "distance=0.2m", "--quiet"]
    assert main(argv) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert "the closing stop was never acknowledged" in err[-1] and STOPPED in err[-1]


def test_a_failed_run_keeps_its_first_cause_and_exits_3() -> None:
    result = pirate_bt.simulate_tree(
        STRAIGHT, params={"distance": "1 m"}, max_time="2 s", observe=_deafen_at_the_end
    )
    assert result.why.startswith("time limit of 2 s") and "; then the closing stop" in result.why
    assert result.exit_code == 3 and result.error is None


def test_after_close_leaves_a_result_alone_when_the_close_stopped_the_robot() -> None:
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "0.1 m"})
    assert result.succeeded and after_close(result, None) is result
    assert result.close_error is None and result.exit_code == 0


# -- 2. an unknown ACK status is a protocol mismatch, not a slow line -------------------------


class _OddAcks(Peer):
    """Answers ESTOP_RESET with ACK status ``status`` (the heartbeats as the protocol says)."""

    def __init__(self, status: int) -> None:
        super().__init__(_heartbeats_only)
        self.status = status

    def step(self, _now: float) -> None:
        for msg in self.decoder.feed(self.far.read_available()):
            if isinstance(msg, EStopReset):
                self.seen.append(msg)
                self.far.write(_raw_ack(msg.seq, MsgType.ESTOP_RESET, self.status))
            elif isinstance(msg, Heartbeat):
                self.far.write(CODEC.encode(Ack(msg.seq, MsgType.HEARTBEAT)))


@pytest.mark.parametrize("status", [5, 3, 255])
def test_a_release_answered_with_an_unknown_ack_status_is_a_protocol_mismatch(status: int) -> None:
    peer = _OddAcks(status)
    with pytest.raises(ProtocolMismatch) as exc:
        _release_boot_latch(peer.session(), 7, CONFIG.give_up_s)
    text = str(exc.value)
    assert f"the bridge answered ESTOP_RESET seq 2 with an unknown ACK status {status}" in text
    assert "protocol mismatch" in text and "round trip" not in text and "\n" not in text
    assert text.startswith("releasing the boot latch: ")
    assert exc.value.exit_code == 3
    assert len(peer.seen) == 1  # answered at once, not retried into a timeout


def test_an_unknown_ack_status_answering_nothing_in_flight_is_only_counted() -> None:
    wire = Wire()
    wire.far.write(_raw_ack(40, MsgType.ESTOP_RESET, 5))
    wire.poll(0.01)
    stats = wire.session.stats()
    assert stats.connected and stats.crc_errors == 1
    wire.session.ensure_alive()


def test_a_setpoint_answered_with_an_unknown_ack_status_ends_the_session() -> None:
    wire = Wire()
    req = wire.session.estop_reset()
    wire.far.write(_raw_ack(req.seq, MsgType.ESTOP_RESET, 9))
    with pytest.raises(ProtocolMismatch, match=r"unknown ACK status 9: a protocol mismatch"):
        wire.poll(0.01)


# -- 3. STATE frames that came but were all refused are named -------------------------------


def test_the_session_counts_the_states_it_refuses_by_reason_until_one_is_taken() -> None:
    wire = Wire()
    wire.answer(state(10))
    wire.poll(0.01)
    assert wire.session.refused_states() == (0, 0, 0, 0)
    wire.far.write(_bad_crc(state(11)) + _bad_crc(state(12)) + _long_state(state(13)))
    wire.answer(state(9), state(10))  # older, and the one held again
    wire.poll(0.01)
    assert wire.session.refused_states() == (2, 1, 2, 0)
    assert STATE_REFUSALS == (
        "with a bad CRC",
        "of another length",
        "out of sequence",
        "of another protocol version",
    )
    wire.answer(state(14))
    wire.poll(0.01)
    assert wire.session.refused_states() == (0, 0, 0, 0)


def test_a_damaged_frame_of_another_type_is_not_counted_as_a_state() -> None:
    wire = Wire()
    ack = bytearray(framing.cobs_decode(CODEC.encode(Ack(3, MsgType.HEARTBEAT))[:-1]))
    ack[-1] ^= 0xFF
    wire.far.write(framing.cobs_encode(bytes(ack)) + b"\x00")
    wire.poll(0.01)
    assert wire.session.refused_states() == (0, 0, 0, 0) and wire.session.crc_errors == 1


def test_link_health_reports_refused_states_from_a_run_of_them() -> None:
    wire = Wire()
    link = RobotLink(ROBOT, wire.session)
    # Before any STATE was taken (the connect) only a run of them: a few can be a
    # bridge at another baud rate. Once one was taken every one is (tests/test_fix20_link.py).
    for i in range(REFUSED_STATES_REPORTED):
        assert link.health().states_refused == ()
        wire.far.write(_bad_crc(state(11 + i)))
        wire.poll(0.01)
    health = link.health()
    assert health.states_refused == (("with a bad CRC", REFUSED_STATES_REPORTED),)
    assert health.states_refused_text() == (
        f"STATE frames arrived but all {REFUSED_STATES_REPORTED} were refused"
        f" ({REFUSED_STATES_REPORTED} with a bad CRC)"
    )
    wire.answer(state(30))
    wire.poll(0.01)
    assert link.health().states_refused == ()


class _DamagedStates:
    """The simulator's byte link with the CRC of every STATE broken from ``from_s`` on."""

    def __init__(self, inner: Transport, clock: SimClock, from_s: float) -> None:
        self.inner, self.clock, self.from_s = inner, clock, from_s
        self.baud = inner.baud
        self._held = b""

    def read_available(self) -> bytes:
        self._held += self.inner.read_available()
        *frames, self._held = self._held.split(b"\x00")
        out = bytearray()
        for frame in frames:
            if frame and self.clock.now() >= self.from_s:
                body = bytearray(framing.cobs_decode(frame))
                if len(body) > 2 and body[1] == MsgType.STATE:
                    body[-1] ^= 0xFF
                frame = framing.cobs_encode(bytes(body))
            out += frame + b"\x00"
        return bytes(out)

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def drain_input(self) -> int:
        return self.inner.drain_input()

    def close(self) -> None:
        self.inner.close()


def _damaged_link(from_s: float) -> tuple[RobotLink, SimClock, Simulator]:
    clock = SimClock()
    sim = Simulator("straight", ROBOT, clock=clock)
    transport = Transport.open(sim.url, baud=ROBOT.bridge.baud)
    return wrap_link(_DamagedStates(transport, clock, from_s), ROBOT, clock), clock, sim


def test_a_connect_whose_states_are_all_refused_says_so() -> None:
    link, clock, sim = _damaged_link(0.0)
    try:
        with pytest.raises(LinkTimeout) as exc:
            wait_for_state(link, clock, 5.0)
    finally:
        link.close()
        sim.close()
    text = str(exc.value)
    assert text.startswith("no state from the robot within 5 s: STATE frames arrived but all ")
    assert text.endswith(" with a bad CRC)") and exc.value.exit_code == 3


def test_a_run_whose_states_are_all_refused_says_so() -> None:
    link, clock, sim = _damaged_link(3.0)
    wait_for_state(link, clock, 5.0)
    supervisor = Supervisor(link, clock)
    supervisor.attach_simulator(sim)
    connection = Connection(
        ROBOT, clock, supervisor, simulated=True, target="x", seed=0, description="damaged"
    )
    with connection:
        result = run_on(connection, STRAIGHT, params={"distance": "1 m"}, max_time="30 s")
    assert result.why.startswith("link_silent: no state frame taken for 0.1"), result.why
    assert "STATE frames arrived but all 15 were refused (15 with a bad CRC)" in result.why
    assert "nothing heard" not in result.why and "held no state" not in result.why
    assert result.exit_code == 3


# -- 4. ESTOP_INPUT without ESTOP is a latch, named once ----------------------------------------


def _input_only(wire: Wire, seqs: range) -> None:
    for seq in seqs:
        wire.answer(state(seq, flags=BridgeFlags.ESTOP_INPUT))
        wire.poll(0.01)


def test_estop_input_without_estop_is_taken_as_latched_and_logged_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = Wire()
    link = RobotLink(ROBOT, wire.session)
    with caplog.at_level(logging.ERROR, logger=LOG):
        _input_only(wire, range(10, 14))
    stats, health = wire.session.stats(), link.health()
    assert stats.estopped and stats.estop_input and health.estopped and health.estop_input
    said = [r.getMessage() for r in caplog.records if "ESTOP_INPUT" in r.getMessage()]
    assert len(said) == 1 and "without its e-stop latched (ESTOP)" in said[0]
    assert not wire.session.latch_reported  # the bridge's own flag, for the close's e-stop


def test_a_1_1_session_still_ignores_bit_4() -> None:
    wire = Wire(config=replace(CONFIG, protocol_minor=1))
    _input_only(wire, range(10, 12))
    assert not wire.session.stats().estopped and not wire.session.stats().estop_input


def test_a_run_on_a_bridge_reporting_the_input_alone_stops(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    flags: Callable[[SimBridge], BridgeFlags] = SimBridge._flags

    def input_from_2_s(bridge: SimBridge) -> BridgeFlags:
        extra = BridgeFlags.ESTOP_INPUT if bridge.now_s >= 2.0 else BridgeFlags.NONE
        return flags(bridge) | extra

    monkeypatch.setattr(SimBridge, "_flags", input_from_2_s)
    with caplog.at_level(logging.ERROR, logger=LOG):
        result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"})
    assert result.status == "failure" and result.safe_state
    assert result.why.startswith("e-stop: the bridge reports its e-stop latched")
    assert sum("ESTOP_INPUT" in r.getMessage() for r in caplog.records) == 1


def test_the_simulated_bridge_never_sets_the_input_without_the_latch() -> None:
    with Simulator("straight", ROBOT, clock=SimClock()) as sim:
        bridge = sim.bridge
        bridge._minor = 2
        seen = [bridge._flags()]
        for pressed in (True, False):
            bridge.set_estop_input(pressed)
            seen.append(bridge._flags())
        bridge._estop_reset()
        seen.append(bridge._flags())
    latch = BridgeFlags.ESTOP | BridgeFlags.ESTOP_INPUT
    assert all(f & latch != BridgeFlags.ESTOP_INPUT for f in seen), seen
    assert seen[1] & latch == latch and seen[-1] & latch == BridgeFlags.NONE
