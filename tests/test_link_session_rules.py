"""The session's rules, each against a bridge the test plays by hand.

Written with the mutation run (docs/testing.md). The reference bridge answers
correctly and fast, so tests against it cannot see a retry counted twice, a round-trip
time smoothed the wrong way, a request given up one poll late or an answer to the wrong
request taken. Here the test reads every frame the host writes and writes every answer
itself, on a :class:`~pirate_bt.clock.SimClock`, and checks the figures, outcomes,
times and log lines a user of the link sees.
"""

from __future__ import annotations

import logging

import pytest
from session_wire import (
    ACK_S,
    CONFIG,
    EPS,
    LAYOUT,
    LOG,
    Wire,
    counters,
    messages,
    reply,
    setpoint,
    state,
)

from pirate_bt.errors import LinkError, LinkLost, LinkTimeout
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BridgeHeartbeat,
    EStop,
    Heartbeat,
    Hello,
    MsgType,
    Nack,
    NackCode,
)
from pirate_bt.link.requests import SESSION_RENEW_GAP, Outcome
from pirate_bt.robot import ControlMode

# -- numbering ---------------------------------------------------------------------------------


def test_ordered_requests_count_from_the_first_seq_and_skip_zero_when_they_wrap() -> None:
    wire = Wire(first_seq=0xFFFE)
    seqs = [wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, i).seq for i in range(4)]
    assert seqs == [0xFFFE, 0xFFFF, 1, 2]
    assert Wire(first_seq=0).session.send_setpoint(22, 1, ControlMode.VELOCITY, 0).seq == 1
    assert Wire(first_seq=0x10005).session.estop().seq == 5
    assert Wire().session.estop_reset().seq == 2


def test_heartbeats_and_counter_requests_count_on_their_own_from_one() -> None:
    wire = Wire(first_seq=300)
    wire.poll(0.125)  # a heartbeat period with nothing sent
    beats = [m for m in wire.sent(heartbeats=True) if isinstance(m, Heartbeat)]
    assert [m.seq for m in beats] == [1]
    assert [wire.session.request_counters().seq for _ in range(2)] == [2, 3]
    assert setpoint(wire)[1].seq == 300


def test_a_session_renews_exactly_when_its_counter_runs_the_gap_ahead() -> None:
    """Created with first seq 100, the bridge last answered 99."""
    below = Wire(first_seq=100)
    below.session._next_seq = 99 + SESSION_RENEW_GAP - 2  # white box: that many lost
    req, msg = setpoint(below)
    assert below.sent() == [msg] and not req.done
    at = Wire(first_seq=100)
    at.session._next_seq = 99 + SESSION_RENEW_GAP - 1
    req, _ = setpoint(at)
    sent = at.sent()
    assert len(sent) == 1 and isinstance(sent[0], Hello)
    assert req.outcome is Outcome.FAILED and req.tries == 0


# -- acknowledgements, retries, give-up ----------------------------------------------------------


def test_an_ack_settles_its_request_and_times_the_round_trip() -> None:
    wire = Wire()
    first, msg = setpoint(wire)
    wire.poll(0.01)
    wire.answer(Ack(msg.seq, MsgType.SETPOINT, AckStatus.APPLIED))
    wire.poll(0.0)
    assert (first.outcome, first.ack_status, first.acked_at_s) == (
        Outcome.ACKED,
        AckStatus.APPLIED,
        wire.clock.now(),
    )
    second, msg = setpoint(wire)
    wire.poll(0.03)
    wire.answer(Ack(msg.seq, MsgType.SETPOINT, AckStatus.DUPLICATE))
    wire.poll()
    assert second.ack_status is AckStatus.DUPLICATE and second.outcome is Outcome.ACKED
    samples = list(wire.session.rtt_samples)
    assert samples == [pytest.approx(0.01), pytest.approx(0.03)]
    # smoothed like TCP's SRTT: the first sample, then an eighth of each difference
    assert wire.session.stats().rtt_s == pytest.approx(0.01 + (0.03 - 0.01) / 8)
    stats = wire.session.stats()
    assert (stats.sent, stats.retries, stats.failed, stats.loss_ratio) == (2, 0, 0, 0.0)


