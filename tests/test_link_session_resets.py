"""The session's rules for sessions, resets, hellos, states, the reader thread and its
counts, each against a bridge the test plays by hand (tests/session_wire.py).

Split from tests/test_link_session_rules.py, whose docstring says why these tests play
the bridge themselves.
"""

from __future__ import annotations

import logging
import re
import threading
import time

import pytest
from session_wire import (
    ACK_S,
    CODEC,
    CONFIG,
    LAYOUT,
    LOG,
    Wire,
    counters,
    messages,
    reply,
    setpoint,
    state,
)

from pirate_bt.clock import SimClock, WallClock
from pirate_bt.errors import LinkError, LinkLost, ProtocolMismatch
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BridgeHeartbeat,
    EStop,
    FrameDecoder,
    Heartbeat,
    Hello,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
)
from pirate_bt.link.requests import SESSION_RENEW_GAP, Outcome
from pirate_bt.link.session import HELLO_TRIES, Session
from pirate_bt.link.testing import memory_pair
from pirate_bt.robot import ControlMode

# -- sessions: resets, hellos, states ----------------------------------------------------------


def test_a_bridge_reset_starts_a_new_session_and_fails_what_was_in_flight(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger=LOG)
    wire = Wire(hello=reply())
    wire.answer(state(40000))  # the old session's states had got far
    wire.poll()
    req, _ = setpoint(wire)
    waiting, _ = setpoint(wire)
    wire.poll(0.01)
    wire.answer(state(40001, flags=BridgeFlags.NO_SESSION | BridgeFlags.ESTOP))
    wire.poll()
    for r in (req, waiting):
        assert (r.outcome, r.acked_at_s, r.tries) == (Outcome.FAILED, wire.clock.now(), r.tries)
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello) and hello.seq == waiting.seq + 1
    assert hello.minor == CONFIG.protocol_minor
    assert wire.session.latest_state()[0].seq == 40000  # type: ignore[index]
    stats = wire.session.stats()
    assert (stats.bridge_resets, stats.estopped, stats.sessions) == (1, True, 1)
    assert messages(caplog) == [
        (logging.ERROR, "the bridge was reset (NO_SESSION): in-flight requests failed"),
        (logging.WARNING, "starting a new session: the bridge was reset"),
        (logging.WARNING, f"{waiting!r} not sent: the session ended or a new one started"),
        (logging.WARNING, f"{req!r} gave up after 1 tries"),
    ]
    # a second reset report while the HELLO is on its way starts nothing new
    wire.answer(BridgeHeartbeat(41, BridgeFlags.NO_SESSION))
    wire.poll()
    assert wire.session.stats().bridge_resets == 1 and wire.sent() == []
    # queued behind the HELLO: not sent until the bridge answers it
    _, later_msg = setpoint(wire)
    wire.poll()
    assert wire.sent() == []
    caplog.clear()
    wire.poll(0.02)
    wire.answer(state(39000), reply(seq=hello.seq, boot_id=8, sessions=2))  # old: dropped
    wire.poll()
    assert wire.session.latest_state()[0].seq == 40000  # type: ignore[index]
    assert wire.sent() == [later_msg]
    assert messages(caplog) == [(logging.WARNING, "the bridge was reset (boot id 7 -> 8)")]
    assert list(wire.session.rtt_samples) == [pytest.approx(0.02)]  # the HELLO's round trip
    assert wire.session.last_hello_reply == reply(seq=hello.seq, boot_id=8, sessions=2)
    assert wire.session.stats().sessions == 2 and not wire.session.stats().estopped
    wire.answer(state(10000))  # the new session's first state, whatever its seq (older)
    wire.poll()
    latest = wire.session.latest_state()
    assert latest is not None and latest == (state(10000), wire.clock.now())
    wire.answer(state(10000), state(0xFFF0))
    wire.poll()
    assert wire.session.latest_state()[0].seq == 10000  # type: ignore[index]
    assert wire.session.stats().duplicates == 3
    # another reset, another session: both counted
    wire.answer(BridgeHeartbeat(9, BridgeFlags.NO_SESSION))
    wire.poll()
    assert wire.session.stats().bridge_resets == 2


