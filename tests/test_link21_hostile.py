"""Session 21: bytes no frame should contain, sent by a hostile bridge to the host.

The session on a simulated clock (tests/session_wire.py), the bridge played by the test;
docs/protocol.md, Bad frames and Timing.
"""

from __future__ import annotations

import math
import random
import re

import pytest
from cleanroom_peer import HELLO_REPLY, STATE, PeerBridge, frame, hello_reply_payload
from session_wire import CODEC, ROBOT, Peer, Wire, reply, state
from test_link21_sessions import LAYOUT as PAGE_LAYOUT
from test_link21_sessions import _stopped

from pirate_bt.errors import LinkError, LinkLost, ProtocolMismatch
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BridgeHeartbeat,
    BulkSetpoints,
    Heartbeat,
    Hello,
    Message,
    MsgType,
    State,
)
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.robot import ControlMode, MotorCommand

LAYOUT = CODEC.layout


@pytest.mark.parametrize("same_read", [True, False], ids=["with-a-good-frame", "alone"])
def test_a_bridge_silent_mid_frame_is_named_by_the_bytes_it_sent(same_read: bool) -> None:
    """A frame cut off, then silence: the lost link names the bytes that made no frame,
    whatever reads they came in. When they came in the read of the last good frame it
    said *nothing heard from the bridge*, as for a silent line."""
    wire = Wire(hello=reply(sessions=1))
    wire.answer(state(1))
    wire.poll(0.01)
    cut = CODEC.encode(state(3))[:20]
    if same_read:
        wire.far.write(CODEC.encode(state(2)) + cut)
    else:
        wire.answer(state(2))
        wire.poll(0.01)
        wire.far.write(cut)
    wire.poll(0.01)
    assert re.fullmatch(r"20 bytes that made no frame", wire.session.stats().line_noise)
    with pytest.raises(LinkLost) as caught:
        for _ in range(100):
            wire.poll(0.01)
    assert re.fullmatch(
        r"no good frame from the bridge for 0\.5\d\d s: 20 bytes that made no frame",
        str(caught.value),
    ), str(caught.value)


# -- a reply to a request never made: a HELLO_REPLY of another boot ------------------------


def _in_session() -> Wire:
    wire = Wire(hello=reply(sessions=1))
    wire.answer(state(1))
    wire.poll(0.01)
    return wire


def test_an_unasked_hello_reply_of_another_boot_is_a_bridge_reset() -> None:
    """The bridge was reset and took a HELLO the host did not send: its boot id says so.
    It was only counted, and the new boot's STATEs (numbered from 1) were refused as out
    of sequence until the run ended on *link_silent*."""
    wire = _in_session()
    wire.answer(reply(seq=5, sessions=1, boot_id=8, flags=BridgeFlags.ESTOP))
    wire.poll(0.01)
    hellos = [m for m in wire.sent() if isinstance(m, Hello)]
    assert len(hellos) == 1  # a session of the host's own
    assert wire.session.stats().bridge_resets == 1
    wire.answer(reply(seq=hellos[0].seq, sessions=2, boot_id=8, flags=BridgeFlags.ESTOP))
    wire.answer(state(2, flags=BridgeFlags.ESTOP))  # the new boot's second STATE
    wire.poll(0.01)
    stats = wire.session.stats()
    assert (stats.bridge_resets, stats.sessions, stats.estopped) == (1, 2, True)
    assert wire.session.latest_state() is not None
    assert wire.session.latest_state()[0].seq == 2  # taken, not refused as older than 1


