"""The link's leftovers of the twentieth session, each pinned by a test that failed before
its fix.

1. A run that stopped for want of state after one to four ``STATE`` frames had arrived
   and been refused (out of sequence, say) said *the last frame heard ... held no
   state*: the frames were left out below ``REFUSED_STATES_REPORTED``. Once a ``STATE``
   was taken in the session every refused one is reported, with its reason.
2. A line cut toward the bridge only (the host's frames lost, the bridge's STATEs still
   coming): the close said *the closing stop was never acknowledged, nor was the e-stop
   sent after it: the robot may still be moving until its bridge's watchdog stops it*,
   while the bridge's own STATEs reported its watchdog tripped (the drives stopped). The
   close now says which way the line failed and that the watchdog stopped the drives.
   So does a connect on such a line: it said only *the bridge did not answer HELLO (16
   tries): it sent 95 STATE but never answered*, though those STATEs reported the
   bridge's watchdog tripped (it heard no HELLO).
3. A new session's first ``STATE`` was taken whatever it carried: a frame the bridge sent
   before it took the session's ``HELLO`` (delivered late, or left in a buffer), say one of
   the old boot after a reset, was taken, and every genuine frame of the new boot (seq
   counted from 1) was then refused as older until the host resynchronised. A frame whose
   ``ack_seq`` names a bulk the host did not send in this session is refused now
   (counted, logged), and after a new session of the same boot the seq must be newer.
"""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
from session_wire import CODEC, LAYOUT, Wire, reply, state

from pirate_bt.api.connection import Connection
from pirate_bt.api.running import run_on
from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import LinkTimeout
from pirate_bt.link import framing
from pirate_bt.link.codec import BridgeFlags, Hello, MsgType
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.robot_link import REFUSED_STATES_REPORTED, RobotLink
from pirate_bt.link.testing import memory_pair
from pirate_bt.link.transport import Transport
from pirate_bt.robot import ControlMode, MotorCommand, load_robot
from pirate_bt.safety.factory import wait_for_state
from pirate_bt.safety.supervisor import Supervisor
from pirate_bt.sim import Simulator

ROBOT = load_robot()
STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"


# -- 1. a few refused STATE frames are named, not "held no state" ---------------------------


class _ReplayThenNoState:
    """The simulator's byte link that, from ``from_s`` on, puts the last ``STATE`` it let
    through in place of the next ``replays`` ones (old: refused as out of sequence) and
    drops every later ``STATE``; every other frame passes."""

    def __init__(self, inner: Transport, clock: SimClock, from_s: float, replays: int) -> None:
        self.inner, self.clock, self.from_s, self.replays = inner, clock, from_s, replays
        self.baud = inner.baud
        self._held = b""
        self._last = b""

    def read_available(self) -> bytes:
        self._held += self.inner.read_available()
        *frames, self._held = self._held.split(b"\x00")
        out = bytearray()
        for frame in frames:
            body = framing.cobs_decode(frame) if frame else b""
            if len(body) > 2 and body[1] == MsgType.STATE:
                if self.clock.now() < self.from_s:
                    self._last = frame
                elif self.replays:
                    self.replays -= 1
                    frame = self._last
                else:
                    continue
            out += frame + b"\x00"
        return bytes(out)

    def write(self, data: bytes) -> None:
        self.inner.write(data)

    def drain_input(self) -> int:
        return self.inner.drain_input()

    def close(self) -> None:
        self.inner.close()


class _Deaf:
    """The simulator's byte link that loses every host frame from ``from_s`` on."""

    def __init__(self, inner: Transport, clock: SimClock, from_s: float) -> None:
        self.inner, self.clock, self.from_s = inner, clock, from_s
        self.baud = inner.baud

    def read_available(self) -> bytes:
        return self.inner.read_available()

    def write(self, data: bytes) -> None:
        if self.clock.now() < self.from_s:
            self.inner.write(data)

    def drain_input(self) -> int:
        return self.inner.drain_input()

    def close(self) -> None:
        self.inner.close()


class _DeafAndDumb(_Deaf):
    """:class:`_Deaf`, and the bridge's frames lost too from ``from_s`` on."""

    def read_available(self) -> bytes:
        data = self.inner.read_available()
        return data if self.clock.now() < self.from_s else b""