def test_a_session_opened_without_a_reply_takes_a_new_one() -> None:
    wire = Wire(hello=None)
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello)
    wire.answer(reply(seq=hello.seq, boot_id=3))
    wire.poll()
    assert wire.session.stats().sessions == 2
    assert wire.session.last_hello_reply == reply(seq=hello.seq, boot_id=3)


def test_the_hardware_estop_input_flag_is_reported() -> None:
    wire = Wire()
    wire.answer(state(1, flags=BridgeFlags.WATCHDOG))
    wire.poll()
    assert not wire.session.stats().estop_input
    wire.answer(state(2, flags=BridgeFlags.ESTOP_INPUT))
    wire.poll()
    assert wire.session.stats().estop_input


def test_the_reader_polls_every_millisecond() -> None:
    slept: list[float] = []

    class Recording(WallClock):
        def sleep(self, seconds: float) -> None:
            slept.append(seconds)
            super().sleep(seconds)

    host, _ = memory_pair()
    session = Session(host, CODEC, Recording(), CONFIG, first_seq=2, hello_reply=reply())
    session.start_reader()
    deadline = time.monotonic() + 30.0
    while len(slept) < 3 and time.monotonic() < deadline:
        time.sleep(0.01)
    session.stop_reader()
    assert slept[:3] == [0.001] * 3


def test_a_new_session_reply_from_a_rebooted_bridge_is_logged(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger=LOG)
    wire = Wire(hello=reply(boot_id=7))
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello)
    caplog.clear()
    wire.answer(reply(seq=hello.seq + 1), reply(seq=hello.seq, boot_id=9, flags=BridgeFlags.ESTOP))
    wire.poll()
    assert wire.session.stats().duplicates == 1
    assert messages(caplog) == [
        (logging.WARNING, "the bridge was reset (boot id 7 -> 9)"),
        (logging.WARNING, "new session: the bridge's e-stop is latched (reset it to move)"),
    ]
    assert wire.session.stats().estopped
    wire.answer(reply(seq=hello.seq, boot_id=9))  # a late copy
    wire.poll()
    assert wire.session.stats().duplicates == 2


def test_a_reply_to_no_hello_is_a_duplicate() -> None:
    wire = Wire(hello=reply(boot_id=7))
    wire.answer(reply(seq=1, boot_id=7))
    wire.poll()
    assert wire.session.stats().duplicates == 1 and wire.session.stats().sessions == 1


@pytest.mark.parametrize(
    ("answer", "what"),
    [
        ({"layout_digest": LAYOUT.digest ^ 1}, r"another layout$"),
        # was "another layout" too: the minor is what differs (2026-11-29)
        ({"minor": 1}, r"protocol 1\.1; the host asked for 1\.2 \(same layout\)$"),
    ],
)
def test_a_new_session_on_another_layout_or_version_is_refused(
    answer: dict[str, int], what: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.ERROR, logger=LOG)
    wire = Wire(hello=reply())
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.session._hello  # white box: the HELLO's request
    assert hello is not None
    wire.answer(reply(seq=hello.seq, **answer))
    with pytest.raises(ProtocolMismatch, match=r"^the bridge answered a new session with " + what):
        wire.poll()
    assert hello.outcome is Outcome.NACKED
    assert any(
        level == logging.ERROR and re.match(r"the bridge answered a new session with " + what, text)
        for level, text in messages(caplog)
    )
    with pytest.raises(ProtocolMismatch):
        wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, 0)


def test_a_refused_new_session_names_the_bridge_s_reason(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.ERROR, logger=LOG)
    wire = Wire(hello=reply())
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.session._hello
    assert hello is not None
    wire.answer(Nack(hello.seq + 1, MsgType.HELLO, NackCode.BAD_LAYOUT))  # not its answer
    wire.poll()
    assert wire.session.stats().duplicates == 1
    wire.answer(Nack(hello.seq, MsgType.HELLO, NackCode.BAD_LAYOUT))
    with pytest.raises(ProtocolMismatch, match=r"^the bridge refused a new session: BAD_LAYOUT$"):
        wire.poll()
    assert (logging.ERROR, "the bridge refused a new session: BAD_LAYOUT") in messages(caplog)
    assert (hello.outcome, hello.acked_at_s) == (Outcome.NACKED, wire.clock.now())


