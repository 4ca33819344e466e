"""The robot's wire layout as a C header, for the PIRATEbay firmware.

The bridge firmware (``firmware/piratebay/``) must agree with the host on every
board id, channel, motor slot and raw range, and the robot description
(``hardware/*.yaml``) is the single source of truth for them. So the firmware
does not carry a copy: ``pirate-bt robot header ROBOT.yaml -o layout.h`` writes
this header at build time, and the firmware's Makefile calls it.

The header holds only what the bridge checks or acts on (``docs/protocol.md``):
the boards in ascending id with the slice of state channels and motors each one
owns, each motor's stop role and the raw range of every mode it accepts, the
bridge's periods and baud rate, and the layout digest the host compares at hello
time. SI conversions, limits and geometry stay on the host. Tables come out as
initializer lists (``PB_BOARD_TABLE``, ``PB_MOTOR_TABLE``) so that the firmware
owns its struct types and where the tables live (flash, on the AVR).

The reference PICO board firmware (``firmware/pico/``) is built from the same
header. It also needs to know what produces each of its channels and how its
closed loops scale: ``PB_CHANNEL_IO_TABLE`` (the source of every state channel: a
sensor connector's ADC, an IMU axis, a motor's encoder or current sense, with the
raw range the ADC spans) and ``PB_MOTOR_IO_TABLE`` (per motor: the angle channel a
position loop closes on and its scale, the duty that holds a joint at the position
hold torque, the wheel circumference and the velocity feedback's raw unit). The
bridge ignores both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from pirate_bt.atomic import write_atomically
from pirate_bt.errors import ConfigurationError
from pirate_bt.robot.description import ControlMode, MotorFunction, RobotDescription

__all__ = [
    "CHANNEL_SOURCES",
    "MODE_ORDER",
    "STOP_ROLES",
    "BoardSlice",
    "ChannelIO",
    "MotorIO",
    "board_io",
    "board_slices",
    "render_header",
    "stop_role",
    "uncovered_boards",
    "write_header",
]

MODE_ORDER: tuple[ControlMode, ...] = (
    ControlMode.PWM,
    ControlMode.TORQUE,
    ControlMode.POSITION,
    ControlMode.VELOCITY,
)
"""Control modes in wire-code order (code = index), as in ``docs/protocol.md``."""

STOP_ROLES: tuple[str, ...] = ("drive", "rotate", "bend", "other")
"""Stop roles in the order of their C codes (``PB_ROLE_DRIVE`` = 0, ...)."""

_INT16 = (-32768, 32767)

CHANNEL_SOURCES: tuple[str, ...] = (
    "adc",
    "imu_roll",
    "imu_pitch",
    "imu_yaw",
    "velocity",
    "current",
)
"""What produces a state channel on its PICO board, in the order of their C codes
(``PB_SRC_ADC`` = 0, ...)."""


@dataclass(frozen=True, slots=True)
class ChannelIO:
    """What produces one state channel on its PICO board (``firmware/pico/``)."""

    index: int
    board_index: int
    source: str
    slot: int
    raw_lo: int
    raw_hi: int
    zero_raw: int
    scale_q16: int
    """IMU axes only: raw units per IMU LSB (1/16 degree), times 65536."""


@dataclass(frozen=True, slots=True)
class MotorIO:
    """What the PICO board's closed loops need to know of one motor."""

    index: int
    angle_channel: int
    """Layout index of the angle channel on the motor's slot (-1: none)."""
    position_q16: int
    """Angle-sensor raw units per position raw unit, times 65536."""
    hold_duty: int
    """Largest duty (of 255) of the position loop: the position hold torque."""
    circumference_um: int
    """Wheel circumference of the motor's module (0: no wheel)."""
    velocity_per_raw_um_s: int
    """One raw unit of the velocity feedback, in µm/s (0: no velocity feedback)."""