def test_only_first_try_acks_time_the_round_trip() -> None:
    wire = Wire()
    req, msg = setpoint(wire)
    wire.poll(ACK_S)  # a retry, same seq
    assert wire.sent() == [msg, msg]
    wire.answer(Ack(msg.seq, MsgType.SETPOINT))
    wire.poll(0.01)
    assert req.outcome is Outcome.ACKED and req.tries == 2
    assert list(wire.session.rtt_samples) == []
    assert wire.session.stats().rtt_s != wire.session.stats().rtt_s  # nan: no sample yet
    nacked, msg = setpoint(wire)
    wire.answer(Nack(msg.seq, MsgType.SETPOINT, NackCode.BAD_SLOT))
    wire.poll(0.01)
    assert nacked.outcome is Outcome.NACKED and nacked.nack is NackCode.BAD_SLOT
    assert list(wire.session.rtt_samples) == []


def test_retries_go_out_exactly_when_due_and_the_request_fails_after_the_last(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.DEBUG, logger=LOG)
    wire = Wire()
    req, msg = setpoint(wire)
    assert wire.sent() == [msg]
    wire.poll(ACK_S - EPS)
    assert wire.sent() == []
    wire.poll(EPS)  # exactly one ack timeout after the first try
    assert wire.sent() == [msg]
    wire.poll(ACK_S)
    assert wire.sent() == [msg]
    wire.poll(ACK_S - EPS)
    assert not req.done
    wire.poll(EPS)
    assert req.outcome is Outcome.FAILED and req.tries == 3
    assert req.acked_at_s == wire.clock.now()
    stats = wire.session.stats()
    assert (stats.retries, stats.failed, stats.sent, stats.loss_ratio) == (2, 1, 1, 1.0)
    assert wire.session.take_failures() == [req]
    assert wire.session.take_failures() == []
    assert (logging.WARNING, f"{req!r} gave up after 3 tries") in messages(caplog)


def test_the_loss_ratio_is_over_the_last_window_of_requests() -> None:
    wire = Wire()
    for _ in range(2):  # two requests that needed a retry
        _, msg = setpoint(wire)
        wire.poll(ACK_S)
        wire.answer(Ack(msg.seq, MsgType.SETPOINT))
        wire.poll()
    assert wire.session.stats().loss_ratio == 1.0
    for _ in range(2):
        _, msg = setpoint(wire)
        wire.answer(Ack(msg.seq, MsgType.SETPOINT))
        wire.poll()
    assert wire.session.stats().loss_ratio == 0.5
    for _ in range(2):
        _, msg = setpoint(wire)
        wire.answer(Ack(msg.seq, MsgType.SETPOINT))
        wire.poll()
    assert wire.session.stats().loss_ratio == 0.0  # the window is 4 requests


def test_a_stale_answer_fails_the_request_and_is_logged(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING, logger=LOG)
    wire = Wire()
    req, msg = setpoint(wire)
    wire.answer(Ack(msg.seq, MsgType.SETPOINT, AckStatus.STALE))
    wire.poll()
    assert req.outcome is Outcome.STALE and req.ack_status is AckStatus.STALE
    assert wire.session.stats().stale == 1 and wire.session.stats().failed == 0
    assert wire.session.take_failures() == [req]
    assert messages(caplog) == [
        (logging.WARNING, f"{req!r}: the bridge answered STALE (not applied)")
    ]


