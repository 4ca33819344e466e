"""Session 21: what the link's liveness (link/liveness.py) and its handling of HELLO_REPLYs
and bridge resets (link/hellos.py) do at their edges, pinned where the mutation run of
that day found nothing that would notice a change (docs/testing.md, Mutation testing).

Every time below is a binary fraction of a second on a simulated clock, so that "exactly
the link timeout" means it.
"""

from __future__ import annotations

import logging

import pytest
from session_wire import CODEC, CONFIG, LAYOUT, LOG, Wire, reply, setpoint, state

from pirate_bt.errors import LinkLost, ProtocolMismatch
from pirate_bt.link.codec import BridgeFlags, Hello, State
from pirate_bt.link.session import Session
from pirate_bt.link.testing import memory_pair

TICK = 1 / 64  # s
DEAF = (
    "the bridge reports its watchdog tripped for over 0.5 s: it hears nothing from the host"
    " (the line toward the bridge is down?)"
)


def _in_session(baud: int = 115200) -> Wire:
    """A session (HELLO seq 1, boot id 7, one session, a watchdog that keeps CONFIG's
    heartbeat period) whose first STATE came at 8 s + TICK, the last poll where the
    bridge's watchdog was not reported tripped."""
    first = reply(sessions=1, watchdog_ms=1250)
    wire = Wire(hello=first)
    if baud != 115200:
        wire.host, wire.far = memory_pair(baud)
        wire.session = Session(wire.host, CODEC, wire.clock, CONFIG, first_seq=2, hello_reply=first)
    assert wire.session.config.heartbeat_period_s == CONFIG.heartbeat_period_s
    wire.answer(state(1))
    wire.poll(TICK)
    return wire


def _errors(caplog: pytest.LogCaptureFixture, level: int = logging.ERROR) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == LOG and r.levelno == level]


def _hellos(wire: Wire) -> list[Hello]:
    return [m for m in wire.sent() if isinstance(m, Hello)]


# -- liveness: the bridge's watchdog reported tripped while the host kept sending ----------


def test_a_bridge_deaf_to_the_host_loses_the_link_just_over_the_timeout_not_at_it(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    for seq in range(2, 34):  # 32 ticks: exactly 0.5 s of STATEs reporting the trip
        wire.answer(state(seq, flags=BridgeFlags.WATCHDOG))
        wire.poll(TICK)
    assert wire.session.stats().connected
    req, _ = setpoint(wire)  # in flight when the link is lost
    wire.answer(state(34, flags=BridgeFlags.WATCHDOG))
    with caplog.at_level(logging.ERROR, logger=LOG), pytest.raises(LinkLost) as caught:
        wire.poll(TICK)
    lost_at = wire.clock.now()
    assert str(caught.value) == DEAF
    assert f"link lost: {DEAF}" in _errors(caplog)
    assert req.done and req.acked_at_s == lost_at  # failed at the time the link was lost
    assert not wire.session.stats().connected
    with pytest.raises(LinkLost) as again:  # and it stays lost, in the same words
        wire.poll(TICK)
    assert str(again.value) == DEAF


def test_a_bridge_tripped_from_the_instant_the_host_holds_its_heartbeats_back_is_not_deaf() -> None:
    """The dead man's handle stops the heartbeats at 33 ticks after the last good STATE:
    from that very instant the bridge's trip is the host's doing, however long it lasts."""
    wire = _in_session()
    wire.session.feed_watchdog_until(wire.clock.now() + 33 * TICK)
    for seq in range(2, 120):  # 1.8 s of STATEs reporting the trip
        wire.answer(state(seq, flags=BridgeFlags.WATCHDOG))
        wire.poll(TICK)
    assert wire.session.stats().connected


def _deaf_then_quiet(quiet_s: float) -> Wire:
    """The bridge reports its watchdog tripped from 8 s + TICK; the host's last heartbeat
    goes at 8.375 s, then the host polls (and sends) nothing for ``quiet_s``, and the next
    STATE, still tripped, comes 0.6 s or more after the trip began."""
    wire = _in_session()
    for seq in range(2, 25):  # until 8.375 s, a heartbeat's time
        wire.answer(state(seq, flags=BridgeFlags.WATCHDOG))
        wire.poll(TICK)
    assert wire.clock.now() == 8.375
    assert wire.sent(heartbeats=True)  # a heartbeat went at that poll
    wire.answer(state(25, flags=BridgeFlags.WATCHDOG))
    wire.clock.advance(quiet_s)
    return wire


def test_a_host_quiet_for_two_heartbeat_periods_still_counts_as_sending() -> None:
    wire = _deaf_then_quiet(2 * CONFIG.heartbeat_period_s)
    with pytest.raises(LinkLost) as caught:
        wire.session.poll()
    assert str(caught.value) == DEAF


def test_a_host_quiet_for_over_two_heartbeat_periods_tripped_the_bridge_itself() -> None:
    wire = _deaf_then_quiet(2 * CONFIG.heartbeat_period_s + TICK)
    wire.session.poll()  # the trip is the host's doing: not a deaf bridge
    assert wire.session.stats().connected


def test_a_link_lost_to_line_noise_says_so_in_its_log(caplog: pytest.LogCaptureFixture) -> None:
    wire = _in_session()
    wire.far.write(b"\x05" * 20 + b"\x00")  # bytes that make no good frame
    wire.poll(TICK)
    with caplog.at_level(logging.ERROR, logger=LOG), pytest.raises(LinkLost) as caught:
        wire.poll(0.5)
    why = str(caught.value)
    assert why.startswith("no good frame from the bridge for 0.5"), why
    assert f"link lost: {why}" in _errors(caplog)


# -- a new session's reply: the watchdog its line can keep fed, its flags --------------------


def _mid_session_hello(wire: Wire) -> Hello:
    wire.answer(state(2, flags=BridgeFlags.NO_SESSION | BridgeFlags.ESTOP))  # a reset
    wire.poll(TICK)
    (hello,) = _hellos(wire)
    return hello


@pytest.mark.parametrize("watchdog_ms", [0, 18])
def test_a_new_session_s_watchdog_its_line_keeps_fed_or_unsaid_is_taken(watchdog_ms: int) -> None:
    """At 100000 baud a heartbeat takes 0.9 ms, and ten a period of at most half the
    line need a watchdog of 18 ms; 0 is a bridge that does not say."""
    wire = _in_session(baud=100000)
    hello = _mid_session_hello(wire)
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8, watchdog_ms=watchdog_ms))
    wire.poll(TICK)
    assert wire.session.stats().sessions == 2
    assert wire.session.last_hello_reply is not None
    assert wire.session.last_hello_reply.boot_id == 8