def _run_with_states_replayed(replays: int) -> str:
    clock = SimClock()
    sim = Simulator("straight", ROBOT, clock=clock)
    transport = Transport.open(sim.url, baud=ROBOT.bridge.baud)
    link = wrap_link(_ReplayThenNoState(transport, clock, 3.0, replays), ROBOT, clock)
    wait_for_state(link, clock, 5.0)
    supervisor = Supervisor(link, clock)
    supervisor.attach_simulator(sim)
    connection = Connection(
        ROBOT, clock, supervisor, simulated=True, target="x", seed=0, description="replayed"
    )
    with connection:
        result = run_on(connection, STRAIGHT, params={"distance": "1 m"}, max_time="30 s")
    assert result.exit_code == 3, result.why
    return result.why


def test_a_run_that_stops_after_two_refused_states_names_them() -> None:
    why = _run_with_states_replayed(2)
    assert why.startswith("link_silent: no state frame taken for 0.1"), why
    assert "two STATE frames arrived but both were refused (2 out of sequence)" in why
    assert "held no state" not in why


def test_a_run_whose_bridge_answers_but_sends_no_state_says_the_frames_held_none() -> None:
    why = _run_with_states_replayed(0)  # the ACKs still come: true, and kept
    assert "held no state" in why and "refused" not in why, why


def test_one_refused_state_is_reported_once_a_state_was_taken() -> None:
    wire = Wire()
    link = RobotLink(ROBOT, wire.session)
    wire.answer(state(10))
    wire.poll(0.01)
    wire.answer(state(9))  # older than the one held
    wire.poll(0.01)
    health = link.health()
    assert health.states_refused == (("out of sequence", 1),)
    assert health.states_refused_text() == (
        "a STATE frame arrived but was refused (1 out of sequence)"
    )
    assert REFUSED_STATES_REPORTED > 1  # before any was taken, one is not (test_link_leftovers13)


# -- 2. a line cut toward the bridge only: what the close says --------------------------------


def test_a_close_on_a_line_cut_toward_the_bridge_says_so_and_that_the_watchdog_stopped() -> None:
    clock = SimClock()
    sim = Simulator("straight", ROBOT, clock=clock)
    transport = Transport.open(sim.url, baud=ROBOT.bridge.baud)
    link = wrap_link(_Deaf(transport, clock, 2.0), ROBOT, clock)
    try:
        wait_for_state(link, clock, 5.0)
        link.send([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.02)])
        clock.sleep(2.0 - clock.now())
    finally:
        link.close()
        sim.close()
    assert sim.bridge.watchdog_tripped
    assert str(link.close_error) == (
        "the closing stop was never acknowledged, nor was the e-stop sent after it: the"
        " bridge reports its watchdog tripped, so its drives are stopped (it hears nothing"
        " from the host: the line toward the bridge is down?)"
    )


def test_a_close_on_a_line_cut_both_ways_still_says_the_robot_may_be_moving() -> None:
    clock = SimClock()
    sim = Simulator("straight", ROBOT, clock=clock)
    transport = Transport.open(sim.url, baud=ROBOT.bridge.baud)
    link = wrap_link(_DeafAndDumb(transport, clock, 2.0), ROBOT, clock)
    try:
        wait_for_state(link, clock, 5.0)
        clock.sleep(2.0 - clock.now())
    finally:
        link.close()
        sim.close()
    text = str(link.close_error)
    assert text.endswith(": the robot may still be moving until its bridge's watchdog stops it")
    assert "toward the bridge" not in text and "STATE" not in text, text


# -- 3. a frame of the session before is not the new session's first --------------------------


def _new_session(wire: Wire, boot_id: int) -> int:
    """The bridge resets (a NO_SESSION frame); its new session's reply, of ``boot_id``.
    Returns the HELLO's seq."""
    wire.answer(state(7, flags=BridgeFlags.NO_SESSION | BridgeFlags.ESTOP))
    wire.poll(0.01)
    hello = next(m for m in wire.sent() if isinstance(m, Hello))
    wire.answer(reply(seq=hello.seq, boot_id=boot_id, sessions=1, flags=BridgeFlags.ESTOP))
    wire.poll(0.01)
    return hello.seq


def _bulk(wire: Wire) -> int:
    """A bulk sent: its seq."""
    n = LAYOUT.n_motors
    return wire.session.send_bulk([ControlMode.VELOCITY] * n, [0] * n).seq


def _bulk_applied(wire: Wire, seq: int) -> int:
    """A bulk sent, and the STATE ``seq`` that acknowledges it taken: the bulk's seq."""
    bulk = _bulk(wire)
    wire.poll(0.01)
    wire.answer(state(seq, ack_seq=bulk))
    wire.poll(0.01)
    assert _taken_seqs(wire)[-1] == seq
    return bulk


def _taken_seqs(wire: Wire) -> list[int]:
    return [frame.seq for frame, _ in wire.session.states_taken()]


