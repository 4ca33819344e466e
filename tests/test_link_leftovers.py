"""Six small link-layer defects a probe found, each pinned by a test.

1. a fault kind that takes no target (``link_loss``) refuses one;
2. (see the report: not here yet);
3. ``PROTOCOL_MINOR``'s docstring says what the host asks for;
4. the hello messages name what differs;
5. the e-stop of a link's close is retried when its frame is lost;
6. a run of STATEs of another layout is a protocol mismatch, not stale data.
"""

from __future__ import annotations

import ast
import inspect
import itertools
from pathlib import Path

import pytest
from session_wire import Peer

import pirate_bt
from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import FrameError, InputError, ProtocolMismatch
from pirate_bt.link import framing
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BoardCounters,
    BridgeFlags,
    Counters,
    CountersRequest,
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
    State,
    cobs_decode,
    cobs_encode,
    crc16,
)
from pirate_bt.link.inbound import BAD_STATES_BEFORE_MISMATCH
from pirate_bt.link.opening import wrap_link
from pirate_bt.link.requests import Outcome, SessionConfig
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.link.session import Session
from pirate_bt.link.testing import MemoryLink, memory_pair
from pirate_bt.link.transport import HelloRefused, handshake
from pirate_bt.pipes import FaultSpec
from pirate_bt.robot import load_robot
from pirate_bt.sim.bridge import SimBridge
from pirate_bt.sim.faults import FaultTargetError, check_fault_target, parse_fault

ROBOT = load_robot()
STRAIGHT = Path(__file__).parents[1] / "trees" / "straight.yaml"
CODEC = FrameCodec.for_robot(ROBOT)
LAYOUT = CODEC.layout
# binary fractions, so that simulated times add up exactly
CONFIG = SessionConfig(
    ack_timeout_s=0.0625,
    max_retries=2,
    heartbeat_period_s=0.125,
    link_timeout_s=0.5,
    poll_step_s=0.005,
    loss_window=4,
)


def hello_reply(**changes: object) -> HelloReply:
    fields: dict[str, object] = {
        "seq": 1,
        "layout_digest": LAYOUT.digest,
        "n_channels": LAYOUT.n_channels,
        "n_motors": LAYOUT.n_motors,
        "watchdog_ms": 250,
        "boot_id": 7,
        "minor": 2,
    }
    fields.update(changes)
    return HelloReply(**fields)  # type: ignore[arg-type]


# -- 1. a fault kind that takes no target refuses one -----------------------------------------


@pytest.mark.parametrize("text", ["link_loss:22@1s", "link_loss:x@1s+2s"])
def test_link_loss_refuses_a_target(text: str) -> None:
    with pytest.raises(InputError, match=r"^faults: fault link_loss takes no target") as caught:
        parse_fault(text)
    assert repr(text) in str(caught.value) and "\n" not in str(caught.value)


def test_a_network_files_link_loss_with_a_target_is_refused_too() -> None:
    with pytest.raises(FaultTargetError, match=r"^fault link_loss takes no target \('22'\)"):
        check_fault_target(FaultSpec(kind="link_loss", at=1.0, target="22"), ROBOT)
    check_fault_target(FaultSpec(kind="link_loss", at=1.0), ROBOT)  # none: fine


