"""The shared protocol test vectors (``tests/data/link_vectors.json``), readable anywhere.

Run ``python -m pirate_bt.link.vectors [OUT]`` to write them. The expectations are
written down from ``docs/protocol.md`` by hand in this module (the request/response
``sequences`` above all); only the hex is computed, by this package's codec. The
JSON is for any implementation: messages are plain objects (``type`` by name,
enums by their wire value, control modes by name, ``null`` = keep), and a frame
that no message can express (an unknown type, a wrong length) is given as hex.

Sections:

- ``good``: one frame per message type, every ACK status and NACK code; decode and
  re-encode to the same bytes;
- ``bad``: frames with the reason a receiver drops them;
- ``cobs``: body/encoded pairs, edge cases of the byte stuffing;
- ``streams``: byte chunks and the frames/errors a decoder yields, in order;
- ``sequences``: steps against a freshly booted bridge for the default robot. A
  step ``send`` (a message) or ``send_hex`` (raw bytes) and ``expect`` the exact
  answers in order (``STATE`` and ``BRIDGE_HEARTBEAT`` frames aside), each as the
  fields that must match (a field left out may be anything); ``advance_s`` lets
  time pass first; ``reset`` reboots the bridge (DTR); ``estop_input`` presses
  (true) or releases (false) the bridge's hardware e-stop input first; ``state``
  checks the newest ``STATE`` received by the end of the step (``flags`` exactly,
  ``flags_set`` and ``flags_clear`` as bit masks, ``ack_seq``, ``board_status_set``
  bits on every board). A sequence with ``needs: "estop_input"`` applies only to a
  bridge that has that input (protocol 1.2, docs/firmware.md).
"""

from __future__ import annotations

import json
import sys
from typing import Any

from pirate_bt.link.codec import FrameCodec
from pirate_bt.link.framing import (
    PROTOCOL_MINOR,
    PROTOCOL_VERSION,
    cobs_encode,
)
from pirate_bt.link.message_json import message_from_json, message_to_json
from pirate_bt.link.messages import (
    Ack,
    AckStatus,
    BoardCounters,
    BoardStatus,
    BridgeFlags,
    BridgeHeartbeat,
    Counters,
    CountersRequest,
    EStop,
    EStopReset,
    Heartbeat,
    Hello,
    HelloReply,
    Message,
    MsgType,
    Nack,
    NackCode,
    Setpoint,
    State,
)
from pirate_bt.link.vector_sequences import frame_hex, good_bulk, sequences
from pirate_bt.robot.description import ControlMode, RobotDescription

__all__ = ["build_vectors", "frame_hex", "message_from_json", "message_to_json"]


def _bad_body(body: bytes) -> str:
    return (cobs_encode(body) + b"\x00").hex()


def _good(codec: FrameCodec, robot: RobotDescription) -> list[dict[str, Any]]:
    lay = codec.layout
    digest = lay.digest
    slots = robot.setpoint_slots()
    n_b, n_ch = lay.n_boards, lay.n_channels
    status = tuple(
        int(BoardStatus.ONLINE | (BoardStatus.MOTORS_OFF if i % 3 == 0 else 0)) for i in range(n_b)
    )
    cases: list[tuple[str, Message]] = [
        ("hello", Hello(1, digest, PROTOCOL_MINOR)),
        (
            "hello_reply",
            HelloReply(
                1,
                digest,
                n_ch,
                lay.n_motors,
                250,
                0x0102,
                PROTOCOL_MINOR,
                0x2A17,
                1,
                BridgeFlags.ESTOP,
            ),
        ),
        ("setpoint_torque", Setpoint(2, slots[4].board, slots[4].slot, ControlMode.TORQUE, -300)),
        ("bulk_setpoints", good_bulk(robot, 3)),
        ("heartbeat", Heartbeat(7)),
        ("estop", EStop(5)),
        ("estop_reset", EStopReset(6)),
        ("counters_request", CountersRequest(8)),
        (
            "state",
            State(
                9,
                BridgeFlags.ESTOP | BridgeFlags.NO_SESSION,
                3,
                (1 << n_ch) - 1 - 4,
                status,
                tuple((i * 37) % 4096 - 2048 for i in range(n_ch)),
            ),
        ),
        ("ack_applied", Ack(2, MsgType.SETPOINT, AckStatus.APPLIED)),
        ("ack_duplicate", Ack(2, MsgType.SETPOINT, AckStatus.DUPLICATE)),
        ("ack_stale", Ack(3, MsgType.BULK_SETPOINTS, AckStatus.STALE)),
        (
            "counters",
            Counters(
                8,
                1234,
                5,
                6,
                7,
                1,
                tuple(BoardCounters(b, b, 2 * b, 3 * b) for b in robot.board_ids()),
            ),
        ),
        ("bridge_heartbeat", BridgeHeartbeat(10, BridgeFlags.WATCHDOG)),
        ("seq_wrap", Heartbeat(0xFFFF)),
    ]
    cases += [(f"nack_{code.name.lower()}", Nack(11, MsgType.SETPOINT, code)) for code in NackCode]
    return [
        {"name": name, "hex": codec.encode(msg).hex(), "message": message_to_json(msg)}
        for name, msg in cases
    ]