def test_two_stale_answers_in_a_row_start_a_new_session(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # the bridge's duplicate filter ran ahead of the host (a damaged frame with a far seq
    # passed the CRC): every ordered request is STALE until a HELLO resets the filter
    caplog.set_level(logging.WARNING, logger=LOG)
    wire = Wire()
    first, msg = setpoint(wire)
    wire.answer(Ack(msg.seq, MsgType.SETPOINT, AckStatus.STALE))
    wire.poll()
    assert not any(isinstance(m, Hello) for m in wire.sent())  # one STALE: an e-stop overtook
    second, msg = setpoint(wire)
    waiting, _ = setpoint(wire)
    wire.answer(Ack(msg.seq, MsgType.SETPOINT, AckStatus.STALE))
    wire.poll()
    assert (first.outcome, second.outcome, waiting.outcome) == (
        Outcome.STALE,
        Outcome.STALE,
        Outcome.FAILED,  # queued behind: never sent, reported
    )
    hello = wire.sent()[-1]
    assert isinstance(hello, Hello) and hello.seq == waiting.msg.seq + 1  # type: ignore[attr-defined]
    assert (
        logging.WARNING,
        "starting a new session: the bridge answered STALE twice in a row",
    ) in (messages(caplog))
    wire.answer(reply(hello.seq))
    wire.poll()
    third, msg = setpoint(wire)
    assert msg.seq == hello.seq + 1
    wire.answer(Ack(msg.seq, MsgType.SETPOINT))
    wire.poll()
    assert third.outcome is Outcome.ACKED


def test_an_answer_goes_to_its_own_request_only() -> None:
    wire = Wire()
    req, msg = setpoint(wire)
    wire.answer(
        Ack(msg.seq + 1, MsgType.SETPOINT),  # another seq
        Ack(msg.seq, MsgType.ESTOP_RESET),  # another type
        Nack(msg.seq + 7, MsgType.SETPOINT, NackCode.BAD_MODE),
    )
    wire.poll()
    assert not req.done
    assert wire.session.stats().duplicates == 3
    wire.answer(Ack(msg.seq, MsgType.SETPOINT))
    wire.poll()
    assert req.outcome is Outcome.ACKED
    wire.answer(Ack(msg.seq, MsgType.SETPOINT))  # late copy: a duplicate, nothing else
    wire.poll()
    assert wire.session.stats().duplicates == 4 and wire.session.stats().sent == 1


def test_the_next_queued_request_goes_out_as_soon_as_one_is_answered() -> None:
    wire = Wire()
    _, m1 = setpoint(wire, 1)
    second, m2 = setpoint(wire, 2)
    assert wire.sent() == [m1]
    wire.answer(Ack(m1.seq, MsgType.SETPOINT))
    wire.poll()
    assert wire.sent() == [m2]
    wire.answer(Nack(m2.seq, MsgType.SETPOINT, NackCode.OUT_OF_RANGE))
    _, m3 = setpoint(wire, 3)
    wire.poll()
    assert second.outcome is Outcome.NACKED and wire.sent() == [m3]
    assert wire.session.take_failures() == [second]


def test_a_newer_bulk_supersedes_an_older_one_queued_or_in_flight() -> None:
    wire = Wire()
    modes = [None] * LAYOUT.n_motors
    ahead, _ = setpoint(wire)
    queued = wire.session.send_bulk(modes, [1] * LAYOUT.n_motors)
    wire.poll(0.01)
    newer = wire.session.send_bulk(modes, [2] * LAYOUT.n_motors)
    assert (queued.outcome, queued.acked_at_s) == (Outcome.SUPERSEDED, wire.clock.now())
    assert list(wire.session._queue) == [newer]  # white box: the old one left the queue
    assert ahead.outcome is Outcome.PENDING
    wire.answer(Ack(ahead.seq, MsgType.SETPOINT))
    wire.poll()
    assert wire.sent()[-1] == newer.msg
    wire.poll(0.01)
    newest = wire.session.send_bulk(modes, [3] * LAYOUT.n_motors)
    assert (newer.outcome, newer.acked_at_s) == (Outcome.SUPERSEDED, wire.clock.now())
    stats = wire.session.stats()
    assert (stats.superseded, stats.sent, stats.failed) == (2, 3, 0)
    assert wire.sent() == [newest.msg]
    wire.answer(state(5, ack_seq=newest.seq))
    wire.poll()
    assert (newest.outcome, newest.ack_status) == (Outcome.ACKED, AckStatus.APPLIED)
    assert wire.session.take_failures() == []


@pytest.mark.parametrize(("modes", "values"), [(1, 1), (1, 0), (0, 1)])
def test_a_bulk_that_does_not_match_the_layout_is_refused(modes: int, values: int) -> None:
    wire = Wire()
    n = LAYOUT.n_motors
    with pytest.raises(ValueError, match=r"^bulk setpoints do not match the layout$"):
        wire.session.send_bulk([None] * (n + modes), [0] * (n + values))


# -- the e-stop -------------------------------------------------------------------------------


def test_an_estop_goes_out_first_and_cancels_what_waits() -> None:
    wire = Wire()
    flying, m1 = setpoint(wire)
    waiting, _ = setpoint(wire)
    reset = wire.session.estop_reset()
    wire.poll(0.01)
    stop = wire.session.estop()
    assert stop.created_s == wire.clock.now()
    for req in (flying, waiting, reset):
        assert (req.outcome, req.acked_at_s) == (Outcome.CANCELLED, wire.clock.now())
    assert wire.sent() == [m1, EStop(stop.seq)]
    assert wire.session.stats().cancelled == 3
    wire.answer(Ack(stop.seq, MsgType.ESTOP))
    wire.poll()
    assert (stop.outcome, stop.ack_status) == (Outcome.ACKED, AckStatus.APPLIED)
    assert wire.session.stats().estopped


class FailingOnce:
    """A byte link whose next write fails."""

    def __init__(self, inner: object) -> None:
        self.inner = inner
        self.fail = False
        self.baud = 115200

    def read_available(self) -> bytes:
        return self.inner.read_available()  # type: ignore[attr-defined, no-any-return]

    def write(self, data: bytes) -> None:
        if self.fail:
            self.fail = False
            raise LinkError("port unplugged")
        self.inner.write(data)  # type: ignore[attr-defined]

    def drain_input(self) -> int:
        return 0

    def close(self) -> None:
        pass


def test_an_estop_whose_write_fails_is_written_again_when_due(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.ERROR, logger=LOG)
    wire = Wire()
    flaky = FailingOnce(wire.host)
    wire.session.link = flaky  # type: ignore[assignment]
    flaky.fail = True
    stop = wire.session.estop()  # never raises for a busy or broken link
    assert messages(caplog) == [(logging.ERROR, "e-stop write failed (will retry): port unplugged")]
    assert wire.sent() == []
    wire.poll(ACK_S - EPS)
    assert wire.sent() == []
    wire.poll(EPS)  # the retry, as for a lost frame
    assert wire.sent() == [EStop(stop.seq)]


def test_an_estop_reset_ack_releases_the_latch_but_a_stale_one_does_not() -> None:
    wire = Wire(hello=reply(flags=BridgeFlags.ESTOP | BridgeFlags.WATCHDOG))
    assert wire.session.stats().estopped and wire.session.stats().watchdog
    stale = wire.session.estop_reset()
    wire.answer(Ack(stale.seq, MsgType.ESTOP_RESET, AckStatus.STALE))
    wire.poll()
    assert wire.session.stats().estopped
    fresh = wire.session.estop_reset()
    wire.answer(Ack(fresh.seq, MsgType.ESTOP_RESET))
    wire.poll()
    stats = wire.session.stats()
    assert not stats.estopped and stats.watchdog  # only the latch is released


def test_an_estop_ack_sets_the_latch_and_keeps_the_other_flags() -> None:
    wire = Wire(hello=reply(flags=BridgeFlags.WATCHDOG))
    stop = wire.session.estop()
    wire.answer(Ack(stop.seq, MsgType.ESTOP))
    wire.poll()
    stats = wire.session.stats()
    assert stats.estopped and stats.watchdog


def test_an_estop_answer_moves_the_answered_mark_only_forward() -> None:
    """The e-stop's ack counts as an answer to the ordered counter (for the renewal gap)."""
    wire = Wire(first_seq=100)
    stop = wire.session.estop()
    wire.answer(Ack(stop.seq, MsgType.ESTOP))
    wire.poll()
    assert wire.sent() == [EStop(100)]
    wire.session._next_seq = 100 + SESSION_RENEW_GAP - 2  # white box
    _, msg = setpoint(wire)
    assert wire.sent() == [msg]  # no renewal: the e-stop (seq 100) was answered


def test_a_nacked_estop_or_counter_request_is_reported() -> None:
    wire = Wire()
    ask = wire.session.request_counters()
    assert ask.created_s == wire.clock.now()
    wire.answer(Nack(ask.seq, MsgType.COUNTERS_REQUEST, NackCode.NOT_READY))
    wire.poll()
    assert (ask.outcome, ask.nack) == (Outcome.NACKED, NackCode.NOT_READY)
    assert wire.session.take_failures() == [ask]


def test_counters_answer_their_request() -> None:
    wire = Wire()
    ask = wire.session.request_counters()
    wire.answer(counters(ask.seq + 1, rx_frames=3), counters(ask.seq, rx_frames=9))
    wire.poll(0.02)
    assert ask.outcome is Outcome.ACKED and ask.reply == counters(ask.seq, rx_frames=9)
    assert wire.session.stats().duplicates == 1
    assert list(wire.session.rtt_samples) == [pytest.approx(0.02)]


# -- waiting -------------------------------------------------------------------------------------


def test_a_wait_without_a_timeout_lasts_for_what_is_ahead_of_the_request() -> None:
    """Behind a new session's HELLO: its own give-up, the queue's and the HELLO's."""
    from dataclasses import replace

    wire = Wire(config=replace(CONFIG, link_timeout_s=5.0))
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))  # a bridge reset: HELLO goes out
    wire.poll()
    req, _ = setpoint(wire)
    start = wire.clock.now()
    with pytest.raises(LinkTimeout) as caught:
        wire.session.wait(req)
    timeout = 3 * CONFIG.give_up_s + 2 * CONFIG.poll_step_s
    assert str(caught.value) == f"{req!r} not answered within {timeout:.3f} s"
    assert wire.clock.now() == pytest.approx(start + timeout, abs=1e-9)