def test_a_new_session_asks_for_the_configured_minor_version() -> None:
    from dataclasses import replace

    wire = Wire(config=replace(CONFIG, protocol_minor=2), hello=reply(minor=2))
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello) and hello.minor == 2
    wire.answer(reply(seq=hello.seq, minor=2))
    wire.poll()
    assert wire.session.stats().sessions == 2


def test_an_unanswered_hello_loses_the_link_after_its_tries() -> None:
    wire = Wire()
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.session._hello
    assert hello is not None
    for _ in range(HELLO_TRIES - 1):
        wire.answer(BridgeHeartbeat(4))  # the bridge talks, but never answers the HELLO
        wire.poll(ACK_S)
    assert hello.tries == HELLO_TRIES and not hello.done
    wire.answer(BridgeHeartbeat(4))
    with pytest.raises(
        LinkLost,
        match=f"^the bridge did not answer a new session's HELLO \\({HELLO_TRIES} tries\\)$",
    ):
        wire.poll(ACK_S)
    assert hello.outcome is Outcome.FAILED


def test_a_state_of_the_old_session_before_any_state_is_not_taken() -> None:
    wire = Wire()
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    wire.answer(state(9))
    wire.poll()
    assert wire.session.latest_state() is None


def test_bridge_flags_follow_every_state_and_heartbeat() -> None:
    wire = Wire()
    wire.answer(state(1, flags=BridgeFlags.WATCHDOG))
    wire.poll()
    assert wire.session.stats().watchdog
    wire.answer(BridgeHeartbeat(2, BridgeFlags.ESTOP))
    wire.poll()
    assert wire.session.stats().estopped and not wire.session.stats().watchdog


def test_a_bulk_is_acknowledged_by_the_state_that_applied_it() -> None:
    wire = Wire()
    bulk = wire.session.send_bulk([None] * LAYOUT.n_motors, [0] * LAYOUT.n_motors)
    _, msg = setpoint(wire)
    wire.answer(state(1, ack_seq=bulk.seq - 1), state(2, ack_seq=bulk.seq + 1))
    wire.poll()
    assert not bulk.done
    wire.poll(0.02)
    wire.answer(state(3, ack_seq=bulk.seq))
    wire.poll()
    assert (bulk.outcome, bulk.ack_status, bulk.acked_at_s) == (
        Outcome.ACKED,
        AckStatus.APPLIED,
        wire.clock.now(),
    )
    assert msg in wire.sent()  # the next request went out at once


def test_frame_errors_are_counted_and_logged(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOG)
    wire = Wire()
    good = CODEC.encode(state(1))
    bad = bytearray(good)
    bad[3] ^= 0x10
    wire.far.write(bytes(bad) + good)
    wire.poll()
    assert wire.session.stats().crc_errors == 1
    assert wire.session.latest_state() is not None
    assert any(m.startswith("dropped frame: ") for _, m in messages(caplog))


def test_our_own_frames_echoed_back_are_not_the_bridge_talking() -> None:
    wire = Wire()
    wire.poll(0.3)
    wire.answer(Heartbeat(5), Setpoint(6, 22, 1, ControlMode.VELOCITY, 0))
    with pytest.raises(LinkLost):  # 0.6 s since the bridge was last heard: echoes do not count
        wire.poll(0.3)
    assert wire.session.stats().duplicates == 0


def test_a_lost_heartbeat_is_not_a_failure(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOG)
    wire = Wire()
    wire.poll(0.125)
    beat = next(m for m in wire.sent(heartbeats=True) if isinstance(m, Heartbeat))
    wire.poll(ACK_S)
    stats = wire.session.stats()
    assert (stats.failed, stats.sent, stats.loss_ratio) == (0, 1, 0.0)
    assert wire.session.take_failures() == []
    assert (logging.DEBUG, f"Request(Heartbeat seq={beat.seq} failed) not acknowledged") in (
        messages(caplog)
    )


# -- the reader thread ---------------------------------------------------------------------------