def test_a_new_session_s_watchdog_just_too_short_for_its_line_is_refused_in_figures() -> None:
    wire = _in_session(baud=100000)
    hello = _mid_session_hello(wire)
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8, watchdog_ms=17))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(TICK)
    assert str(caught.value) == (
        "the bridge's watchdog is 17 ms, shorter than its line can keep fed (ten heartbeats"
        " a period, each 0.90 ms at 100000 baud: at least 18 ms); a firmware built for"
        " another robot description?"
    )


def test_a_new_session_s_reply_with_no_session_still_set_is_refused() -> None:
    wire = _in_session()
    hello = _mid_session_hello(wire)
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8, flags=BridgeFlags.NO_SESSION))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(TICK)
    assert str(caught.value) == (
        "the bridge answered HELLO with NO_SESSION still set: it took no session (a bridge"
        " that does not follow the protocol)"
    )
    assert wire.session.stats().sessions == 1


def test_a_new_session_s_reply_with_the_estop_input_alone_is_said(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    hello = _mid_session_hello(wire)
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8, flags=BridgeFlags.ESTOP_INPUT))
    with caplog.at_level(logging.ERROR, logger=LOG):
        wire.poll(TICK)
    flags = f"{int(BridgeFlags.ESTOP_INPUT):#04x}"
    assert (
        "the bridge reports its hardware e-stop input (ESTOP_INPUT) without its e-stop"
        f" latched (ESTOP), which the protocol rules out: taken as latched (flags {flags})"
    ) in _errors(caplog)


def test_a_reply_counting_no_session_names_the_hello_that_started_the_new_one(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    hello = _mid_session_hello(wire)
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8))
    wire.poll(TICK)
    wire.answer(reply(seq=40, sessions=0, boot_id=8))
    with caplog.at_level(logging.ERROR, logger=LOG), pytest.raises(ProtocolMismatch) as caught:
        wire.poll(TICK)
    why = str(caught.value)
    assert f"(started by HELLO seq {hello.seq})" in why, why
    assert why in _errors(caplog)


