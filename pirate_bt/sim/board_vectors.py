"""The board bus's shared byte-level vectors (``tests/data/board_bus_vectors.json``).

``docs/board-bus.md`` (version 2) is the one truth for both ends of the board bus:
the bridge firmware (``firmware/piratebay/``), the reference PICO board firmware
(``firmware/pico/``) and the Python boards (:class:`pirate_bt.sim.boardbus.BoardBus`).
These vectors hold them to it. Run ``python -m pirate_bt.sim.board_vectors [OUT]`` to
write them; the expectations are spelled out here by hand from the page, only the
hex is computed.

Sections, for the default robot (``hardware/pirate.yaml``):

- ``frames``: one of each frame the bridge sends or accepts: an ``EXCHANGE``, a
  ``STOP`` in the boards' own modes (a drive brakes with ``pwm 0``, a bend joint
  keeps), an ``EXCHANGE_REPLY``, and replies the bridge must refuse; each as wire hex
  (delimiter included) with its fields.
- ``sequences``: one board, freshly booted at time 0, and steps in order: at
  ``at_ms`` (milliseconds since the board's boot) the board's inputs are ``channels``
  (the raw values its reply carries; ``pico_inputs`` gives the ADC readings 0..1023
  and the IMU's 1/16 degree that produce them on the reference board), then the
  master sends ``send_hex`` (if any). The board must answer ``expect_reply_hex``
  (``null``: nothing) and then execute ``expect_motors``: per motor in slot order,
  ``[mode code, raw]``, or ``null`` for a motor never commanded (its H-bridge off).
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pirate_bt.atomic import write_atomically
from pirate_bt.link.codec import MODE_CODES, MODE_KEEP, cobs_encode, crc16
from pirate_bt.robot.description import ControlMode, RobotDescription

__all__ = ["build_vectors", "main", "pico_inputs", "reply_hex", "request_hex"]

EXCHANGE, STOP, REPLY = 0x01, 0x02, 0x81
FAULT, MOTORS_OFF, OWN_STOP, STALE = 0x01, 0x02, 0x04, 0x08
PWM = MODE_CODES[ControlMode.PWM]
TORQUE = MODE_CODES[ControlMode.TORQUE]
VELOCITY = MODE_CODES[ControlMode.VELOCITY]
KEEP = MODE_KEEP
_IMU_LSB_RAD = math.radians(1 / 16)

Setpoints = list[tuple[int, int]]


def _wire(body: bytes) -> str:
    body += crc16(body).to_bytes(2, "little")
    return (cobs_encode(body) + b"\x00").hex()


def request_hex(addr: int, cmd: int, setpoints: Setpoints) -> str:
    """The wire hex of an EXCHANGE or STOP to ``addr``."""
    payload = b"".join(
        bytes((mode,)) + raw.to_bytes(2, "little", signed=True) for mode, raw in setpoints
    )
    return _wire(bytes((addr, cmd)) + payload)


def reply_hex(addr: int, status: int, channels: list[int]) -> str:
    """The wire hex of an EXCHANGE_REPLY from ``addr``."""
    values = b"".join(v.to_bytes(2, "little", signed=True) for v in channels)
    return _wire(bytes((addr, REPLY, status)) + values)


def heading_of_yaw(yaw_lsb: int) -> int:
    """The IMU's heading register (a BNO055's: 0..360 degrees clockwise, in 1/16 degree)
    that the reference PICO reads as ``yaw_lsb`` (1/16 degree counter-clockwise)."""
    return -yaw_lsb % 5760


def pico_inputs(robot: RobotDescription, board: int, channels: list[int]) -> dict[str, Any]:
    """The reference board's inputs that make its channels read ``channels``.

    An ADC channel spans its raw range over 0..1023 (raw = lo + adc * (hi - lo + 1) /
    1024); a velocity channel reads 0 (the encoders stand still); an IMU axis is the
    IMU's 1/16 degree in the channel's unit (yaw is the heading, clockwise 0..360
    degrees, turned counter-clockwise and wrapped to (-180, 180]).

    Raises:
        ValueError: a value the board cannot produce exactly.
    """
    adc = [0, 0, 0, 0]
    imu = [0, 0, 0]
    entry = robot.board(board)
    specs = [c for c in robot.state_channels() if c.board == board]
    sources: list[tuple[str, int]] = []
    for sensor in sorted(entry.sensors, key=lambda s: s.slot):
        if sensor.kind == "imu":
            sources += [(f"imu_{axis}", sensor.slot) for axis in sensor.channels]
        else:
            sources.append(("adc", sensor.slot))
    for motor in sorted(entry.motors, key=lambda m: m.slot):
        for key in ("velocity", "current"):
            if getattr(motor.feedback, key) is not None:
                sources.append((key, motor.slot))
    for (source, slot), spec, value in zip(sources, specs, channels, strict=True):
        lo, hi = spec.conversion.raw
        if source in ("adc", "current"):
            step = (hi - lo + 1) / 1024
            reading = round((value - lo) / step)
            if lo + (reading * (hi - lo + 1)) // 1024 != value:
                raise ValueError(f"{spec.name}: {value} is not a reading of the ADC")
            adc[slot if source == "adc" else 2 + slot] = reading
        elif source == "velocity":
            if value != 0:
                raise ValueError(f"{spec.name}: the vectors' encoders stand still")
        else:
            scale = round(_IMU_LSB_RAD / spec.conversion.per_raw * 65536)
            lsb = round(value * 65536 / scale)
            q = lsb * scale + (32768 if lsb >= 0 else -32768)
            rounded = abs(q) // 65536 * (1 if q >= 0 else -1)  # C division truncates
            if spec.conversion.zero_raw + rounded != value:
                raise ValueError(f"{spec.name}: {value} is not an IMU reading")
            if source == "imu_yaw":
                # the IMU's heading grows clockwise, 0..360 degrees; yaw counter-clockwise
                imu[0] = heading_of_yaw(lsb)
            else:
                imu[{"imu_roll": 1, "imu_pitch": 2}[source]] = lsb
    return {"adc": adc, "imu": imu}


def build_vectors(robot: RobotDescription) -> dict[str, Any]:
    """The vectors for ``robot`` (written for the default robot; see the module doc)."""
    ids = robot.board_ids()
    for needed in (22, 23, 24, 25, 28):
        if needed not in ids:
            raise ValueError("the board-bus vectors are written for the default robot")

    def step(
        at_ms: int,
        board: int,
        channels: list[int],
        send: str | None,
        reply: str | None,
        motors: Sequence[list[int] | None],
    ) -> dict[str, Any]:
        return {
            "at_ms": at_ms,
            "channels": channels,
            "pico_inputs": pico_inputs(robot, board, channels),
            "send_hex": send,
            "expect_reply_hex": reply,
            "expect_motors": list(motors),
        }

    ch22 = [2448, 300, 0, 100]  # angle (a multiple of 4: the 10-bit ADC), spring, speed, current
    ch24 = [1745, -873, 175, 0, 40]  # IMU roll, pitch, yaw (10, -5, 1 degree), speed, current
    ch25 = [2000, 0, 12]
    ch28 = [4092]
    x22 = request_hex(22, EXCHANGE, [(KEEP, 0), (VELOCITY, 800)])
    both22 = request_hex(22, EXCHANGE, [(TORQUE, 500), (VELOCITY, 800)])
    other22 = request_hex(22, EXCHANGE, [(TORQUE, 300), (VELOCITY, 900)])
    stop22 = request_hex(22, STOP, [(KEEP, 0), (PWM, 0)])
    x23 = request_hex(23, EXCHANGE, [(KEEP, 0), (VELOCITY, 100)])

    def r22(status: int) -> str:
        return reply_hex(22, status, ch22)

    held = [[TORQUE, 500], [PWM, 0]]
    bad_crc = bytearray(bytes.fromhex(x22))
    bad_crc[-2] ^= 0x01  # the CRC's high byte (never 0: COBS keeps it non-zero)
    frames: list[dict[str, Any]] = [
        {
            "name": "exchange",
            "hex": x22,
            "addr": 22,
            "cmd": EXCHANGE,
            "setpoints": [[KEEP, 0], [VELOCITY, 800]],
        },
        {
            "name": "stop_drive_and_bend",
            "hex": stop22,
            "addr": 22,
            "cmd": STOP,
            "setpoints": [[KEEP, 0], [PWM, 0]],
        },
        {
            "name": "stop_rotate_and_drive",
            "hex": request_hex(25, STOP, [(PWM, 0), (PWM, 0)]),
            "addr": 25,
            "cmd": STOP,
            "setpoints": [[PWM, 0], [PWM, 0]],
        },
        {
            "name": "stop_leds",
            "hex": request_hex(28, STOP, [(PWM, 0)]),
            "addr": 28,
            "cmd": STOP,
            "setpoints": [[PWM, 0]],
        },
        {
            "name": "reply",
            "hex": r22(0),
            "addr": 22,
            "cmd": REPLY,
            "status": 0,
            "channels": ch22,
        },
        {
            "name": "reply_fault_and_motors_off",
            "hex": reply_hex(24, FAULT | MOTORS_OFF, ch24),
            "addr": 24,
            "cmd": REPLY,
            "status": FAULT | MOTORS_OFF,
            "channels": ch24,
        },
    ]
    bad_reply = bytearray(bytes.fromhex(r22(0)))
    bad_reply[-2] ^= 0x01
    refused: list[dict[str, Any]] = [
        {"name": "reply_bad_crc", "hex": bad_reply.hex(), "addr": 22, "reason": "crc"},
        {
            "name": "reply_wrong_length",
            "hex": reply_hex(22, 0, ch22[:-1]),
            "addr": 22,
            "reason": "length",
        },
        {
            "name": "reply_from_another_board",
            "hex": reply_hex(23, 0, ch22),
            "addr": 22,
            "reason": "address",
        },
        {"name": "reply_not_a_reply", "hex": x22, "addr": 22, "reason": "command"},
    ]
    sequences: list[dict[str, Any]] = [
        {
            "name": "exchange_answers_status_and_channels",
            "description": "an EXCHANGE is applied and answered with the status and the "
            "board's channels; a motor never commanded (keep) leaves MOTORS_OFF set",
            "board": 22,
            "steps": [
                step(5, 22, ch22, x22, r22(MOTORS_OFF), [None, [VELOCITY, 800]]),
                step(15, 22, ch22, both22, r22(0), [[TORQUE, 500], [VELOCITY, 800]]),
            ],
        },
        {
            "name": "stop_brakes_the_drive_and_the_clamp_holds",
            "description": "a STOP is applied and not answered: the drive brakes (pwm 0), "
            "the bend joint keeps its torque",
            "board": 22,
            "steps": [
                step(5, 22, ch22, both22, r22(0), [[TORQUE, 500], [VELOCITY, 800]]),
                step(8, 22, ch22, stop22, None, held),
            ],
        },
        {
            "name": "own_stop_after_silence",
            "description": "no frame to the board for 100 ms: it stops itself (drive "
            "braked, clamp holding), answers OWN_STOP without applying exchanges, until a "
            "STOP hands the stop back to the master",
            "board": 22,
            "steps": [
                step(5, 22, ch22, both22, r22(0), [[TORQUE, 500], [VELOCITY, 800]]),
                step(95, 22, ch22, None, None, [[TORQUE, 500], [VELOCITY, 800]]),
                step(130, 22, ch22, None, None, held),
                step(131, 22, ch22, other22, r22(OWN_STOP), held),
                step(132, 22, ch22, stop22, None, held),
                step(133, 22, ch22, other22, r22(0), [[TORQUE, 300], [VELOCITY, 900]]),
            ],
        },
        {
            "name": "frames_to_other_boards",
            "description": "a frame to another board is not answered, applied, or taken "
            "for the master's voice: the silence timer runs on",
            "board": 22,
            "steps": [
                step(5, 22, ch22, both22, r22(0), [[TORQUE, 500], [VELOCITY, 800]]),
                step(60, 22, ch22, x23, None, [[TORQUE, 500], [VELOCITY, 800]]),
                step(100, 22, ch22, x23, None, [[TORQUE, 500], [VELOCITY, 800]]),
                step(120, 22, ch22, x23, None, held),
            ],
        },
        {
            "name": "bad_frames_are_ignored",
            "description": "a bad CRC, a wrong payload length, an unknown command, broken "
            "COBS: no answer, nothing applied",
            "board": 22,
            "steps": [
                step(5, 22, ch22, bad_crc.hex(), None, [None, None]),
                step(
                    6,
                    22,
                    ch22,
                    request_hex(22, EXCHANGE, [(VELOCITY, 800)]),
                    None,
                    [None, None],
                ),
                step(7, 22, ch22, _wire(bytes((22, 0x03)) + bytes(6)), None, [None, None]),
                step(8, 22, ch22, "0522010000", None, [None, None]),
                step(9, 22, ch22, x22, r22(MOTORS_OFF), [None, [VELOCITY, 800]]),
            ],
        },
        {
            "name": "entries_the_motor_does_not_accept",
            "description": "an entry out of the mode's range, or in a mode the motor "
            "lacks, is not applied; the rest of the frame is",
            "board": 22,
            "steps": [
                step(
                    5,
                    22,
                    ch22,
                    request_hex(22, EXCHANGE, [(VELOCITY, 5), (VELOCITY, 5000)]),
                    r22(MOTORS_OFF),
                    [None, None],
                ),
                step(
                    6,
                    22,
                    ch22,
                    request_hex(22, EXCHANGE, [(TORQUE, 5), (VELOCITY, 5000)]),
                    r22(MOTORS_OFF),
                    [[TORQUE, 5], None],
                ),
            ],
        },
        {
            "name": "a_board_with_one_motor",
            "description": "board 28: its LEDs on slot 1, one channel",
            "board": 28,
            "steps": [
                step(
                    5,
                    28,
                    ch28,
                    request_hex(28, EXCHANGE, [(PWM, 128)]),
                    reply_hex(28, 0, ch28),
                    [[PWM, 128]],
                ),
                step(6, 28, ch28, request_hex(28, STOP, [(PWM, 0)]), None, [[PWM, 0]]),
            ],
        },
        {
            "name": "imu_and_drive",
            "description": "board 24: IMU roll, pitch, yaw, the drive's speed and current",
            "board": 24,
            "steps": [
                # 40 ms after boot: a BNO055 starts in CONFIGMODE, its outputs 0; the
                # board reads the mode, sets a fusion mode, and reads the angles 10 ms
                # later (firmware/pico/hal_avr.c)
                step(
                    40,
                    24,
                    ch24,
                    request_hex(24, EXCHANGE, [(VELOCITY, 0)]),
                    reply_hex(24, 0, ch24),
                    [[VELOCITY, 0]],
                ),
            ],
        },
        {
            "name": "rotate_and_drive_stop",
            "description": "board 25: a STOP brakes the rotation and the drive",
            "board": 25,
            "steps": [
                step(
                    5,
                    25,
                    ch25,
                    request_hex(25, EXCHANGE, [(TORQUE, 200), (VELOCITY, 300)]),
                    reply_hex(25, 0, ch25),
                    [[TORQUE, 200], [VELOCITY, 300]],
                ),
                step(
                    6,
                    25,
                    ch25,
                    request_hex(25, STOP, [(PWM, 0), (PWM, 0)]),
                    None,
                    [[PWM, 0], [PWM, 0]],
                ),
            ],
        },
    ]
    for seq in sequences:  # checks of this module: times in order, one delimiter a frame
        times = [s["at_ms"] for s in seq["steps"]]
        assert times == sorted(times) and times[0] > 0
    for item in (*frames, *refused):
        assert bytes.fromhex(item["hex"]).count(0) == 1, item["name"]
    return {
        "version": 2,
        "robot": "hardware/pirate.yaml",
        "layout_digest": robot.layout_digest(),
        "board_silence_ms": 100,
        "frames": frames,
        "refused_replies": refused,
        "sequences": sequences,
    }


_USAGE = "usage: python -m pirate_bt.sim.board_vectors [FILE]"
_CHECKOUT_FILE = Path(__file__).resolve().parents[2] / "tests" / "data" / "board_bus_vectors.json"


def main(argv: list[str] | None = None) -> int:
    """Write the vectors to ``argv[0]`` (default: the checkout's
    ``tests/data/board_bus_vectors.json``, wherever it is run from).

    Returns 2, with one line on stderr, for anything but one file name (``--help`` was
    written to as a file), a file that cannot be written, or no file named outside a
    checkout (each a traceback, before 2026-11-30); the file is written whole or not
    at all.
    """
    from pirate_bt.robot.loader import load_robot

    args = sys.argv[1:] if argv is None else argv
    if args in (["-h"], ["--help"]):
        print(_USAGE)
        return 0
    if len(args) > 1 or (args and (args[0].startswith("-") or not args[0])):
        print(f"{_USAGE}: not {' '.join(args)!r}", file=sys.stderr)
        return 2
    if args:
        out = args[0]
    elif _CHECKOUT_FILE.parent.is_dir():
        out = str(_CHECKOUT_FILE)
    else:
        print(f"{_USAGE}: no checkout's tests/data here; name the file to write", file=sys.stderr)
        return 2
    data = (json.dumps(build_vectors(load_robot()), indent=1) + "\n").encode()
    try:
        write_atomically(out, lambda stream: stream.write(data))
    except OSError as exc:
        print(f"{out}: cannot write: {exc.strerror or exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