def _bad(codec: FrameCodec) -> list[dict[str, Any]]:
    hb = codec.encode(Heartbeat(4))
    flipped = bytearray(hb)
    flipped[3] ^= 0x01
    return [
        {"name": "crc_flipped_bit", "hex": bytes(flipped).hex(), "reason": "crc"},
        {"name": "cobs_code_past_end", "hex": "0501020300", "reason": "cobs"},
        {"name": "too_short", "hex": "0401010100", "reason": "short"},
        {
            "name": "wrong_version",
            "hex": frame_hex(MsgType.HEARTBEAT, 4, version=2),
            "reason": "version",
        },
        {"name": "unknown_type", "hex": frame_hex(0x42, 4), "reason": "type"},
        {
            "name": "heartbeat_with_payload",
            "hex": frame_hex(MsgType.HEARTBEAT, 4, 0, b"\x01"),
            "reason": "length",
        },
        {
            "name": "hello_1_0_payload",
            "hex": frame_hex(MsgType.HELLO, 1, 0, b"\x01\x02\x03\x04"),
            "reason": "length",
        },
        {
            "name": "state_for_other_layout",
            "hex": frame_hex(MsgType.STATE, 4, 0, b"\x01" * 20),
            "reason": "length",
        },
        {
            "name": "setpoint_bad_mode",
            "hex": frame_hex(MsgType.SETPOINT, 4, 22, b"\x00\x09\x01\x00"),
            "reason": "value",
        },
        {
            "name": "ack_bad_status",
            "hex": frame_hex(MsgType.ACK, 4, 0, b"\x02\x07"),
            "reason": "value",
        },
        {
            "name": "nack_bad_code",
            "hex": frame_hex(MsgType.NACK, 4, 0, b"\x02\x0b"),
            "reason": "value",
        },
        {"name": "oversize_body", "hex": _bad_body(b"\x01" * 255), "reason": "oversize"},
        {"name": "oversize_no_delimiter", "hex": "01" * 300, "reason": "oversize"},
    ]


def _cobs() -> list[dict[str, Any]]:
    cases = [
        ("one_zero", b"\x00"),
        ("two_zeros", b"\x00\x00"),
        ("no_zero", b"\x11\x22\x33"),
        ("zero_inside", b"\x11\x22\x00\x33"),
        ("zero_at_end", b"\x11\x22\x33\x00"),
        ("non_zero_253", bytes(range(1, 254))),
        ("non_zero_254", bytes((i % 255) + 1 for i in range(254))),
        ("non_zero_254_then_zero", bytes((i % 255) + 1 for i in range(254)) + b"\x00"),
        ("zero_then_non_zero_254", b"\x00" + bytes((i % 255) + 1 for i in range(254))),
        ("non_zero_255", bytes((i % 255) + 1 for i in range(255))),
    ]
    out: list[dict[str, Any]] = [
        {"name": name, "body": body.hex(), "encoded": cobs_encode(body).hex()}
        for name, body in cases
    ]
    body = bytes((i % 255) + 1 for i in range(254))
    out.append(
        {
            "name": "non_zero_254_with_trailing_01_block",
            "body": body.hex(),
            "encoded": (b"\xff" + body + b"\x01").hex(),
            "decode_only": True,
        }
    )
    return out