def test_a_state_of_the_old_boot_delivered_after_the_new_session_is_refused(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = Wire(hello=reply(boot_id=7))
    old = _bulk_applied(wire, 5000)
    hello = _new_session(wire, boot_id=8)
    assert wire.session.bridge_resets == 1
    with caplog.at_level(logging.WARNING, "pirate_bt.link.session"):
        # the old boot's last frames, late (a relay's buffer), then the new boot's
        wire.answer(state(5001, ack_seq=old), state(5002, ack_seq=old), state(1), state(2))
        wire.poll(0.01)
    assert _taken_seqs(wire)[-2:] == [1, 2]  # before: 5001, and 1 and 2 refused as older
    said = [r.getMessage() for r in caplog.records if "refused" in r.getMessage()]
    assert said == [
        f"STATE seq 5001 refused: it acknowledges BULK_SETPOINTS seq {old}, which the host did not"
        f" send in this session (started by HELLO seq {hello}): a frame of the session"
        " before, delivered late"
    ]
    assert wire.session.duplicates >= 2


def test_refused_frames_of_the_session_before_are_counted_until_one_is_taken() -> None:
    wire = Wire(hello=reply(boot_id=7))
    old = _bulk_applied(wire, 5000)
    _new_session(wire, boot_id=8)
    wire.answer(state(5001, ack_seq=old), state(5002, ack_seq=old))
    wire.poll(0.01)
    assert wire.session.refused_states() == (0, 0, 2, 0)
    wire.answer(state(1))
    wire.poll(0.01)
    assert wire.session.refused_states() == (0, 0, 0, 0) and _taken_seqs(wire)[-1] == 1


def test_a_new_session_of_the_same_boot_takes_no_state_older_than_the_one_held() -> None:
    wire = Wire(hello=reply(boot_id=7))
    wire.answer(state(500))
    wire.poll(0.01)
    wire.answer(state(490, flags=BridgeFlags.NO_SESSION))  # a stale boot frame: not a reset
    wire.poll(0.01)
    hello = next(m for m in wire.sent() if isinstance(m, Hello))
    wire.answer(reply(seq=hello.seq, boot_id=7, sessions=2))
    wire.poll(0.01)
    wire.answer(state(499), state(501))  # 499: sent before 500, delivered late
    wire.poll(0.01)
    assert _taken_seqs(wire) == [500, 501]  # before: [500, 499, 501]
    assert wire.session.refused_states() == (0, 0, 0, 0)


def test_a_new_sessions_states_acknowledging_its_own_bulks_are_taken() -> None:
    wire = Wire(hello=reply(boot_id=7))
    wire.answer(state(10))
    wire.poll(0.01)
    hello = _new_session(wire, boot_id=8)
    bulk = _bulk(wire)
    wire.poll(0.01)
    wire.answer(state(1, ack_seq=bulk))
    wire.poll(0.01)
    assert bulk not in (0, hello)
    assert _taken_seqs(wire)[-1] == 1 and wire.session.refused_states() == (0, 0, 0, 0)


def test_a_first_state_acknowledging_a_bulk_not_sent_yet_is_refused() -> None:
    wire = Wire(hello=reply(boot_id=7))
    _bulk_applied(wire, 10)
    hello = _new_session(wire, boot_id=8)
    wire.answer(state(1, ack_seq=(hello + 5) & 0xFFFF))  # newer than any bulk sent
    wire.poll(0.01)
    assert wire.session.refused_states() == (0, 0, 1, 0) and _taken_seqs(wire)[-1] == 10


# -- 2b. a connect on a line cut toward the bridge --------------------------------------------


def test_a_connect_on_a_line_cut_toward_the_bridge_says_so(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["run", str(STRAIGHT), "--sim", "straight", "--param", "distance=0.2m"]
    argv += ["--faults", "drop=1,direction=tx"]
    assert main([*argv, "--quiet"]) == 3
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.endswith(
        " STATE but never answered: its STATE frames report its watchdog tripped (it hears"
        " nothing from the host: the line toward the bridge is down?)"
    ), last


def test_a_connect_to_a_bridge_that_hears_but_ignores_hello_does_not_blame_the_line() -> None:
    clock = SimClock()
    host, far = memory_pair()
    frames = iter(range(1, 10_000))  # STATEs without WATCHDOG: it hears the host
    clock.add_listener(lambda now: far.write(CODEC.encode(state(next(frames)))))
    with pytest.raises(LinkTimeout) as caught:
        wrap_link(host, ROBOT, clock)
    assert str(caught.value).endswith(" STATE but never answered"), caught.value