def test_a_request_that_is_never_answered_fails_within_its_default_wait() -> None:
    wire = Wire()
    req, _ = setpoint(wire)
    assert wire.session.wait(req).outcome is Outcome.FAILED


# -- liveness -------------------------------------------------------------------------------


def test_the_link_is_lost_just_after_the_link_timeout_of_silence(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.ERROR, logger=LOG)
    wire = Wire()
    req, _ = setpoint(wire)
    wire.clock.advance(CONFIG.link_timeout_s)
    wire.session.ensure_alive()  # exactly the timeout: still alive
    wire.answer(state(1))  # heard: the silence starts again
    wire.poll()
    wire.clock.advance(CONFIG.link_timeout_s + 0.01)
    with pytest.raises(LinkLost, match=r"^nothing heard from the bridge for 0\.510 s$"):
        wire.session.poll()
    assert messages(caplog) == [(logging.ERROR, "link lost: bridge silent for 0.510 s")]
    assert (req.outcome, req.acked_at_s) == (Outcome.FAILED, wire.clock.now())
    with pytest.raises(LinkLost, match=r"^nothing heard from the bridge for over 0\.5 s$"):
        wire.session.poll()
    assert not wire.session.stats().connected


def test_silence_is_counted_from_the_last_valid_frame() -> None:
    wire = Wire()
    for _ in range(3):
        wire.poll(0.3)
        wire.answer(BridgeHeartbeat(1))
        wire.poll()
    wire.far.write(b"\x07garbage\x00")  # not valid: not heard
    wire.poll(0.3)
    wire.poll(0.2)
    with pytest.raises(LinkLost):
        wire.poll(0.01)