def test_a_state_of_another_session_is_said_once_a_session(
    caplog: pytest.LogCaptureFixture,
) -> None:
    def foreign(seq: int) -> State:  # acknowledges a BULK the host never sent
        boards, values = (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels
        return State(seq, BridgeFlags.NONE, 900, 0, boards, values)

    wire = Wire(hello=reply(sessions=1))
    with caplog.at_level(logging.WARNING, logger=LOG):
        wire.answer(foreign(1), foreign(2))
        wire.poll(TICK)
        hello = _mid_session_hello(wire)
        wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8))
        wire.poll(TICK)
        wire.answer(foreign(3), foreign(4))
        wire.poll(TICK)
    said = [m for m in _errors(caplog, logging.WARNING) if "did not send in this session" in m]
    assert len(said) == 2, said


# -- stale NO_SESSION frames: the boot unchanged -----------------------------------------------


def _stale_reset(wire: Wire, sessions: int, seq: int) -> None:
    """A NO_SESSION STATE of the boot the bridge is still in; its new session's reply."""
    wire.answer(state(seq, flags=BridgeFlags.NO_SESSION))
    wire.poll(TICK)
    (hello,) = _hellos(wire)
    wire.answer(reply(seq=hello.seq, sessions=sessions, boot_id=7))
    wire.poll(TICK)