def board_io(robot: RobotDescription) -> tuple[list[ChannelIO], list[MotorIO]]:
    """The PICO boards' I/O tables (see the module docstring).

    Raises:
        ConfigurationError: an IMU with other axes than roll, pitch, yaw, or a value the
            PICO firmware's tables cannot hold (a reversed or sub-micrometre velocity
            feedback step, an IMU or position scale beyond int32).
    """
    channels = robot.state_channels()
    boards = sorted(robot.boards, key=lambda b: b.id)
    out_channels: list[ChannelIO] = []
    for bi, board in enumerate(boards):
        for sensor in sorted(board.sensors, key=lambda s: s.slot):
            conv = sensor.conversion()
            lo, hi = conv.raw
            if sensor.kind == "imu":
                scale = round(math.radians(1 / 16) / conv.per_raw * 65536)
                for axis in sensor.channels:
                    if axis not in ("roll", "pitch", "yaw"):
                        raise ConfigurationError(f"IMU {sensor.name!r}: axis {axis!r} unknown")
                    out_channels.append(
                        ChannelIO(
                            len(out_channels),
                            bi,
                            f"imu_{axis}",
                            sensor.slot,
                            lo,
                            hi,
                            conv.zero_raw,
                            scale,
                        )
                    )
            else:
                out_channels.append(
                    ChannelIO(len(out_channels), bi, "adc", sensor.slot, lo, hi, conv.zero_raw, 0)
                )
        for motor in sorted(board.motors, key=lambda m: m.slot):
            for key in ("velocity", "current"):
                fb = getattr(motor.feedback, key)
                if fb is not None:
                    lo, hi = fb.raw
                    out_channels.append(
                        ChannelIO(len(out_channels), bi, key, motor.slot, lo, hi, fb.zero_raw, 0)
                    )
    # the same order as the wire layout (robot.state_channels), by construction
    assert len(out_channels) == len(channels)
    assert all(
        c.board_index == [b.id for b in boards].index(s.board)
        for c, s in zip(out_channels, channels, strict=True)
    )
    hold_nm = robot.motion.position_hold_torque
    out_motors: list[MotorIO] = []
    for slot in robot.setpoint_slots():
        motor = slot.motor
        board = robot.board(slot.board)
        angle = next((s for s in board.sensors if s.slot == slot.slot and s.kind == "angle"), None)
        angle_channel, position_q16 = -1, 0
        position = motor.modes.position
        if angle is not None and position is not None:
            angle_channel = next(
                c.index
                for c in out_channels
                if c.source == "adc"
                and c.slot == slot.slot
                and c.board_index == boards.index(board)
            )
            position_q16 = round(position.per_raw / angle.conversion().per_raw * 65536)
        torque = motor.modes.torque
        hold_duty = 255
        if torque is not None:
            stall_nm = max(abs(v) for v in torque.si_range)
            hold_duty = max(1, min(255, round(255 * hold_nm / stall_nm)))
        module = robot.module(board.module)
        radius = module.wheel_radius
        circumference = round(2 * math.pi * radius * 1e6) if radius else 0
        velocity = motor.feedback.velocity
        per_raw = round(velocity.per_raw * 1e6) if velocity is not None else 0
        if velocity is not None and not 1 <= per_raw <= 65535:
            # a uint16 in the PICO's table: -100 became 65436, 0.4 became 0 (no feedback)
            raise ConfigurationError(
                f"motor {motor.name!r}: the reference PICO firmware takes a velocity feedback"
                f" step of 1 .. 65535 um/s (whole, positive), not {velocity.per_raw * 1e6:g}"
                " um/s: change feedback.velocity's raw range and per_raw"
            )
        if not -(2**31) <= position_q16 < 2**31 or not 0 <= circumference < 2**32:
            raise ConfigurationError(
                f"motor {motor.name!r}: its position scale or wheel circumference does not"
                " fit the reference PICO firmware's table (int32, uint32)"
            )
        out_motors.append(
            MotorIO(slot.index, angle_channel, position_q16, hold_duty, circumference, per_raw)
        )
    for channel in out_channels:
        if not -(2**31) <= channel.scale_q16 < 2**31:
            raise ConfigurationError(
                f"state channel {channels[channel.index].name!r}: its IMU scale"
                f" ({channel.scale_q16} raw per 1/16 degree, Q16) does not fit the reference"
                " PICO firmware's table (int32): make per_raw coarser"
            )
    return out_channels, out_motors


def stop_role(function: MotorFunction) -> str:
    """The stop role of a motor function: what every stop does to the motor."""
    if function is MotorFunction.DRIVE:
        return "drive"
    if function is MotorFunction.ROTATE:
        return "rotate"
    if function is MotorFunction.BEND:
        return "bend"
    return "other"


@dataclass(frozen=True, slots=True)
class BoardSlice:
    """One board's part of the wire layout."""

    board: int
    first_channel: int
    channels: tuple[str, ...]
    first_motor: int
    motor_slots: tuple[int, ...]


