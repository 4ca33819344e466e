"""The link under faults, probed from the user docs (docs/protocol.md, docs/safety.md).

Each test pins a bug a user saw, fixed here: a malformed ``--port`` URL, bytes no
frame should contain, forged frames with a good CRC.
"""

from __future__ import annotations

import binascii
import logging
import struct
from pathlib import Path

import pytest
from session_wire import LAYOUT, ROBOT, Peer, Wire, reply

from pirate_bt.cli import main
from pirate_bt.clock import SimClock
from pirate_bt.errors import InputError, LinkError, ProtocolMismatch
from pirate_bt.link import open_link, vectors
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    EStop,
    Heartbeat,
    Message,
    MsgType,
    State,
)
from pirate_bt.link.faults import split_fault_url
from pirate_bt.link.framing import cobs_encode
from pirate_bt.link.inbound import BAD_STATES_BEFORE_MISMATCH
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.link.transport import Transport

REPO = Path(__file__).resolve().parent.parent
STRAIGHT = str(REPO / "trees" / "straight.yaml")
ZERO = [c.conversion.zero_raw for c in ROBOT.state_channels()]


@pytest.mark.parametrize(
    ("url", "said"),
    [
        ("socket://host:notaport", "the port 'notaport' is not from 0 to 65535"),
        ("socket://:99999", "the port '99999' is not from 0 to 65535"),
        ("socket://", "no host; give socket://HOST:PORT"),
        ("socket://[::1", "no host and port in '[::1' (Invalid IPv6 URL)"),
        ("socket://127.0.0.1:5760?x=1", "no option 'x' (a socket:// URL takes logging)"),
        ("rfc2217://127.0.0.1:5760?timeout=abc", "timeout='abc' is not a number of seconds"),
    ],
)
def test_a_malformed_port_url_is_bad_input_exit_2(
    url: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`pirate-bt run --port socket://host:notaport` exited 3 (link error) for what is
    a bad argument (exit 2, DESIGN.md's command-line contract); `socket://` said
    *'<=' not supported between instances of 'int' and 'NoneType'*, `socket://[::1`
    was an *internal error: ValueError: Invalid IPv6 URL* (exit 1) and `?x=1` said
    *'debug|info|warning|error'*."""
    code = main(["run", STRAIGHT, "--param", "distance=0.1m", "--quiet", "--port", url])
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.startswith("pirate-bt:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert code == 2, err
    assert lines[0].startswith(f"pirate-bt: --port: cannot open {url}: {said}"), lines[0]


@pytest.mark.parametrize(
    ("url", "said"),
    [
        ("loop://?x=1", "no option 'x' (a loop:// URL takes logging)"),
        ("loop://?logging=verbose", "logging='verbose' is none of debug, info, warning, error"),
    ],
)
def test_a_loop_url_with_a_bad_option_is_bad_input_not_an_internal_error(
    url: str, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--port 'loop://?x=1'` was *internal error: KeyError: 'debug|info|warning|error'*
    (exit 1): pyserial's loop:// formats its own message wrongly."""
    code = main(["run", STRAIGHT, "--param", "distance=0.1m", "--quiet", "--port", url])
    err = capsys.readouterr().err
    assert code == 2 and "internal error" not in err, err
    assert err.strip() == f"pirate-bt: --port: cannot open {url}: {said}"


def test_a_malformed_port_url_is_still_a_link_error_to_python() -> None:
    """A caller that catches the failure to connect as a ``LinkError`` still does."""
    with pytest.raises(LinkError) as caught:
        Transport.open("socket://", baud=115200)
    assert isinstance(caught.value, InputError)
    assert caught.value.exit_code == 2


# -- a STATE with a reading no board reads ------------------------------------------------


def _state(seq: int, values: list[int]) -> State:
    return State(
        seq,
        BridgeFlags.NONE,
        0,
        (1 << LAYOUT.n_channels) - 1,
        (1,) * LAYOUT.n_boards,
        tuple(values),
    )


def test_a_reading_outside_its_raw_range_is_refused_not_taken(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A `STATE` (a damaged frame that passed the CRC, or a forged one) saying 32767 for
    the camera tilt's angle sensor, whose raw range is 0..4095, was converted and taken
    as fresh: 47 rad for a joint that turns through one. The reading is now refused (the
    last one taken stays, with its old stamp), counted and logged once; the frame's
    other readings are taken, and the channel's next reading in range is taken again."""
    wire = Wire(hello=reply())
    link = RobotLink(ROBOT, wire.session)
    channels = ROBOT.state_channels()
    good = [c.conversion.zero_raw for c in channels]
    i = next(k for k, c in enumerate(channels) if c.name == "camera_tilt_angle")
    j = next(k for k, c in enumerate(channels) if c.conversion.raw[1] > good[k] + 10 and k != i)
    name, other = channels[i].name, channels[j].name
    assert channels[i].conversion.raw == (0, 4095)
    wire.answer(_state(1, good))
    wire.poll(0.01)
    first = link.state()
    assert first is not None and first.readings[name].value == 0.0
    bad = list(good)
    bad[i], bad[j] = 32767, good[j] + 10
    with caplog.at_level(logging.WARNING):
        for seq in (2, 3):
            wire.answer(_state(seq, bad))
            wire.poll(0.01)
            now = link.state()
            assert now is not None
    assert now.readings[name] == first.readings[name]  # the old reading, its old stamp
    assert now.readings[other].stamp_s > first.readings[other].stamp_s  # the rest taken
    assert now.readings[other].value != first.readings[other].value
    assert link.readings_refused == 2
    said = [r.getMessage() for r in caplog.records if "outside its raw range" in r.getMessage()]
    assert said == [
        f"STATE seq 2: {name} reads 32767, outside its raw range 0..4095: not taken (a"
        " damaged or forged frame that passed the CRC, or a board that does not match the"
        " robot description)"
    ]
    wire.answer(_state(4, good))
    wire.poll(0.01)
    again = link.state()
    assert again is not None and again.readings[name].stamp_s > first.readings[name].stamp_s


# -- the close's e-stop, acknowledged ---------------------------------------------------------


def test_a_close_whose_estop_is_acknowledged_says_the_drives_stopped(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A close whose drive stop was never acknowledged logged *could not stop the drives
    on close: ...; e-stop sent* (an ERROR) and nothing more when the bridge took that
    e-stop: the log left the user thinking the robot might still be moving. It now says
    the e-stop was acknowledged (and ``close_error`` stays unset)."""

    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, EStop):
            return [Ack(msg.seq, MsgType.ESTOP, AckStatus.APPLIED)]
        if isinstance(msg, Heartbeat):
            return [Ack(msg.seq, MsgType.HEARTBEAT, AckStatus.APPLIED), _state(msg.seq, ZERO)]
        return []  # the bulk: never acknowledged

    peer = Peer(answer)
    link = RobotLink(ROBOT, peer.session())
    with caplog.at_level(logging.INFO):
        link.close()
    said = [r.getMessage() for r in caplog.records if r.name == "pirate_bt.link.robot_link"]
    assert any(m.startswith("could not stop the drives on close:") for m in said), said
    assert said[-1] == "the e-stop sent on close was acknowledged: the drives stopped", said
    assert link.close_error is None
    assert any(isinstance(m, EStop) for m in peer.seen)


# -- python -m pirate_bt.link.vectors FILE ----------------------------------------------------


def test_the_vectors_writer_refuses_what_is_not_one_file_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`python -m pirate_bt.link.vectors --help` (docs/protocol.md, Test vectors) wrote
    the vectors to a file named `--help`, extra arguments were ignored, and a file that
    cannot be written (a folder) was a traceback."""
    monkeypatch.chdir(tmp_path)
    assert vectors.main(["--help"]) == 0
    assert capsys.readouterr().out.startswith("usage: python -m pirate_bt.link.vectors [FILE]")
    assert vectors.main(["a.json", "b.json"]) == 2
    assert vectors.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0].endswith(": not 'a.json b.json'"), err
    assert err[1] == f"{tmp_path}: cannot write: Is a directory", err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    assert vectors.main(["v.json"]) == 0
    assert (tmp_path / "v.json").read_text() == vectors.dumps(ROBOT)


@pytest.mark.parametrize("twice", ["faults=dup=0.2", "fault_seed=3&fault_seed=4"])
def test_a_fault_option_given_twice_in_the_port_url_is_refused(
    twice: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """`--port 'loop://?faults=drop=0.1&faults=dup=0.2'` rehearsed with dup=0.2 only:
    the last `faults=` silently replaced the first (and the last `fault_seed=` the
    first), so a run asked to lose frames lost none."""
    url = f"loop://?faults=drop=0.1&{twice}"
    key = twice.partition("=")[0]
    with pytest.raises(InputError, match=rf"^faults: {key}= is given twice in the port URL"):
        split_fault_url(url)
    code = main(["run", STRAIGHT, "--param", "distance=0.1m", "--quiet", "--port", url])
    assert code == 2
    assert capsys.readouterr().err.startswith(f"pirate-bt: faults: {key}= is given twice")


# -- the close after a protocol mismatch -----------------------------------------------------


def _mismatch(peer: Peer) -> None:
    """Three STATE frames of another length (a good CRC): the session's protocol mismatch."""
    body = bytes([1, int(MsgType.STATE), 9, 0, 0]) + bytes(LAYOUT.state_payload_bytes + 2)
    frame = cobs_encode(body + struct.pack("<H", binascii.crc_hqx(body, 0))) + b"\x00"
    peer.far.write(frame * BAD_STATES_BEFORE_MISMATCH)


@pytest.mark.parametrize("answers", [True, False])
def test_the_close_after_a_protocol_mismatch_waits_for_its_estop(
    answers: bool, caplog: pytest.LogCaptureFixture
) -> None:
    """After a protocol mismatch (three STATE frames of another layout) the close's
    e-stop went out but every wait raised the mismatch at once: its ACK, which reads
    the same whatever the layout, was never read, and the close said *the e-stop sent
    after it failed (<the mismatch>): the robot may still be moving*, the mismatch told
    twice, for a bridge that had taken it. The close now reads the line on for the
    e-stop's answer; unanswered, it names the mismatch once."""

    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, EStop) and answers:
            return [Ack(msg.seq, MsgType.ESTOP, AckStatus.APPLIED)]
        return []

    peer = Peer(answer)
    link = RobotLink(ROBOT, peer.session())
    _mismatch(peer)
    with pytest.raises(ProtocolMismatch):
        link.poll()
    with caplog.at_level(logging.INFO):
        link.close()
    assert any(isinstance(m, EStop) for m in peer.seen)
    if answers:
        assert link.close_error is None
        said = [r.getMessage() for r in caplog.records]
        assert "the e-stop sent on close was acknowledged: the drives stopped" in said
    else:
        why = str(link.close_error)
        assert why.count("STATE frames in a row of another layout") == 1, why
        assert "and the e-stop sent after it was not answered either: the robot may" in why


@pytest.mark.parametrize("url", ["sim://[::1", "sim://", "chain://[x"])
def test_an_in_process_url_without_a_name_says_so(url: str) -> None:
    """`open_link("sim://[::1", ...)` said *Invalid IPv6 URL* (urlsplit's words, about
    an address a simulator's URL never has) and `sim://` *no simulator named ''*."""
    import pirate_bt.sim  # noqa: F401  (registers sim:// and chain://)

    with pytest.raises(LinkError) as caught:
        open_link(url, ROBOT, SimClock())
    scheme = url.partition("://")[0]
    assert str(caught.value) == f"cannot open {url}: expected a {scheme}://NAME URL, got {url!r}"