def test_a_closed_session_says_so_and_fails_what_was_pending() -> None:
    wire = Wire()
    req, _ = setpoint(wire)
    wire.clock.advance(0.02)
    wire.session.close()
    assert (req.outcome, req.acked_at_s) == (Outcome.FAILED, wire.clock.now())
    assert wire.host.closed and not wire.session.stats().connected
    with pytest.raises(LinkError, match=r"^session closed$"):
        wire.session.poll()
    with pytest.raises(LinkError, match=r"^session closed$"):
        wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, 0)
    wire.session.close()  # again: nothing happens


def test_a_fresh_session_s_figures() -> None:
    stats = Wire().session.stats()
    assert stats.connected and stats.last_heard_s == 8.0
    assert (stats.crc_errors, stats.retries, stats.failed, stats.duplicates) == (0, 0, 0, 0)
    assert (stats.superseded, stats.sent, stats.stale, stats.cancelled) == (0, 0, 0, 0)
    assert (stats.estopped, stats.watchdog, stats.bridge_resets, stats.sessions) == (
        False,
        False,
        0,
        1,
    )
    assert stats.loss_ratio == 0.0
    assert Wire().session.latest_state() is None


def test_round_trip_samples_are_bounded() -> None:
    wire = Wire()
    for i in range(10_001):
        req = wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, i & 0xFF)
        wire.answer(Ack(req.seq, MsgType.SETPOINT))
        wire.session.poll()
    assert len(wire.session.rtt_samples) == 10_000
