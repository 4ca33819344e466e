"""Request/response sequences of the protocol vectors, written from ``docs/protocol.md``.

Each sequence starts from a freshly booted bridge for the default robot; see
:mod:`pirate_bt.link.vectors` for the step format. The expected answers are the
spec's, spelled out by hand here: only the hex is computed.
"""

from __future__ import annotations

from typing import Any

from pirate_bt.link.codec import FrameCodec
from pirate_bt.link.framing import PROTOCOL_MINOR, PROTOCOL_MINOR_MAX, cobs_encode, crc16
from pirate_bt.link.message_json import message_to_json
from pirate_bt.link.messages import (
    MODE_CODES,
    Ack,
    AckStatus,
    BoardStatus,
    BridgeFlags,
    BulkSetpoints,
    CountersRequest,
    EStop,
    EStopReset,
    Heartbeat,
    Hello,
    Message,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
)
from pirate_bt.robot.description import ControlMode, RobotDescription

__all__ = ["bulk_payload", "drive_bulk", "frame_hex", "good_bulk", "sequences"]


def frame_hex(kind: int, seq: int, arg: int = 0, payload: bytes = b"", version: int = 1) -> str:
    """The wire hex (delimiter included) of any header and payload, valid CRC."""
    body = bytes((version, kind)) + seq.to_bytes(2, "little") + bytes((arg,)) + payload
    body += crc16(body).to_bytes(2, "little")
    return (cobs_encode(body) + b"\x00").hex()


def good_bulk(robot: RobotDescription, seq: int) -> BulkSetpoints:
    """A bulk setpoint every motor of ``robot`` accepts: each motor's first mode, in range."""
    modes: list[ControlMode | None] = []
    values: list[int] = []
    for i, slot in enumerate(robot.setpoint_slots()):
        motor = slot.motor
        if i % 4 == 3:
            modes.append(None)
            values.append(0)
            continue
        mode = next(m for m in ControlMode if motor.modes.get(m) is not None)
        conversion = motor.modes.get(mode)
        assert conversion is not None
        lo, hi = conversion.raw
        modes.append(mode)
        values.append(max(lo, min(hi, i - 3)))
    return BulkSetpoints(seq, tuple(modes), tuple(values))


def drive_bulk(robot: RobotDescription, seq: int, raw_velocity: int) -> BulkSetpoints:
    """Every drive at ``raw_velocity`` (velocity mode), every other motor kept."""
    modes = tuple(
        ControlMode.VELOCITY if s.motor.function == "drive" else None
        for s in robot.setpoint_slots()
    )
    values = tuple(raw_velocity if m is not None else 0 for m in modes)
    return BulkSetpoints(seq, modes, values)


def bulk_payload(robot: RobotDescription, entries: dict[int, tuple[int, int]]) -> bytes:
    """A bulk payload: every motor kept but the given ``index: (mode_code, raw)`` entries."""
    out = bytearray()
    for slot in robot.setpoint_slots():
        code, raw = entries.get(slot.index, (0xFF, 0))
        out += bytes((code,)) + raw.to_bytes(2, "little", signed=True)
    return bytes(out)