def _streams(codec: FrameCodec) -> list[dict[str, Any]]:
    hb1, hb2 = codec.encode(Heartbeat(1)), codec.encode(Heartbeat(2))
    ack = codec.encode(Ack(3, MsgType.HEARTBEAT))
    j = message_to_json
    return [
        {
            "name": "split_byte_by_byte",
            "chunks": [bytes((b,)).hex() for b in hb1],
            "expect": [j(Heartbeat(1))],
        },
        {
            "name": "garbage_then_frame",
            "chunks": [(b"\x13\x37\x42" + b"\x00" + hb1).hex()],
            "expect": [{"error": "cobs"}, j(Heartbeat(1))],
        },
        {
            "name": "empty_frames_ignored",
            "chunks": [(b"\x00\x00" + hb1 + b"\x00\x00" + hb2).hex()],
            "expect": [j(Heartbeat(1)), j(Heartbeat(2))],
        },
        {
            "name": "lost_delimiter_costs_two_frames_at_most",
            "chunks": [(hb1[:-1] + hb2 + ack).hex()],
            "expect": [{"error": "crc"}, j(Ack(3, MsgType.HEARTBEAT))],
        },
        {
            "name": "oversize_run_then_resync",
            "chunks": [("01" * 200), ("01" * 200), (b"\x00" + hb1).hex()],
            "expect": [{"error": "oversize"}, j(Heartbeat(1))],
        },
        {
            "name": "truncated_frame_then_flush",
            "chunks": [(hb1[:4] + b"\x00" + hb2).hex()],
            "expect": [{"error": "short"}, j(Heartbeat(2))],
        },
    ]


def build_vectors(robot: RobotDescription) -> dict[str, Any]:
    """Every vector for ``robot``'s layout (the file is built for the default robot).

    Args:
        robot: The robot description.

    Returns:
        The JSON document.
    """
    codec = FrameCodec.for_robot(robot)
    lay = codec.layout
    return {
        "description": (
            "PIRATEbay protocol 1.2 test vectors (1.1 is its subset) for the default robot "
            "(hardware/pirate.yaml); see docs/protocol.md, Test vectors, and the module "
            "pirate_bt/link/vectors.py that writes them. 'hex' is a wire frame with its "
            "0x00 delimiter. Messages: 'type' by name, enums by wire value, control modes "
            "by name, null = keep."
        ),
        "protocol_version": PROTOCOL_VERSION,
        "protocol_minor": PROTOCOL_MINOR,
        "layout": {
            "n_channels": lay.n_channels,
            "n_motors": lay.n_motors,
            "n_boards": lay.n_boards,
            "digest": lay.digest,
            "watchdog_ms": round(robot.bridge.watchdog * 1000),
            "state_period_ms": round(robot.bridge.state_period * 1000),
        },
        "good": _good(codec, robot),
        "bad": _bad(codec),
        "cobs": _cobs(),
        "streams": _streams(codec),
        "sequences": sequences(codec, robot),
    }


def dumps(robot: RobotDescription) -> str:
    """The vectors file's text for ``robot``."""
    return json.dumps(build_vectors(robot), indent=1) + "\n"


_USAGE = "usage: python -m pirate_bt.link.vectors [FILE]  (default: standard output)"


def main(argv: list[str] | None = None) -> int:
    """Write the vectors of the default robot to ``argv[0]`` (default: stdout).

    Returns 2, with one line on stderr, for anything but one file name (``--help``
    was written to as a file) or a file that cannot be written (a traceback, before
    2026-11-30); the file is written whole or not at all.
    """
    from pirate_bt.atomic import write_atomically
    from pirate_bt.robot.loader import load_robot

    args = sys.argv[1:] if argv is None else argv
    if len(args) > 1 or (args and (args[0].startswith("-") or not args[0])):
        if args == ["-h"] or args == ["--help"]:
            print(_USAGE)
            return 0
        print(f"{_USAGE}: not {' '.join(args)!r}", file=sys.stderr)
        return 2
    data = dumps(load_robot()).encode()
    if not args:
        sys.stdout.write(data.decode())
        return 0
    try:
        write_atomically(args[0], lambda stream: stream.write(data))
    except OSError as exc:
        print(f"{args[0]}: cannot write: {exc.strerror or exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
