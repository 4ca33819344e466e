"""Probe 15 of the wire protocol: a clean-room host and bridge written from
docs/protocol.md alone, run against the simulated bridge and the pirate_bt host.

Each test pins one finding with its fix (docs/protocol.md, Layout).
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import pytest
import yaml
from session_wire import CODEC, Peer, reply, state

from pirate_bt.errors import ConfigurationError, ValidationFailed
from pirate_bt.link.closing import RequestsFailed
from pirate_bt.link.codec import (
    Ack,
    AckStatus,
    BridgeFlags,
    BulkSetpoints,
    EStop,
    EStopReset,
    FrameCodec,
    Heartbeat,
    Hello,
    Message,
    State,
)
from pirate_bt.link.layout import LayoutUncovered, WireLayout, layout_text, validate_robot_file
from pirate_bt.link.opening import wrap_link
from pirate_bt.resources import default_robot_path
from pirate_bt.robot import ControlMode, load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.loader import robot_from_data

ROBOT = load_robot()
DEFAULT: dict[str, Any] = yaml.safe_load(default_robot_path().read_text())


def _with_empty_board(board_id: int) -> dict[str, Any]:
    """The default robot plus a board that carries no motor and no sensor."""
    data = copy.deepcopy(DEFAULT)
    data["boards"].insert(0, {"id": board_id, "module": "front"})
    return data


def test_a_board_with_no_motor_and_no_sensor_is_refused_by_the_link() -> None:
    # The digest names boards only through their channels and motors: an empty board
    # 19 leaves it (and the channel and motor text) as the default robot's, yet takes
    # the first status nibble of STATE, so a host without it read board 20's status
    # from board 19's nibble (a bridge's FAULT on 19 came out as board 20 faulted).
    robot = robot_from_data(_with_empty_board(19))
    default = robot_from_data(DEFAULT)
    assert layout_text(robot) == layout_text(default)
    assert robot.layout_digest() == default.layout_digest()
    with pytest.raises(LayoutUncovered, match=r"board\(s\) 19 have no motor and no sensor"):
        WireLayout.from_robot(robot)
    with pytest.raises(ConfigurationError):  # exit 2, as a frame that does not fit
        FrameCodec.for_robot(robot)


def test_validate_reports_the_empty_board_at_boards(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(_with_empty_board(29)))
    with pytest.raises(ValidationFailed, match=r"board\(s\) 29 have no motor and no sensor"):
        validate_robot_file(path)


def test_the_firmware_header_of_a_robot_with_an_empty_board_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `pirate-bt robot header` (what `make firmware` builds the bridge with) wrote the
    # header of such a robot: a firmware the host's digest could not tell apart
    from pirate_bt.cli import main
    from pirate_bt.robot.header import render_header

    with pytest.raises(ConfigurationError, match=r"board\(s\) 19 have no motor and no sensor"):
        render_header(robot_from_data(_with_empty_board(19)))
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(_with_empty_board(19)))
    out = tmp_path / "layout.h"
    code = main(["robot", "header", str(path), "-o", str(out)])
    assert code == 2 and not out.exists()
    assert capsys.readouterr().err.count("\n") == 1


def test_an_earlier_failure_does_not_keep_the_closing_stop_from_going_out() -> None:
    # A bridge answered the host's last bulk STALE (an ESTOP's trace, or a frame that
    # passed the CRC with a newer seq) and the caller sent nothing after it. The close's
    # stop raised for that earlier failure before it was sent, and the close latched the
    # bridge's e-stop instead ("could not stop the drives on close: 1 earlier request(s)
    # failed; ... e-stop sent"), so the next connection found a latch "from an earlier
    # session" to be reset by an operator. protocol.md: the close stops the drives and
    # sends an ESTOP only when that stop is refused or never acknowledged.
    bulks: list[BulkSetpoints] = []
    tx = iter(range(1, 10_000))

    def answer(msg: Message) -> list[Message]:
        if isinstance(msg, Hello):
            return [reply(msg.seq, flags=BridgeFlags.ESTOP, sessions=1)]
        if isinstance(msg, EStopReset | Heartbeat | EStop):
            return [Ack(msg.seq, msg.TYPE, AckStatus.APPLIED)]
        if isinstance(msg, BulkSetpoints):
            bulks.append(msg)
            if len(bulks) == 1:
                return [Ack(msg.seq, msg.TYPE, AckStatus.STALE)]
            return [state(next(tx), ack_seq=msg.seq)]
        return []

    peer = Peer(answer)
    link = wrap_link(peer.host, ROBOT, peer.clock)
    link.send([MotorCommand("bend_1_drive", ControlMode.VELOCITY, 0.05)])
    with pytest.raises(RequestsFailed, match="STALE"):  # said by a poll since 2026-12-01
        for _ in range(4):
            peer.clock.advance(0.005)
            link.poll()
    link.close()
    assert not any(isinstance(m, EStop) for m in peer.seen)
    assert len(bulks) == 2 and link.close_error is None
    drives = {s.motor.name for s in ROBOT.setpoint_slots() if s.motor.function == "drive"}
    stop = dict(
        zip((s.motor.name for s in ROBOT.setpoint_slots()), bulks[1].raw_values, strict=True)
    )
    assert all(stop[name] == 0 for name in drives)


def test_a_reading_fresh_only_between_two_state_reads_is_not_lost() -> None:
    # A bridge whose poll cycle spans several state periods marks a channel fresh in
    # one STATE and not in the next ones ("the last value read", protocol.md, STATE).
    # RobotLink.state() built its snapshot from the newest STATE only: a reading fresh
    # in a STATE taken between two calls (a tick every 50 ms, STATEs every 10 ms) was
    # dropped, so bend_1_angle, fresh every 50 ms out of phase with the tick, never
    # showed at all, and would have gone stale with every reading delivered.
    names = [c.name for c in ROBOT.state_channels()]
    angle = names.index("bend_1_angle")
    seqs = iter(range(1, 10_000))
    peer = Peer(
        lambda msg: (
            [reply(msg.seq, flags=BridgeFlags.ESTOP, sessions=1)]
            if isinstance(msg, Hello)
            else [Ack(msg.seq, msg.TYPE, AckStatus.APPLIED)]
            if isinstance(msg, EStopReset | Heartbeat | EStop)
            else []
        )
    )
    link = wrap_link(peer.host, ROBOT, peer.clock)
    raw = [0] * len(names)
    raw[angle] = 2048 + 1024  # +90 degrees
    every = (1 << len(names)) - 1
    arrived: dict[int, float] = {}
    for _ in range(30):
        seq = next(seqs)
        mask = every if seq % 5 == 0 else every & ~(1 << angle)
        frame = State(seq, BridgeFlags.NONE, 0, mask, (1,) * len(ROBOT.board_ids()), tuple(raw))
        peer.far.write(CODEC.encode(frame))
        peer.clock.advance(0.010)
        link.poll()
        arrived[seq] = peer.clock.now()
        if seq % 5 == 2:  # the caller's tick, out of phase with the fresh readings
            snap = link.state()
            assert snap is not None
            if seq > 5:
                reading = snap.readings.get("bend_1_angle")
                assert reading is not None, f"no bend_1_angle at seq {seq}"
                assert reading.value == pytest.approx(math.pi / 2)
                # the reading of the fresh STATE before this tick, with its own stamp
                assert reading.stamp_s == arrived[seq - 2]
    link.close()