def test_a_reader_thread_polls_the_session_and_reports_its_error() -> None:
    clock = WallClock()
    host, far = memory_pair()
    session = Session(host, CODEC, clock, CONFIG, first_seq=2, hello_reply=reply())
    session.start_reader()
    session.start_reader()  # a second call starts nothing
    readers = [t for t in threading.enumerate() if t.name == "pirate-link-reader"]
    assert len(readers) == 1 and readers[0].daemon
    assert session.threaded
    decoder = FrameDecoder(CODEC)
    req = session.send_setpoint(22, 1, ControlMode.VELOCITY, 5)
    deadline = time.monotonic() + 30.0
    while not req.done and time.monotonic() < deadline:
        for msg in decoder.feed(far.read_available()):
            if isinstance(msg, Setpoint):
                far.write(CODEC.encode(Ack(msg.seq, MsgType.SETPOINT)))
        time.sleep(0.001)
    assert session.wait(req, timeout_s=1.0).outcome is Outcome.ACKED
    session.check_reader()  # no error yet

    def broken() -> bytes:
        raise LinkError("port gone")

    host.read_available = broken  # type: ignore[method-assign]
    deadline = time.monotonic() + 30.0
    while session._reader_error is None and time.monotonic() < deadline:  # white box
        time.sleep(0.001)
    with pytest.raises(LinkError, match=r"^port gone$"):
        session.check_reader()
    with pytest.raises(LinkError, match=r"^port gone$"):
        session.wait(session.request_counters())
    session.stop_reader()
    assert not session.threaded
    session.stop_reader()


# -- counts that add up, times that are stamped -----------------------------------------------


def test_a_session_made_after_a_handshake_numbers_from_two() -> None:
    clock = SimClock(8.0)
    host, _ = memory_pair()
    session = Session(host, CODEC, clock)  # the handshake's HELLO had seq 1
    req = session.send_setpoint(22, 1, ControlMode.VELOCITY, 0)
    assert req.seq == 2 and req.created_s == 8.0


def test_a_request_queued_behind_another_sends_nothing_by_itself() -> None:
    """Queuing is not polling: no retry, no heartbeat goes out until the next poll."""
    wire = Wire()
    _, m1 = setpoint(wire)
    assert wire.sent(heartbeats=True) == [m1]
    wire.clock.advance(0.125)  # a retry (and so no heartbeat) is due now
    second, _ = setpoint(wire)
    assert second.created_s == wire.clock.now()
    assert wire.sent(heartbeats=True) == []
    wire.poll()
    assert wire.sent(heartbeats=True) == [m1]


def test_an_estop_after_a_quiet_spell_is_retried_when_due() -> None:
    wire = Wire()
    wire.poll()
    stop = wire.session.estop()
    assert wire.sent() == [EStop(stop.seq)]
    wire.poll(ACK_S)
    assert wire.sent() == [EStop(stop.seq)]


def test_an_unanswered_estop_is_tried_max_retries_plus_one_times() -> None:
    wire = Wire()
    stop = wire.session.estop()
    for _ in range(CONFIG.max_retries):
        wire.poll(ACK_S)
    assert stop.tries == CONFIG.max_retries + 1 and not stop.done
    wire.poll(ACK_S)
    assert (stop.outcome, stop.acked_at_s) == (Outcome.FAILED, wire.clock.now())
    assert [m for m in wire.sent() if isinstance(m, EStop)] == [EStop(stop.seq)] * 3


def test_figures_count_every_occurrence() -> None:
    wire = Wire()
    for _ in range(2):
        req, msg = setpoint(wire)
        wire.answer(Ack(msg.seq, MsgType.SETPOINT, AckStatus.STALE))
        wire.poll()
        req, msg = setpoint(wire)  # applied: two STALEs in a row would start a new session
        wire.answer(Ack(msg.seq, MsgType.SETPOINT))
        wire.poll()
    for _ in range(2):
        req, _ = setpoint(wire)
        for _ in range(CONFIG.max_retries + 1):
            wire.answer(BridgeHeartbeat(1))
            wire.poll(ACK_S)
        assert req.outcome is Outcome.FAILED
    bad = bytearray(CODEC.encode(state(1)))
    bad[3] ^= 0x10
    wire.far.write(bytes(bad) * 2)
    wire.answer(Heartbeat(5), Heartbeat(6))  # our own frames, echoed
    ask = wire.session.request_counters()
    wire.answer(counters(ask.seq), counters(ask.seq), counters(ask.seq))
    wire.poll()
    stats = wire.session.stats()
    assert (stats.stale, stats.failed, stats.crc_errors, stats.duplicates) == (2, 2, 2, 2)
    assert wire.session.unexpected == 2