def test_the_command_line_exits_2_naming_the_spec(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["run", "trees/straight.yaml", "--sim", "straight", "--param", "distance=0.1m"]
    assert main([*argv, "--faults", "link_loss:22@1s"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "'link_loss:22@1s'" in err and "takes no target" in err


# -- 3. PROTOCOL_MINOR's docstring says what is true ------------------------------------------


def _constant_doc(module: str, name: str) -> str:
    """The docstring written under a module constant (the string right after it)."""
    tree = ast.parse(Path(module).read_text(encoding="utf-8"))
    body = tree.body
    for node, after in itertools.pairwise(body):
        if (
            isinstance(node, ast.Assign)
            and any(isinstance(t, ast.Name) and t.id == name for t in node.targets)
            and isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
        ):
            return " ".join(str(after.value.value).split())
    raise AssertionError(f"{name} has no docstring in {module}")


def test_protocol_minor_says_the_host_asks_for_1_2_and_falls_back_to_1_1() -> None:
    # the facts the docstrings state
    assert (framing.PROTOCOL_MINOR, framing.PROTOCOL_MINOR_MAX) == (1, 2)
    assert SessionConfig().protocol_minor == framing.PROTOCOL_MINOR_MAX
    assert inspect.signature(handshake).parameters["minor"].default == framing.PROTOCOL_MINOR
    doc = _constant_doc(framing.__file__, "PROTOCOL_MINOR")
    assert not doc.startswith("Protocol minor version the host asks for by default")
    assert doc.startswith("Lowest") and "falls back" in doc
    assert "SessionConfig.protocol_minor" in doc
    top = _constant_doc(framing.__file__, "PROTOCOL_MINOR_MAX")
    assert "by default" in top and "SessionConfig(protocol_minor=1)" in top


# -- 5. the e-stop a close sends is retried when its frame is lost ----------------------------


def test_the_close_estop_is_sent_again_when_its_frame_is_lost() -> None:
    estops: list[int] = []

    def bridge(msg: Message) -> list[Message]:
        if isinstance(msg, Heartbeat):
            return [Ack(msg.seq, MsgType.HEARTBEAT, AckStatus.APPLIED)]
        if isinstance(msg, EStop):
            estops.append(msg.seq)
            if len(estops) > 1:  # the first copy is lost on the way
                return [Ack(msg.seq, MsgType.ESTOP, AckStatus.APPLIED)]
        return []  # the stop bulk is never acknowledged

    peer = Peer(bridge)
    link = RobotLink(ROBOT, peer.session())
    link.close()  # the stop bulk fails: an e-stop, lost once, then acknowledged
    assert len(estops) == 2 and estops[0] == estops[1]  # the same frame, sent again
    assert link.session.stats().estopped  # its ACK was taken before the session closed
    assert peer.host.closed


def test_a_close_whose_estop_is_never_answered_ends_without_raising() -> None:
    peer = Peer(lambda msg: [])  # a bridge that hears but never answers
    link = RobotLink(ROBOT, peer.session())
    start = peer.clock.now()
    link.close()
    sent = [m for m in peer.seen if isinstance(m, EStop)]
    assert len(sent) == CONFIG.max_retries + 1 and len({m.seq for m in sent}) == 1
    assert peer.clock.now() - start < 1.0 and peer.host.closed


# -- 4. (part) only a BAD_LAYOUT refusal of HELLO makes the host ask for 1.1 -------------------


def hellos_to_a_refusing_bridge(code: NackCode) -> tuple[list[Hello], HelloRefused]:
    clock = SimClock()
    host, far = memory_pair()
    hellos: list[Hello] = []

    def refuse_every_hello(now: float) -> None:
        for msg in FrameDecoder(CODEC).feed(far.read_available()):
            if isinstance(msg, Hello):
                hellos.append(msg)
                far.write(CODEC.encode(Nack(msg.seq, MsgType.HELLO, code)))

    clock.add_listener(refuse_every_hello)
    with pytest.raises(HelloRefused) as caught:
        wrap_link(host, ROBOT, clock)
    return hellos, caught.value


def test_a_hello_refused_not_ready_is_not_asked_again_for_1_1() -> None:
    # its message names BAD_LAYOUT (as the only code a bridge may refuse HELLO with),
    # which made the host take it for a 1.1 bridge and ask again
    hellos, error = hellos_to_a_refusing_bridge(NackCode.NOT_READY)
    assert [h.minor for h in hellos] == [2]
    assert error.code is NackCode.NOT_READY and "(NOT_READY)" in str(error)


def test_a_hello_refused_bad_layout_is_asked_again_for_1_1() -> None:
    hellos, error = hellos_to_a_refusing_bridge(NackCode.BAD_LAYOUT)
    assert [h.minor for h in hellos] == [2, 1] and error.code is NackCode.BAD_LAYOUT


# -- 2. a COUNTERS reply for another number of boards is refused -----------------------------


def counters_for(n_boards: int, seq: int = 1) -> Counters:
    return Counters(seq, 5, boards=tuple(BoardCounters(20 + i) for i in range(n_boards)))


def test_counters_of_another_board_count_are_a_bad_frame() -> None:
    with pytest.raises(FrameError) as caught:
        CODEC.decode(CODEC.encode(counters_for(2))[:-1])
    assert (caught.value.reason, caught.value.detail) == (
        "length",
        f"counters of 2 boards, the layout has {LAYOUT.n_boards}",
    )
    whole = counters_for(LAYOUT.n_boards)
    assert CODEC.decode(CODEC.encode(whole)[:-1]) == whole


@pytest.mark.parametrize("boards", [0, 2, LAYOUT.n_boards + 1])
def test_a_counters_reply_for_other_boards_is_refused_not_taken(boards: int) -> None:
    peer = Peer(
        lambda msg: [counters_for(boards, msg.seq)] if isinstance(msg, CountersRequest) else []
    )
    session = peer.session()
    ask = session.wait(session.request_counters())  # retried, then given up; never raises
    assert ask.outcome is Outcome.FAILED and ask.reply is None
    assert session.stats().crc_errors == ask.tries == CONFIG.max_retries + 1
    good = Peer(
        lambda msg: (
            [counters_for(LAYOUT.n_boards, msg.seq)] if isinstance(msg, CountersRequest) else []
        )
    ).session()
    ask = good.wait(good.request_counters())
    assert ask.outcome is Outcome.ACKED and ask.reply == counters_for(LAYOUT.n_boards, ask.seq)


# -- 6. STATEs of another layout, in a row, are a protocol mismatch ---------------------------


def state_frame(seq: int, extra: int = 0) -> bytes:
    """A STATE of the robot's layout, or with ``extra`` payload bytes more (or fewer)."""
    good = State(seq, BridgeFlags.NONE, 0, 0, (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels)
    if not extra:
        return CODEC.encode(good)
    raw = cobs_decode(CODEC.encode(good)[:-1])[:-2]  # header + payload, no CRC
    raw = raw + bytes(extra) if extra > 0 else raw[:extra]
    return cobs_encode(raw + crc16(raw).to_bytes(2, "little")) + b"\x00"


def quiet_session() -> tuple[Session, MemoryLink]:
    host, far = memory_pair()
    return Session(host, CODEC, SimClock(8.0), CONFIG, hello_reply=hello_reply()), far


@pytest.mark.parametrize("extra", [2, -2])
def test_states_of_another_layout_in_a_row_are_a_protocol_mismatch(extra: int) -> None:
    session, far = quiet_session()
    far.write(state_frame(1))
    session.poll()
    expected = LAYOUT.state_payload_bytes
    for seq in range(2, 2 + BAD_STATES_BEFORE_MISMATCH - 1):
        far.write(state_frame(seq, extra))
        session.poll()  # one or two could be line noise that passed the CRC: counted
    assert session.stats().crc_errors == BAD_STATES_BEFORE_MISMATCH - 1
    far.write(state_frame(9, extra))
    message = (
        rf"^the bridge sent {BAD_STATES_BEFORE_MISMATCH} STATE frames in a row of another"
        rf" layout: a {expected + extra}-byte payload, the robot description's layout"
        rf" needs {expected} bytes"
    )
    with pytest.raises(ProtocolMismatch, match=message):
        session.poll()
    with pytest.raises(ProtocolMismatch, match=message):
        session.ensure_alive()  # for good: every later call says so too


def test_a_good_state_between_ends_the_run_of_bad_ones() -> None:
    session, far = quiet_session()
    seq = 1
    for _ in range(3):
        for _ in range(BAD_STATES_BEFORE_MISMATCH - 1):
            far.write(state_frame(seq, 2))
            seq += 1
        far.write(state_frame(seq))  # line noise, then a good one: still one layout
        seq += 1
        session.poll()
    session.ensure_alive()
    assert session.stats().crc_errors == 3 * (BAD_STATES_BEFORE_MISMATCH - 1)


def test_a_run_fed_states_of_another_layout_ends_as_a_link_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # the simulated bridge sends each STATE one channel too long from t = 1 s
    read = SimBridge.read

    def longer_states(self: SimBridge, size: int = -1) -> bytes:
        out = read(self, size)
        if self.now_s < 1.0 or not out:
            return out
        frames = []
        for part in out.split(b"\x00")[:-1]:
            raw = cobs_decode(part)
            if raw[1] == MsgType.STATE:
                raw = raw[:-2] + bytes(2)
                raw += crc16(raw).to_bytes(2, "little")
            frames.append(cobs_encode(raw) + b"\x00")
        return b"".join(frames)

    monkeypatch.setattr(SimBridge, "read", longer_states)
    result = pirate_bt.simulate_tree(STRAIGHT, params={"distance": "1 m"}, max_time="10 s")
    assert result.safe_state
    assert isinstance(result.error, ProtocolMismatch), result.why
    assert result.exit_code == 3
    assert "layout needs" in result.why and "STATE frames in a row" in result.why


# -- 4. the hello messages name what differs --------------------------------------------------
# (a new session's HELLO_REPLY of another minor: tests/test_link_session_resets.py)


def test_a_layout_refused_under_both_minors_is_named_as_the_layout() -> None:
    _, error = hellos_to_a_refusing_bridge(NackCode.BAD_LAYOUT)
    assert str(error) == (
        f"the bridge refused the layout digest {LAYOUT.digest:#010x} (BAD_LAYOUT) with"
        " protocol 1.2 and again with 1.1: it was built for another robot description"
    )


# -- 6. a bridge whose watchdog its line cannot keep fed is refused (probe 9) ------------------


@pytest.mark.parametrize(
    ("watchdog_ms", "refused"), [(1, True), (15, True), (16, False), (0, False)]
)
def test_a_bridge_watchdog_too_short_for_its_line_is_refused_at_the_handshake(
    watchdog_ms: int, refused: bool
) -> None:
    # a bridge saying 1 ms had the host heartbeat every 0.1 ms, more than 115200 baud
    # carries (a heartbeat takes 0.78 ms): it tripped all the same; 0 is "not said"
    clock = SimClock()
    host, far = memory_pair()

    def reply(now: float) -> None:
        for msg in FrameDecoder(CODEC).feed(far.read_available()):
            if isinstance(msg, Hello):
                answer = hello_reply(seq=msg.seq, watchdog_ms=watchdog_ms, minor=msg.minor)
                far.write(CODEC.encode(answer))

    clock.add_listener(reply)
    if not refused:
        wrap_link(host, ROBOT, clock, release_boot_latch=False).session.close()
        return
    with pytest.raises(ProtocolMismatch, match=rf"the bridge's watchdog is {watchdog_ms} ms,"):
        wrap_link(host, ROBOT, clock)
    assert host.closed