def board_slices(robot: RobotDescription) -> list[BoardSlice]:
    """Each board (ascending id) with its contiguous run of channels and motors."""
    channels = robot.state_channels()
    motors = robot.setpoint_slots()
    out = []
    for board in robot.board_ids():
        chans = [c for c in channels if c.board == board]
        mots = [m for m in motors if m.board == board]
        first_channel = chans[0].index if chans else sum(1 for c in channels if c.board < board)
        first_motor = mots[0].index if mots else sum(1 for m in motors if m.board < board)
        # the layout is boards by id, so each board's entries are contiguous
        assert [c.index for c in chans] == list(range(first_channel, first_channel + len(chans)))
        assert [m.index for m in mots] == list(range(first_motor, first_motor + len(mots)))
        out.append(
            BoardSlice(
                board,
                first_channel,
                tuple(c.name for c in chans),
                first_motor,
                tuple(m.slot for m in mots),
            )
        )
    return out


def _c_string(text: str) -> str:
    """``text`` as a C string literal: printable ASCII (anything else as ``?``), with
    every ``?`` escaped, so that no ``??x`` trigraph (``-std=c11``) changes it."""
    printable = "".join(ch if " " <= ch <= "~" else "?" for ch in text)
    escaped = printable.replace("\\", "\\\\").replace('"', '\\"').replace("?", "\\?")
    return '"' + escaped + '"'


def _c_comment(text: str) -> str:
    """``text`` fit for a ``/* */`` comment: printable ASCII (anything else as ``?``),
    with no ``*/`` to end it early, no ``/*`` (``-Wcomment``) and no ``??`` (a trigraph)."""
    out = "".join(ch if " " <= ch <= "~" else "?" for ch in text)
    while "/*" in out or "*/" in out or "??" in out:
        out = out.replace("/*", "/?").replace("*/", "?/").replace("??", "?_")
    return out


def _ms(seconds: float) -> int:
    return round(seconds * 1000)


def uncovered_boards(robot: RobotDescription) -> str | None:
    """Why ``robot``'s wire layout cannot be made, if it has boards with no motor and no
    sensor: each would take a board status nibble in ``STATE`` and an entry in
    ``COUNTERS`` that the layout digest cannot cover (``None`` when it has none)."""
    empty = sorted(b.id for b in robot.boards if not b.motors and not b.sensors)
    if not empty:
        return None
    return (
        f"robot {robot.name!r}: board(s) {', '.join(map(str, empty))} have no motor"
        " and no sensor: each would take a board status nibble in STATE and an"
        " entry in COUNTERS that the layout digest cannot cover (a bridge built"
        " with or without them would pass the hello); remove them"
    )