def test_acks_nacks_and_give_ups_are_stamped_with_the_time_they_came() -> None:
    wire = Wire()
    ask = wire.session.request_counters()
    wire.poll(0.01)
    wire.answer(Nack(ask.seq, MsgType.COUNTERS_REQUEST, NackCode.NOT_READY))
    wire.poll(0.01)
    assert (ask.outcome, ask.acked_at_s) == (Outcome.NACKED, wire.clock.now())


def test_a_lost_link_stays_lost_when_the_bridge_talks_again() -> None:
    wire = Wire()
    with pytest.raises(LinkLost):
        wire.poll(CONFIG.link_timeout_s + 0.01)
    wire.answer(state(1), BridgeHeartbeat(2))
    with pytest.raises(LinkLost, match=r"^nothing heard from the bridge for over 0\.5 s$"):
        wire.poll()
    assert wire.session.latest_state() is not None  # heard, but too late


def test_an_unanswered_hello_fails_everything_at_the_time_it_gives_up() -> None:
    wire = Wire()
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.session._hello
    assert hello is not None
    waiting, _ = setpoint(wire)
    ask = wire.session.request_counters()
    for _ in range(HELLO_TRIES - 1):
        wire.answer(BridgeHeartbeat(4))
        wire.poll(ACK_S)
    wire.answer(BridgeHeartbeat(4))
    with pytest.raises(LinkLost):
        wire.poll(ACK_S)
    now = wire.clock.now()
    assert (hello.outcome, hello.acked_at_s) == (Outcome.FAILED, now)
    assert (waiting.outcome, waiting.acked_at_s) == (Outcome.FAILED, now)
    assert ask.outcome is Outcome.FAILED
    wire.answer(BridgeHeartbeat(5))  # the bridge still talks: the session is lost anyway
    with pytest.raises(LinkLost):
        wire.poll()


def test_a_renewed_session_fails_what_was_queued_at_that_time(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger=LOG)
    wire = Wire(first_seq=100)
    wire.session._next_seq = 99 + SESSION_RENEW_GAP - 1  # white box: that many lost
    wire.clock.advance(0.01)
    req, _ = setpoint(wire)
    assert (req.outcome, req.acked_at_s) == (Outcome.FAILED, wire.clock.now())
    assert (
        logging.WARNING,
        "starting a new session: the bridge has answered no ordered request for long",
    ) in messages(caplog)


def test_a_bridge_heartbeat_resets_only_when_it_says_so() -> None:
    wire = Wire()
    wire.answer(BridgeHeartbeat(1, BridgeFlags.ESTOP | BridgeFlags.WATCHDOG))
    wire.poll()
    assert wire.session.stats().bridge_resets == 0
    req, _ = setpoint(wire)
    wire.poll(0.01)
    wire.answer(BridgeHeartbeat(2, BridgeFlags.NO_SESSION))
    wire.poll()
    assert wire.session.stats().bridge_resets == 1
    assert (req.outcome, req.acked_at_s) == (Outcome.FAILED, wire.clock.now())


def test_a_reset_ack_sets_no_flag_that_was_not_set() -> None:
    wire = Wire(hello=reply(flags=BridgeFlags.ESTOP))
    reset = wire.session.estop_reset()
    wire.answer(Ack(reset.seq, MsgType.ESTOP_RESET))
    wire.poll()
    stats = wire.session.stats()
    assert not stats.estopped and not stats.watchdog and not stats.estop_input


def test_a_dropped_frame_is_logged_with_what_was_wrong(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger=LOG)
    wire = Wire()
    bad = bytearray(CODEC.encode(state(1)))
    bad[3] ^= 0x10
    (error,) = FrameDecoder(CODEC).feed(bytes(bad))
    wire.far.write(bytes(bad))
    wire.poll()
    assert (logging.DEBUG, f"dropped frame: {error}") in messages(caplog)