def test_a_stale_hello_reply_of_another_boot_is_not_counted_as_a_reset(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A reply of the boot before (a relay's buffer): the host's own new session shows the
    boot unchanged, and the reset is taken back, as for a stale NO_SESSION frame."""
    wire = _in_session()
    wire.answer(reply(seq=5, sessions=3, boot_id=6))
    wire.poll(0.01)
    (hello,) = [m for m in wire.sent() if isinstance(m, Hello)]
    wire.answer(reply(seq=hello.seq, sessions=2, boot_id=7))
    with caplog.at_level("WARNING", logger="pirate_bt.link.session"):
        wire.poll(0.01)
    assert wire.session.stats().bridge_resets == 0
    assert (
        "a stale HELLO_REPLY of boot id 6, not 7, that the host did not ask for (reordered"
        " link?) started a new session; the bridge was not reset (boot id 7 unchanged)"
    ) in caplog.text


def test_the_reply_to_a_new_session_with_other_channel_counts_is_refused() -> None:
    """The digest alone was checked in the middle of a connection; the connect checks the
    channel and motor counts too."""
    wire = _in_session()
    wire.answer(state(2, flags=BridgeFlags.NO_SESSION))
    wire.poll(0.01)
    (hello,) = [m for m in wire.sent() if isinstance(m, Hello)]
    wire.answer(reply(seq=hello.seq, sessions=1, boot_id=8, n_channels=LAYOUT.n_channels + 1))
    with pytest.raises(ProtocolMismatch) as caught:
        wire.poll(0.01)
    assert str(caught.value) == "the bridge answered a new session with another layout"


@pytest.mark.xdist_group("real-time")
def test_a_run_whose_bridge_resets_and_answers_another_s_hello_ends_in_one_line() -> None:
    """The page's bridge on TCP resets after 0.3 s, takes a HELLO the host did not send
    and numbers its STATEs from 1 again: exit 3, *it reset in the middle of the session*,
    one line, the robot stopped (before: *link_silent: ... 10 out of sequence*)."""
    import pirate_bt

    reset_at: list[int] = []

    def hostile(n: int, peer: PeerBridge) -> bytes | None:
        if not reset_at:
            if n <= 30 or not peer.session or peer.estopped:
                return None
            reset_at.append(n)
            peer.reset()  # latched, a new boot id, no session
            peer.session, peer.sessions = True, 1  # and someone else's HELLO taken
            unasked = frame(
                HELLO_REPLY, 5, hello_reply_payload(PAGE_LAYOUT, boot_id=peer.boot_id), peer.flags()
            )
        else:
            unasked = b""
        seq = n - reset_at[0] + 1
        payload = PAGE_LAYOUT.state_payload(ack_seq=peer.ack_seq, values=peer.values)
        return unasked + frame(STATE, seq, payload, peer.flags())

    peer = PeerBridge(PAGE_LAYOUT, state=hostile)
    try:
        result = pirate_bt.run_tree("straight", port=peer.url, params={"distance": "0.1 m"})
        assert result.exit_code == 3, result.why
        assert "it reset in the middle of the session" in result.why, result.why
        assert "\n" not in result.why, result.why
        assert peer.wait_for(_stopped), [(f.kind, f.seq) for f in peer.received]
    finally:
        peer.close()


# -- replies with the wrong sequence number ------------------------------------------------


def _answering_with_another_seq(msg: Message) -> list[Message]:
    """A bridge that acknowledges every bulk with the seq after its own, and heartbeats
    as it should (so the link stays heard)."""
    if isinstance(msg, Heartbeat):
        return [Ack(msg.seq, MsgType.HEARTBEAT, AckStatus.APPLIED)]
    if isinstance(msg, BulkSetpoints):
        return [Ack((msg.seq + 1) & 0xFFFF, MsgType.BULK_SETPOINTS, AckStatus.APPLIED)]
    return []


def test_a_request_answered_with_another_seq_fails_naming_those_answers() -> None:
    """The bridge answered each try with another seq: the request fails after its tries,
    and the failure says the bridge answered, not *though the bridge's STATE frames still
    arrive (does it hear the host?)*: it hears the host."""
    peer = Peer(_answering_with_another_seq)
    link = RobotLink(ROBOT, peer.session())
    drive = [MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.01)]
    link.send(drive)
    with pytest.raises(LinkError) as caught:  # at a poll, since 2026-12-01 (a send before)
        for i in range(40):
            peer.far.write(CODEC.encode(state(100 + i)))  # STATEs go on arriving
            peer.clock.advance(0.01)
            link.poll()
    assert str(caught.value) == (
        "1 earlier request(s) failed; last: BulkSetpoints seq 2 not acknowledged after 3"
        " tries, though the bridge sent 3 answers meanwhile to requests the host never made"
        " (another seq or type than any asked: does it follow the protocol?)"
    )
    link.close()


def test_a_late_answer_to_a_request_given_up_is_no_answer_to_one_never_made() -> None:
    """A slow line: the answer comes after the request was given up. That is no sign of a
    bridge that answers requests never made, and the failure says what it said."""
    wire = _in_session()
    link = RobotLink(ROBOT, wire.session)
    drive = [MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.01)]
    link.send(drive)
    (bulk,) = [m for m in wire.sent() if isinstance(m, BulkSetpoints)]
    for i in range(30):
        wire.answer(state(2 + i))  # STATEs that acknowledge nothing
        wire.poll(0.01)
    wire.answer(Ack(bulk.seq, MsgType.BULK_SETPOINTS, AckStatus.DUPLICATE))  # too late
    wire.poll(0.01)
    with pytest.raises(LinkError) as caught:
        link.send(drive)
    assert str(caught.value).endswith(
        "not acknowledged after 3 tries, though the bridge's STATE frames still arrive (does"
        " it hear the host?)"
    )
    link.close()


# -- bytes no frame should contain: skipped, counted, never taken --------------------------


def _frame(kind: int, payload: bytes, seq: int = 7, arg: int = 0) -> bytes:
    """A frame whose CRC is good, whatever it carries (the clean-room peer's encoder)."""
    return frame(kind, seq, payload, arg)


def _cut_at_every_position() -> bytes:
    whole = CODEC.encode(state(50))
    return b"".join(whole[:k] + b"\x00" for k in range(1, len(whole) - 1))


_STATE_BYTES = len(CODEC.encode(state(1))) - 9  # the payload: COBS, header, CRC, delimiter off
_HOSTILE = {
    "random-bytes": (random.Random(21).randbytes(4000), "crc_errors"),
    "lying-length": (
        b"".join(
            _frame(kind, bytes(n))
            for kind, n in (
                (0x81, 13),
                (0x81, 15),
                (0x82, _STATE_BYTES - 1),
                (0x82, _STATE_BYTES + 1),
                (0x83, 1),
                (0x83, 3),
                (0x84, 0),
                (0x85, 19),
                (0x85, 21 + 13 * 9),
                (0x86, 1),
            )
        ),
        "crc_errors",
    ),
    "unknown-types": (
        b"".join(_frame(kind, b"\x01\x02") for kind in (0x00, 0x08, 0x7F, 0x80, 0x87, 0xFF)),
        "crc_errors",
    ),
    "unknown-ack-status-and-nack-code": (
        _frame(0x83, bytes([0x04, 9])) + _frame(0x84, bytes([0x02, 0])),
        "crc_errors",
    ),
    "sync-flood": (b"\x00" * 5000, None),
    "cut-at-every-position": (_cut_at_every_position(), "crc_errors"),
    "answers-to-nothing": (
        _frame(0x83, bytes([0x02, 0]), seq=900)  # ACK of a SETPOINT never sent
        + _frame(0x84, bytes([0x03, 7]), seq=901)  # NACK of a bulk never sent
        + _frame(0x83, bytes([0x04, 0]), seq=902),  # ACK of a heartbeat never sent
        "duplicates",
    ),
}


@pytest.mark.parametrize("name", sorted(_HOSTILE))
def test_bytes_no_frame_should_contain_are_skipped_counted_and_never_taken(name: str) -> None:
    """docs/protocol.md, Bad frames: a receiver drops a bad frame, counts it and carries on
    at the next delimiter. The host raises nothing, takes nothing of them (its newest STATE
    stays the last good one), counts them, and takes the next good STATE."""
    hostile, counter = _HOSTILE[name]
    wire = _in_session()
    before = wire.session.stats()
    wire.far.write(hostile + b"\x00")
    wire.poll(0.01)
    latest = wire.session.latest_state()
    assert latest is not None and latest[0] == state(1)  # nothing of them taken
    after = wire.session.stats()
    if counter is None:  # delimiters alone: an empty frame is no frame
        assert (after.crc_errors, after.duplicates) == (before.crc_errors, before.duplicates)
    else:
        assert getattr(after, counter) > getattr(before, counter)
    assert after.connected
    wire.answer(state(2))
    wire.poll(0.01)
    latest = wire.session.latest_state()
    assert latest is not None and latest[0] == state(2)  # the next good one is taken


@pytest.mark.parametrize("raw", [32767, -32768], ids=["max", "min"])
def test_a_state_of_extreme_raw_values_is_never_taken_as_a_reading(raw: int) -> None:
    """Every channel fresh at int16's end (a forged or damaged frame that passed the CRC):
    a channel whose raw range excludes it keeps its last reading and stamp (the IMU's
    too: its raw range is ±π, -31416..31416), every value stays finite, and each refusal
    counts."""
    wire = _in_session()
    link = RobotLink(ROBOT, wire.session)
    fresh = (1 << LAYOUT.n_channels) - 1
    good = State(2, BridgeFlags.NONE, 0, fresh, (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels)
    wire.answer(good)
    wire.poll(0.01)
    first = link.state()
    assert first is not None
    extreme = (raw,) * LAYOUT.n_channels
    wire.answer(State(3, BridgeFlags.NONE, 0, fresh, (1,) * LAYOUT.n_boards, extreme))
    wire.poll(0.01)
    second = link.state()
    assert second is not None and second is not first
    lows = {c.name: c.conversion.raw for c in ROBOT.state_channels()}
    refused = [name for name, (lo, hi) in lows.items() if not lo <= raw <= hi]
    assert refused and link.readings_refused == len(refused)
    for name, reading in second.readings.items():
        assert math.isfinite(reading.value), name
        if name in refused:
            assert reading == first.readings[name], name  # the last good one, its stamp
        else:
            assert reading.stamp_s > first.readings[name].stamp_s, name
    link.close()


# -- frames that restart the session again and again --------------------------------------


def _answer_hellos(wire: Wire, sessions: int) -> None:
    for msg in wire.sent():
        if isinstance(msg, Hello):
            wire.answer(reply(seq=msg.seq, sessions=sessions, boot_id=7))


def test_no_session_heartbeats_between_good_states_end_the_session_in_the_end() -> None:
    """A BRIDGE_HEARTBEAT with NO_SESSION between STATEs without it, every 50 ms, the boot
    unchanged: each started a session of the host's (the bridge applying its stop category
    each time) for as long as the run went on, since a good STATE between them reset the
    count of stale resets in a row."""
    wire = _in_session()
    with pytest.raises(ProtocolMismatch) as caught:
        for i in range(40):
            wire.answer(BridgeHeartbeat(100 + i, BridgeFlags.NO_SESSION), state(2 + i))
            wire.poll(0.025)
            _answer_hellos(wire, sessions=2 + i)
            wire.poll(0.025)
    assert str(caught.value).startswith(
        "the bridge's frames started 16 sessions within 5 s that were not the bridge's own"
        " reset (NO_SESSION frames of a boot it is still in):"
    ), str(caught.value)
    assert i < 20  # ended within a second, not at the loop's end


def test_unasked_hello_replies_again_and_again_end_the_session() -> None:
    """A HELLO_REPLY the host did not ask for, with a new session count, every 50 ms: each
    made the host start a session of its own, for as long as the run went on."""
    wire = _in_session()
    with pytest.raises(ProtocolMismatch) as caught:
        for i in range(40):
            wire.answer(reply(seq=1000 + i, sessions=10 + 2 * i, boot_id=7), state(2 + i))
            wire.poll(0.025)
            _answer_hellos(wire, sessions=11 + 2 * i)
            wire.poll(0.025)
    assert str(caught.value).startswith(
        "the bridge's frames started 4 sessions within 0.5 s that were not the bridge's own"
        " reset (HELLO_REPLYs the host did not ask for):"
    ), str(caught.value)
    assert i < 8


def test_a_close_whose_estop_wait_ends_before_its_give_up_says_it_was_never_answered(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """On a flooded line the reader thread polls late, and the close's wait for its e-stop
    (the e-stop's own retry budget) ends before the poll that gives it up: the close said
    *and the e-stop sent after it failed (Request(EStop seq=10 pending) not answered within
    0.240 s)*, a request's repr for what is an e-stop never acknowledged."""
    wire = _in_session()  # a bridge that answers nothing
    link = RobotLink(ROBOT, wire.session)
    session = wire.session
    wait = session.wait
    late = session.config.ack_timeout_s  # the last poll comes after the wait's end

    def wait_polled_late(request: object, timeout_s: float | None = None) -> object:
        return wait(request, late)  # type: ignore[arg-type]

    monkeypatch.setattr(session, "wait", wait_polled_late)
    for i in range(3):
        wire.answer(state(2 + i))
        wire.poll(0.01)
    link.close()
    assert str(link.close_error).startswith(
        "the closing stop was never acknowledged, nor was the e-stop sent after it"
    ), str(link.close_error)


def test_a_reading_out_of_range_is_named_once_though_older_frames_are_folded_after(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The newest STATE is checked first, then the older ones taken since the last snapshot
    (a reading fresh in one of them only is not lost): an older one in range made the
    channel 'read in range again', and the next older one out of range named it a second
    time, after the newest (seq 4, then seq 3), though it never read in range since."""
    wire = _in_session()
    link = RobotLink(ROBOT, wire.session)
    fresh = (1 << LAYOUT.n_channels) - 1
    mid = tuple(2048 if c.conversion.raw == (0, 4095) else 0 for c in ROBOT.state_channels())
    bad = (32767, *mid[1:])  # camera_tilt_angle, raw range 0..4095
    boards = (1,) * LAYOUT.n_boards
    wire.answer(State(2, BridgeFlags.NONE, 0, fresh, boards, mid))
    wire.poll(0.01)
    assert link.state() is not None
    wire.answer(
        State(3, BridgeFlags.NONE, 0, fresh, boards, mid),
        State(4, BridgeFlags.NONE, 0, fresh, boards, bad),
        State(5, BridgeFlags.NONE, 0, fresh, boards, bad),
    )
    wire.poll(0.01)
    with caplog.at_level("WARNING", logger="pirate_bt.link.robot_link"):
        link.state()
    named = [r.getMessage() for r in caplog.records if "camera_tilt_angle reads" in r.getMessage()]
    assert len(named) == 1, named
    assert link.readings_refused == 2  # seq 4 and 5, each counted
    link.close()
