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
import threading
import time

import pytest

from pirate_bt.clock import SimClock, WallClock
from pirate_bt.errors import FrameError, LinkError, LinkLost, LinkTimeout, ProtocolMismatch
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BridgeHeartbeat,
    Counters,
    EStop,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
    State,
    encode_many,
)
from pirate_bt.link.requests import SESSION_RENEW_GAP, Outcome, SessionConfig
from pirate_bt.link.session import HELLO_TRIES, Session
from pirate_bt.link.testing import memory_pair
from pirate_bt.robot import ControlMode, load_robot

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
LAYOUT = CODEC.layout
# Binary fractions, so that simulated times add up exactly and "exactly when due" means it.
ACK_S = 0.0625
EPS = 1 / 1024
CONFIG = SessionConfig(
    ack_timeout_s=ACK_S,
    max_retries=2,
    heartbeat_period_s=0.125,
    link_timeout_s=0.5,
    poll_step_s=0.005,
    loss_window=4,
)
LOG = "pirate_bt.link.session"


def reply(seq: int = 1, **changes: object) -> HelloReply:
    fields: dict[str, object] = {
        "seq": seq,
        "layout_digest": LAYOUT.digest,
        "n_channels": LAYOUT.n_channels,
        "n_motors": LAYOUT.n_motors,
        "watchdog_ms": 250,
        "boot_id": 7,
        "minor": SessionConfig().protocol_minor,  # the session's (1.2 by default)
    }
    fields.update(changes)
    return HelloReply(**fields)  # type: ignore[arg-type]


def state(seq: int, ack_seq: int = 0, flags: BridgeFlags = BridgeFlags.NONE) -> State:
    return State(seq, flags, ack_seq, 0, (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels)


class Wire:
    """A session whose bridge is the test: ``sent()`` decodes what the host wrote since the
    last call, ``answer()`` writes frames back, ``poll(dt)`` lets simulated time pass."""

    def __init__(
        self,
        config: SessionConfig = CONFIG,
        first_seq: int = 2,
        hello: HelloReply | None = None,
        start_s: float = 8.0,
    ) -> None:
        self.clock = SimClock(start_s)
        self.host, self.far = memory_pair()
        self.session = Session(
            self.host, CODEC, self.clock, config, first_seq=first_seq, hello_reply=hello
        )
        self.decoder = FrameDecoder(CODEC)

    def sent(self, *, heartbeats: bool = False) -> list[Message]:
        out = [
            m for m in self.decoder.feed(self.far.read_available()) if not isinstance(m, FrameError)
        ]
        return out if heartbeats else [m for m in out if not isinstance(m, Heartbeat)]

    def answer(self, *msgs: Message) -> None:
        self.far.write(encode_many(CODEC, msgs))

    def poll(self, dt: float = 0.0) -> None:
        if dt:
            self.clock.advance(dt)
        self.session.poll()


def setpoint(wire: Wire, value: int = 1) -> tuple[object, Setpoint]:
    req = wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, value)
    msg = req.msg
    assert isinstance(msg, Setpoint)
    return req, msg


def messages(caplog: pytest.LogCaptureFixture) -> list[tuple[int, str]]:
    return [(r.levelno, r.getMessage()) for r in caplog.records if r.name == LOG]


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
    wire.answer(Counters(ask.seq + 1, rx_frames=3), Counters(ask.seq, rx_frames=9))
    wire.poll(0.02)
    assert ask.outcome is Outcome.ACKED and ask.reply == Counters(ask.seq, rx_frames=9)
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
    "answer",
    [{"layout_digest": LAYOUT.digest ^ 1}, {"minor": 1}],
)
def test_a_new_session_on_another_layout_or_version_is_refused(
    answer: dict[str, int], caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.ERROR, logger=LOG)
    wire = Wire(hello=reply())
    wire.answer(BridgeHeartbeat(3, BridgeFlags.NO_SESSION))
    wire.poll()
    hello = wire.session._hello  # white box: the HELLO's request
    assert hello is not None
    wire.answer(reply(seq=hello.seq, **answer))
    with pytest.raises(
        ProtocolMismatch, match=r"^the bridge answered a new session with another layout$"
    ):
        wire.poll()
    assert hello.outcome is Outcome.NACKED
    assert (logging.ERROR, "the bridge answered a new session with another layout") in messages(
        caplog
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
    wire.answer(Counters(ask.seq), Counters(ask.seq), Counters(ask.seq))
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