def test_three_stale_resets_in_a_row_end_the_session_two_do_not(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    with caplog.at_level(logging.WARNING, logger=LOG):
        _stale_reset(wire, 2, 2)
    assert (
        "a stale NO_SESSION frame (reordered link?) started a new session; the bridge was"
        " not reset (boot id 7 unchanged)"
    ) in _errors(caplog, logging.WARNING)
    _stale_reset(wire, 3, 3)
    stats = wire.session.stats()
    assert (stats.sessions, stats.bridge_resets) == (3, 0)
    with pytest.raises(ProtocolMismatch) as caught:
        _stale_reset(wire, 4, 4)
    assert str(caught.value) == (
        "the bridge took 3 HELLOs in a row without a reset (boot id 7 unchanged) but sent"
        " NO_SESSION after each: it never keeps a session (a bridge that does not follow"
        " the protocol)"
    )


def test_after_a_stale_reset_the_state_seqs_run_on() -> None:
    """The reply shows the same boot: a STATE older than the last one taken is not taken."""
    wire = _in_session()
    for seq in range(2, 10):
        wire.answer(state(seq))
        wire.poll(TICK)
    _stale_reset(wire, 2, 10)
    wire.answer(state(5))
    wire.poll(TICK)
    latest = wire.session.latest_state()
    assert latest is not None and latest[0].seq == 9


def test_sixteen_stale_replies_of_another_boot_end_the_session_in_their_words(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    seq = 2
    for n in range(1, 17):
        wire.answer(reply(seq=5, sessions=90, boot_id=6))  # a relay's old frame
        wire.poll(TICK)
        (hello,) = _hellos(wire)
        wire.answer(reply(seq=hello.seq, sessions=n + 1, boot_id=7))
        if n == 16:
            break
        wire.poll(TICK)
        wire.answer(state(seq))  # a good STATE between them: not "in a row"
        seq += 1
        wire.poll(TICK)
    assert wire.session.stats().sessions == 16
    with caplog.at_level(logging.ERROR, logger=LOG), pytest.raises(ProtocolMismatch) as caught:
        wire.poll(TICK)
    why = (
        "the bridge's frames started 16 sessions within 5 s that were not the bridge's own"
        " reset (stale HELLO_REPLYs of another boot): each makes it stop its drives (a bridge"
        " that does not follow the protocol, or frames forged or replayed on the line)"
    )
    assert str(caught.value) == why
    assert why in _errors(caplog)
    assert wire.session.stats().sessions == 16  # the 16th was not taken


# -- replies no HELLO in flight asked for ------------------------------------------------------


def test_a_reply_before_any_session_is_only_counted() -> None:
    wire = Wire()  # opened without a reply: no session yet, and no HELLO in flight
    wire.answer(reply(seq=1, sessions=2))
    wire.poll()
    assert wire.session.stats().duplicates == 1


def test_a_doubled_reply_is_only_counted() -> None:
    wire = _in_session()
    wire.answer(reply(seq=1, sessions=1))
    wire.poll(TICK)
    assert wire.session.stats().duplicates == 1
    assert not _hellos(wire)


def test_an_unasked_reply_while_a_new_session_is_on_its_way_is_only_counted(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    _mid_session_hello(wire)
    caplog.clear()
    with caplog.at_level(logging.ERROR, logger=LOG):
        wire.answer(reply(seq=900, sessions=5, boot_id=7))
        wire.poll(TICK)
    assert not _hellos(wire)  # no second HELLO
    assert not _errors(caplog)
    assert wire.session.last_hello_reply is not None
    assert wire.session.last_hello_reply.sessions == 1


def test_an_unasked_reply_of_another_boot_fails_what_was_in_flight_at_its_time() -> None:
    wire = _in_session()
    req, _ = setpoint(wire)
    wire.answer(reply(seq=5, sessions=1, boot_id=8))
    wire.poll(TICK)
    assert req.done and req.acked_at_s == wire.clock.now()
    assert len(_hellos(wire)) == 1


def _unasked(wire: Wire, sessions: int, dt: float = TICK) -> None:
    """A reply of the same boot for a HELLO the host did not send (seq 900), counting
    ``sessions``; the host's new session then answered."""
    wire.answer(reply(seq=900, sessions=sessions, boot_id=7))
    wire.poll(dt)
    hellos = _hellos(wire)
    if hellos:
        wire.answer(reply(seq=hellos[0].seq, sessions=sessions + 1, boot_id=7))
        wire.poll()


def test_an_unasked_reply_restarts_the_session_and_says_why(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    req, _ = setpoint(wire)
    with caplog.at_level(logging.WARNING, logger=LOG):
        wire.answer(reply(seq=900, sessions=5, boot_id=7))
        wire.poll(TICK)
    assert wire.session.last_hello_reply is not None
    assert wire.session.last_hello_reply.sessions == 5
    assert req.done and req.acked_at_s == wire.clock.now()
    assert len(_hellos(wire)) == 1
    assert (
        "the bridge started session 5 for HELLO seq 900, which the host did not send now (a"
        " replayed or late frame): its duplicate filter went back to that seq"
    ) in _errors(caplog)
    assert "starting a new session: the bridge took a HELLO the host did not send now" in (
        _errors(caplog, logging.WARNING)
    )


def test_four_unasked_sessions_within_the_link_timeout_end_the_session(
    caplog: pytest.LogCaptureFixture,
) -> None:
    wire = _in_session()
    for n in range(3):
        _unasked(wire, 10 + 2 * n)
    wire.answer(reply(seq=900, sessions=20, boot_id=7))
    with caplog.at_level(logging.ERROR, logger=LOG), pytest.raises(ProtocolMismatch) as caught:
        wire.poll(TICK)
    why = (
        "the bridge's frames started 4 sessions within 0.5 s that were not the bridge's own"
        " reset (HELLO_REPLYs the host did not ask for): each makes it stop its drives (a"
        " bridge that does not follow the protocol, or frames forged or replayed on the"
        " line)"
    )
    assert str(caught.value) == why
    assert why in _errors(caplog)
    assert not _hellos(wire)  # no new session for the fourth


@pytest.mark.parametrize(
    ("gaps", "ends"),
    [
        ([0.25, 0.125, 0.125], True),  # the fourth exactly the link timeout after the first
        ([0.25, 0.125, 0.125 + TICK], False),  # the first over the link timeout before
        ([0.75, 0.125, 0.125, 0.125], True),  # four within it, after one long before
    ],
    ids=["at-timeout", "over-timeout", "after-an-old-one"],
)
def test_unasked_sessions_end_the_session_when_four_came_within_the_link_timeout(
    gaps: list[float], ends: bool
) -> None:
    wire = _in_session()
    _unasked(wire, 10)
    for n, gap in enumerate(gaps[:-1]):
        _unasked(wire, 12 + 2 * n, gap)
    wire.answer(reply(seq=900, sessions=40, boot_id=7))
    if ends:
        with pytest.raises(ProtocolMismatch, match=r"started 4 sessions within 0\.5 s"):
            wire.poll(gaps[-1])
    else:
        wire.poll(gaps[-1])
        assert len(_hellos(wire)) == 1


def test_a_stale_reset_is_not_counted_with_unasked_replies() -> None:
    wire = _in_session()
    _unasked(wire, 10)
    _unasked(wire, 12)
    _stale_reset(wire, 14, 2)
    _unasked(wire, 16)  # three unasked within the timeout, one stale reset: not four
    assert wire.session.stats().connected
    wire.session.ensure_alive()