def render_header(robot: RobotDescription, source: str = "") -> str:
    """The C header text of ``robot``'s wire layout (``source`` names the YAML in a comment).

    Raises:
        ConfigurationError: the layout does not fit the wire format or the firmware,
            or has a board with no motor and no sensor (:func:`uncovered_boards`).
    """
    if (uncovered := uncovered_boards(robot)) is not None:
        raise ConfigurationError(uncovered)
    slices = board_slices(robot)
    channels = robot.state_channels()
    motors = robot.setpoint_slots()
    bridge = robot.bridge
    if len(channels) > 255 or len(motors) > 255:
        raise ConfigurationError("the wire layout allows at most 255 channels and 255 motors")
    state_period_ms = _ms(bridge.state_period)
    watchdog_ms = _ms(bridge.watchdog)
    if not 1 <= state_period_ms <= 60000 or not 1 <= watchdog_ms <= 60000:
        raise ConfigurationError("bridge.state_period and bridge.watchdog must be 1 ms .. 60 s")
    lines = [
        "/* Generated by `pirate-bt robot header` from"
        f" {_c_comment(source) or 'the robot description'}.",
        " * Do not edit: change the robot description and rebuild (make firmware).",
        " * Layout rules: docs/protocol.md; types: firmware/piratebay/layout.h. */",
        "#ifndef PB_GENERATED_LAYOUT_H",
        "#define PB_GENERATED_LAYOUT_H",
        "",
        f"#define PB_ROBOT_NAME {_c_string(robot.name)}",
        f"#define PB_LAYOUT_DIGEST 0x{robot.layout_digest():08X}UL",
        f"#define PB_N_BOARDS {len(slices)}",
        f"#define PB_N_CHANNELS {len(channels)}",
        f"#define PB_N_MOTORS {len(motors)}",
        f"#define PB_MAX_BOARD_CHANNELS {max((len(s.channels) for s in slices), default=0)}",
        f"#define PB_MAX_BOARD_MOTORS {max((len(s.motor_slots) for s in slices), default=0)}",
        f"#define PB_BAUD {bridge.baud}UL",
        f"#define PB_STATE_PERIOD_MS {state_period_ms}",
        f"#define PB_WATCHDOG_MS {watchdog_ms}",
        f"#define PB_RESET_TIME_MS {_ms(bridge.reset_time)}",
        "",
        "/* Stop roles (docs/protocol.md, Stop category). */",
        *(f"#define PB_ROLE_{role.upper()} {code}" for code, role in enumerate(STOP_ROLES)),
        "",
        "/* State channels in wire order (index: board name). */",
        *(f"/*   {c.index:3d}: {c.board} {c.name} */" for c in channels),
        "",
        "/* Boards in ascending id: {id, first channel, channels, first motor, motors,",
        " *   slot mask}. */",
        "#define PB_BOARD_TABLE { \\",
    ]
    for s in slices:
        mask = sum(1 << slot for slot in s.motor_slots)
        lines.append(
            f"    {{{s.board}, {s.first_channel}, {len(s.channels)}, {s.first_motor},"
            f" {len(s.motor_slots)}, 0x{mask:02X}}}, \\"
        )
    lines += [
        "}",
        "",
        "/* Motors in wire order: {board index, slot, role, accepted-mode mask (bit = mode",
        " *   code), {raw lo, raw hi} for pwm, torque, position, velocity}; a mode the",
        " *   motor lacks has the range {0, -1} and its bit clear. */",
        "#define PB_MOTOR_TABLE { \\",
    ]
    board_index = {s.board: i for i, s in enumerate(slices)}
    for m in motors:
        mask = 0
        ranges = []
        for code, mode in enumerate(MODE_ORDER):
            conv = m.motor.modes.get(mode)
            if conv is None:
                ranges.append("{0, -1}")
                continue
            lo, hi = conv.raw
            if not (_INT16[0] <= lo <= hi <= _INT16[1]):
                raise ConfigurationError(f"motor {m.motor.name!r}: {mode} raw range is not int16")
            mask |= 1 << code
            ranges.append(f"{{{lo}, {hi}}}")
        role = stop_role(m.motor.function).upper()
        lines.append(
            f"    {{{board_index[m.board]}, {m.slot}, PB_ROLE_{role}, 0x{mask:X},"
            f" {{{', '.join(ranges)}}}}}, /* {m.board}:{m.slot} {m.motor.name} */ \\"
        )
    lines += ["}", ""]
    lines += _board_io_lines(robot)
    lines += ["#endif /* PB_GENERATED_LAYOUT_H */", ""]
    return "\n".join(lines)


def _board_io_lines(robot: RobotDescription) -> list[str]:
    """The PICO boards' I/O tables as C (firmware/pico/; the bridge ignores them)."""
    channels, motors = board_io(robot)
    lines = [
        "/* The reference PICO firmware's board I/O (firmware/pico/, docs/board-bus.md).",
        " * Channel sources: */",
        *(f"#define PB_SRC_{name.upper()} {code}" for code, name in enumerate(CHANNEL_SOURCES)),
        "",
        "/* State channels in wire order: {board index, source, slot (sensor or motor",
        " *   connector), raw lo, raw hi, zero raw, IMU raw per 1/16 degree (Q16)}. An ADC",
        " *   channel spans [raw lo, raw hi] over the ADC's 0..1023. */",
        "#define PB_CHANNEL_IO_TABLE { \\",
    ]
    for c in channels:
        lines.append(
            f"    {{{c.board_index}, PB_SRC_{c.source.upper()}, {c.slot}, {c.raw_lo},"
            f" {c.raw_hi}, {c.zero_raw}, {c.scale_q16}}}, \\"
        )
    lines += [
        "}",
        "",
        "/* Motors in wire order: {angle channel of the position loop (-1: none), angle raw",
        " *   per position raw (Q16), duty limit of the position loop (of 255: the position",
        " *   hold torque), wheel circumference (um), velocity feedback raw unit (um/s)}. */",
        "#define PB_MOTOR_IO_TABLE { \\",
    ]
    for m in motors:
        lines.append(
            f"    {{{m.angle_channel}, {m.position_q16}, {m.hold_duty}, {m.circumference_um},"
            f" {m.velocity_per_raw_um_s}}}, \\"
        )
    lines += ["}", ""]
    return lines


def write_header(robot: RobotDescription, out: Path, source: str = "") -> Path:
    """Write the header to ``out`` atomically (no half-written file on failure)."""
    data = render_header(robot, source).encode("ascii")
    write_atomically(out, lambda stream: stream.write(data))
    return out