def sequences(codec: FrameCodec, robot: RobotDescription) -> list[dict[str, Any]]:
    """The request/response sequences for ``robot``'s bridge.

    Args:
        codec: The codec of ``robot``'s layout.
        robot: The robot description.

    Returns:
        One dict per sequence: ``name``, ``description``, ``steps``.
    """
    lay = codec.layout
    digest = lay.digest
    j = message_to_json
    slots = robot.setpoint_slots()
    bend = next(s for s in slots if s.motor.function == "bend")
    drive = next(s for s in slots if s.motor.function == "drive")
    e = int(BridgeFlags.ESTOP)
    ei = int(BridgeFlags.ESTOP_INPUT)
    w = int(BridgeFlags.WATCHDOG)
    ns = int(BridgeFlags.NO_SESSION)
    off = int(BoardStatus.MOTORS_OFF)
    wd = robot.bridge.watchdog

    def reply(seq: int, sessions: int, flags: int, minor: int = PROTOCOL_MINOR) -> dict[str, Any]:
        return {
            "type": "HELLO_REPLY",
            "seq": seq,
            "layout_digest": digest,
            "n_channels": lay.n_channels,
            "n_motors": lay.n_motors,
            "watchdog_ms": round(wd * 1000),
            "minor": minor,
            "sessions": sessions,
            "flags": flags,
        }

    def ack(seq: int, kind: MsgType, status: AckStatus = AckStatus.APPLIED) -> dict[str, Any]:
        return j(Ack(seq, kind, status))

    def nack(seq: int, kind: int, code: NackCode) -> dict[str, Any]:
        return j(Nack(seq, kind, code))

    def sp(seq: int, value: int, mode: ControlMode = ControlMode.POSITION) -> Setpoint:
        return Setpoint(seq, bend.board, bend.slot, mode, value)

    def step(msg: Message, *answers: dict[str, Any]) -> dict[str, Any]:
        return {"send": j(msg), "expect": list(answers)}

    def raw(hex_: str, *answers: dict[str, Any]) -> dict[str, Any]:
        return {"send_hex": hex_, "expect": list(answers)}

    def wait(seconds: float, **state: int) -> dict[str, Any]:
        out: dict[str, Any] = {"advance_s": seconds, "expect": []}
        if state:
            out["state"] = state
        return out

    def button(pressed: bool, seconds: float, **state: int) -> dict[str, Any]:
        """The hardware e-stop input pressed or released, then ``seconds`` pass."""
        return {"estop_input": pressed, **wait(seconds, **state)}

    start = [
        step(Hello(1, digest), reply(1, 1, e)),
        step(EStopReset(2), ack(2, MsgType.ESTOP_RESET)),
    ]
    sp_t, bulk_t, reset_t = MsgType.SETPOINT, MsgType.BULK_SETPOINTS, MsgType.ESTOP_RESET
    dup, stale = AckStatus.DUPLICATE, AckStatus.STALE
    keep_drive_torque = bulk_payload(robot, {drive.index: (MODE_CODES[ControlMode.TORQUE], 0)})
    drive_too_fast = bulk_payload(robot, {drive.index: (MODE_CODES[ControlMode.VELOCITY], 30000)})
    return [
        {
            "name": "handshake",
            "description": "boots latched with NO_SESSION; HELLO starts a session; the boot "
            "latch is released by ESTOP_RESET; setpoints apply",
            "steps": [
                wait(0.05, flags=e | ns, ack_seq=0),
                step(Hello(1, digest), reply(1, 1, e)),
                wait(0.03, flags=e),
                step(EStopReset(2), ack(2, reset_t)),
                step(sp(3, 100), ack(3, sp_t)),
                wait(0.03, flags=0, ack_seq=0),
            ],
        },
        {
            "name": "not_ready_before_hello",
            "description": "ordered requests before any session: NOT_READY; ESTOP, HEARTBEAT "
            "and COUNTERS_REQUEST are handled",
            "steps": [
                step(sp(5, 100), nack(5, sp_t, NackCode.NOT_READY)),
                step(good_bulk(robot, 6), nack(6, bulk_t, NackCode.NOT_READY)),
                step(EStopReset(7), nack(7, reset_t, NackCode.NOT_READY)),
                step(Heartbeat(9), ack(9, MsgType.HEARTBEAT)),
                step(CountersRequest(10), {"type": "COUNTERS", "seq": 10}),
                step(EStop(8), ack(8, MsgType.ESTOP)),
                step(Hello(11, digest), reply(11, 1, e)),
            ],
        },
        {
            "name": "duplicates",
            "description": "a duplicate gets the first copy's answer again, an older seq (or "
            "the same seq with another type) STALE; a duplicate or stale bulk gets an ACK frame",
            "steps": [
                *start,
                step(sp(3, 100), ack(3, sp_t)),
                step(sp(3, 100), ack(3, sp_t, dup)),
                step(sp(2, 100), ack(2, sp_t, stale)),
                step(good_bulk(robot, 4)),
                wait(0.03, ack_seq=4),
                step(good_bulk(robot, 4), ack(4, bulk_t, dup)),
                step(good_bulk(robot, 3), ack(3, bulk_t, stale)),
                step(sp(5, 30000), nack(5, sp_t, NackCode.OUT_OF_RANGE)),
                step(sp(5, 30000), nack(5, sp_t, NackCode.OUT_OF_RANGE)),
                step(sp(4, 100), ack(4, sp_t, stale)),
                step(sp(6, 100), ack(6, sp_t)),
                step(EStopReset(6), ack(6, reset_t, stale)),
                wait(0.03, ack_seq=4),
            ],
        },
        {
            "name": "wrap",
            "description": "the ordered counter wraps 65535 -> 1; heartbeats on the untracked "
            "counter, at any seq, never touch the filter",
            "steps": [
                step(Hello(65533, digest), reply(65533, 1, e)),
                step(EStopReset(65534), ack(65534, reset_t)),
                step(sp(65535, 100), ack(65535, sp_t)),
                step(Heartbeat(30000), ack(30000, MsgType.HEARTBEAT)),
                step(Heartbeat(65535), ack(65535, MsgType.HEARTBEAT)),
                step(sp(1, 110), ack(1, sp_t)),
                step(good_bulk(robot, 2)),
                step(Heartbeat(1), ack(1, MsgType.HEARTBEAT)),
                step(sp(3, 120), ack(3, sp_t)),
                step(sp(65535, 100), ack(65535, sp_t, stale)),
                wait(0.03, flags=0, ack_seq=2),
            ],
        },
        {
            "name": "estop_and_reset",
            "description": "ESTOP latches whatever its seq; an older reset arriving after a "
            "newer ESTOP is stale; setpoints refused while latched; a reset leaves the motors "
            "stopped (MOTORS_OFF) until new setpoints",
            "steps": [
                *start,
                step(sp(3, 100), ack(3, sp_t)),
                step(EStop(5), ack(5, MsgType.ESTOP)),
                step(EStopReset(4), ack(4, reset_t, stale)),
                wait(0.03, flags=e, board_status_set=off),
                step(sp(6, 100), nack(6, sp_t, NackCode.ESTOP_LATCHED)),
                step(drive_bulk(robot, 7, 100), nack(7, bulk_t, NackCode.ESTOP_LATCHED)),
                step(EStop(3), ack(3, MsgType.ESTOP)),
                step(EStopReset(8), ack(8, reset_t)),
                wait(0.03, flags=0, board_status_set=off),
                step(EStopReset(9), ack(9, reset_t)),
                step(sp(10, 100), ack(10, sp_t)),
                step(EStop(11), ack(11, MsgType.ESTOP)),
                step(sp(11, 100), ack(11, sp_t, stale)),
            ],
        },
        {
            "name": "watchdog_trip_and_recovery",
            "description": "armed from boot; a silent host trips it (stop category, MOTORS_OFF); "
            "the next valid frame releases it; setpoints are accepted at once",
            "steps": [
                wait(wd + 0.1, flags=e | w | ns),
                *start,
                wait(0.03, flags=0),
                step(drive_bulk(robot, 3, 200)),
                wait(0.03, flags=0, ack_seq=3),
                wait(wd + 0.1, flags=w, board_status_set=off),
                step(Heartbeat(40), ack(40, MsgType.HEARTBEAT)),
                wait(0.03, flags=0),
                step(drive_bulk(robot, 4, 100)),
                wait(0.03, flags=0, ack_seq=4),
            ],
        },
        {
            "name": "mid_session_hello",
            "description": "a new HELLO resets the filter and ack_seq, keeps the latch as it is "
            "and counts a session; a retried HELLO does not count again",
            "steps": [
                *start,
                step(good_bulk(robot, 3)),
                wait(0.03, ack_seq=3),
                step(Hello(20, digest), reply(20, 2, 0)),
                step(Hello(20, digest), reply(20, 2, 0)),
                wait(0.03, flags=0, ack_seq=0),
                step(good_bulk(robot, 4), ack(4, bulk_t, stale)),
                step(good_bulk(robot, 21)),
                wait(0.03, ack_seq=21),
                step(EStop(22), ack(22, MsgType.ESTOP)),
                step(Hello(23, digest), reply(23, 3, e)),
            ],
        },
        {
            "name": "new_host_same_hello_seq",
            "description": "a second host starts with the same HELLO seq after the first one "
            "e-stopped: a new session (sessions 2), the latch kept, so the second host does "
            "not take it for a boot latch",
            "steps": [
                *start,
                step(EStop(3), ack(3, MsgType.ESTOP)),
                step(Hello(1, digest), reply(1, 2, e)),
                step(Hello(1, digest), reply(1, 2, e)),
                step(sp(2, 100), nack(2, sp_t, NackCode.ESTOP_LATCHED)),
            ],
        },
        {
            "name": "bridge_reset",
            "description": "a DTR reset loses the session: NO_SESSION and the latch are back, "
            "ack_seq 0, ordered requests NOT_READY until a HELLO",
            "steps": [
                *start,
                step(good_bulk(robot, 3)),
                {**wait(0.05, flags=e | ns, ack_seq=0), "reset": True},
                step(sp(4, 100), nack(4, sp_t, NackCode.NOT_READY)),
                step(Hello(5, digest), reply(5, 1, e)),
                step(sp(6, 100), nack(6, sp_t, NackCode.ESTOP_LATCHED)),
            ],
        },
        {
            "name": "minor_versions",
            "description": "protocol 1.2: a bridge that speaks 1.2 also speaks 1.1; each "
            "session speaks the minor its HELLO asked for, and says so in HELLO_REPLY",
            "steps": [
                step(Hello(1, digest, 2), reply(1, 1, e, minor=2)),
                wait(0.03, flags=e),
                step(Hello(2, digest, 1), reply(2, 2, e, minor=1)),
                step(EStopReset(3), ack(3, reset_t)),
                step(Hello(4, digest, 2), reply(4, 3, 0, minor=2)),
                wait(0.03, flags=0),
            ],
        },
        {
            "name": "estop_input",
            "description": "protocol 1.2, a bridge with a hardware e-stop input: pressing it "
            "latches the e-stop (stop category, MOTORS_OFF) and sets ESTOP_INPUT; ESTOP_RESET "
            "is NOT_READY while it is pressed; released, the latch stays until a reset, which "
            "clears both flags",
            "needs": "estop_input",
            "steps": [
                step(Hello(1, digest, 2), reply(1, 1, e, minor=2)),
                step(EStopReset(2), ack(2, reset_t)),
                step(sp(3, 100), ack(3, sp_t)),
                button(True, 0.03, flags=e | ei, board_status_set=off),
                step(sp(4, 100), nack(4, sp_t, NackCode.ESTOP_LATCHED)),
                step(EStopReset(5), nack(5, reset_t, NackCode.NOT_READY)),
                button(False, 0.1, flags=e | ei, board_status_set=off),
                step(EStopReset(6), ack(6, reset_t)),
                wait(0.03, flags=0, board_status_set=off),
                step(sp(7, 100), ack(7, sp_t)),
            ],
        },
        {
            "name": "estop_input_in_a_1_1_session",
            "description": "the hardware e-stop input in a 1.1 session: the same latch and the "
            "same refused reset, but no ESTOP_INPUT flag (bits 4-7 stay 0 in 1.1)",
            "needs": "estop_input",
            "steps": [
                *start,
                button(True, 0.03, flags=e, board_status_set=off),
                step(EStopReset(3), nack(3, reset_t, NackCode.NOT_READY)),
                button(False, 0.1, flags=e),
                step(EStopReset(4), ack(4, reset_t)),
                wait(0.03, flags=0),
            ],
        },
        {
            "name": "nacks",
            "description": "every NACK a bridge sends for bytes alone (BUS_ERROR needs a board "
            "that stops answering), in the order of the checks",
            "steps": [
                raw(
                    frame_hex(sp_t, 1, bend.board, b"\x00"),
                    nack(1, sp_t, NackCode.BAD_LENGTH),
                ),
                step(Hello(2, digest ^ 1), nack(2, MsgType.HELLO, NackCode.BAD_LAYOUT)),
                step(
                    Hello(3, digest, PROTOCOL_MINOR_MAX + 1),
                    nack(3, MsgType.HELLO, NackCode.BAD_LAYOUT),
                ),
                raw(
                    frame_hex(MsgType.HELLO, 4, 0, digest.to_bytes(4, "little")),
                    nack(4, MsgType.HELLO, NackCode.BAD_LENGTH),
                ),
                step(sp(5, 100), nack(5, sp_t, NackCode.NOT_READY)),
                step(Hello(6, digest), reply(6, 1, e)),
                step(EStopReset(7), ack(7, reset_t)),
                raw(frame_hex(0x42, 9), nack(9, 0x42, NackCode.UNKNOWN_TYPE)),
                step(Ack(10, MsgType.HEARTBEAT), nack(10, MsgType.ACK, NackCode.UNKNOWN_TYPE)),
                raw(
                    frame_hex(MsgType.HEARTBEAT, 11, 0, b"\x00"),
                    nack(11, MsgType.HEARTBEAT, NackCode.BAD_LENGTH),
                ),
                raw(
                    frame_hex(bulk_t, 12, 0, b"\x00" * 3),
                    nack(12, bulk_t, NackCode.BAD_LENGTH),
                ),
                step(Setpoint(13, 99, 0, ControlMode.PWM, 0), nack(13, sp_t, NackCode.BAD_BOARD)),
                step(
                    Setpoint(14, bend.board, 7, ControlMode.PWM, 0),
                    nack(14, sp_t, NackCode.BAD_SLOT),
                ),
                step(sp(15, 0, ControlMode.VELOCITY), nack(15, sp_t, NackCode.BAD_MODE)),
                raw(
                    frame_hex(sp_t, 16, bend.board, bytes((bend.slot, 9, 0, 0))),
                    nack(16, sp_t, NackCode.BAD_MODE),
                ),
                raw(
                    frame_hex(sp_t, 17, bend.board, bytes((bend.slot, 0xFF, 0, 0))),
                    nack(17, sp_t, NackCode.BAD_MODE),
                ),
                step(sp(18, 30000), nack(18, sp_t, NackCode.OUT_OF_RANGE)),
                raw(
                    frame_hex(bulk_t, 19, 0, keep_drive_torque), nack(19, bulk_t, NackCode.BAD_MODE)
                ),
                raw(
                    frame_hex(bulk_t, 20, 0, drive_too_fast),
                    nack(20, bulk_t, NackCode.OUT_OF_RANGE),
                ),
                step(EStop(21), ack(21, MsgType.ESTOP)),
                step(sp(22, 30000), nack(22, sp_t, NackCode.OUT_OF_RANGE)),
                step(sp(23, 100), nack(23, sp_t, NackCode.ESTOP_LATCHED)),
                wait(0.03, flags=e, ack_seq=0),
            ],
        },
    ]
