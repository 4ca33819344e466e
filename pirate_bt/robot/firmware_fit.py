"""Rules of a robot description that the reference PICO firmware sets.

A description the simulator drives can still be one the reference firmware cannot:
the PICO boards stop themselves when the bridge polls them too seldom, close a
position loop only on an angle sensor of the motor's own slot, and a speed loop only
on a wheel's speed they can work out; the bridge's serial line, which the simulator
does not have, must carry the host's heartbeats and a fresh enough STATE.
:mod:`pirate_bt.robot.fitness` asks these rules with its own.
"""

from __future__ import annotations

import math

from pirate_bt.robot.parts import SensorKind
from pirate_bt.robot.workable import KeyPath, Workable

__all__ = [
    "BOARD_SILENCE_S",
    "HEARTBEAT_WIRE_BYTES",
    "board_poll_problems",
    "heartbeat_problems",
    "position_sensor_problems",
    "state_line_problems",
    "state_wire_bytes",
    "velocity_loop_problems",
]

BOARD_SILENCE_S = 0.1
"""A board that hears no poll from the bridge for this long stops itself and says
``OWN_STOP``, on which the bridge stops the whole robot: the reference PICO firmware's
``BOARD_SILENCE_MS`` (firmware/pico/bus.h), the simulated boards' too
(docs/board-bus.md, Board-side timeout). A robot description cannot change it."""


HEARTBEAT_WIRE_BYTES = 9
"""A HEARTBEAT frame on the wire (docs/protocol.md; the link's own figure, which the
tests hold equal to this one)."""


def heartbeat_problems(desc: Workable) -> list[tuple[KeyPath, str]]:
    """The host sends ten heartbeats a watchdog period, and they may take at most half
    the line (docs/protocol.md, Heartbeats): a watchdog shorter than that at the
    description's baud is refused by the host when it connects, to the simulator as to
    the bridge, as a firmware built for another description."""
    baud = desc.bridge.baud
    frame_ms = 1000 * HEARTBEAT_WIRE_BYTES * 10 / baud
    least_ms = math.ceil(2 * 10 * frame_ms)
    if round(desc.bridge.watchdog * 1000) >= least_ms:
        return []
    return [
        (
            ("bridge", "watchdog"),
            f"watchdog {_fmt_ms(desc.bridge.watchdog)} is too short for its line at {baud}"
            f" baud: the host sends ten heartbeats a watchdog period, each {frame_ms:.2f} ms"
            f" on the line, and they may take at most half of it, so the watchdog must be at"
            f" least {least_ms} ms (docs/protocol.md, Heartbeats); lengthen it (and"
            " safety.max_link_silence with it) or raise the baud",
        )
    ]


def state_wire_bytes(desc: Workable) -> int:
    """A STATE frame of the description's layout on the wire (docs/protocol.md, Budget
    of one cycle): header 5, ack_seq 2, fresh mask, board status nibbles, 2 bytes a
    channel, CRC 2, COBS 1 and a delimiter (the link's own figure, which the tests hold
    equal to this one)."""
    channels = sum(len(s.channel_names()) for b in desc.boards for s in b.sensors) + sum(
        (m.feedback.velocity is not None) + (m.feedback.current is not None)
        for b in desc.boards
        for m in b.motors
    )
    payload = 2 + (channels + 7) // 8 + (len(desc.boards) + 1) // 2 + 2 * channels
    body = 5 + payload + 2
    return body + (body + 253) // 254 + 1


def state_line_problems(desc: Workable) -> list[tuple[KeyPath, str]]:
    """A bridge sends a STATE each period, or as often as its line carries one when
    the frame takes longer: then no reading can be fresher than that, and one whose
    freshness limit (``safety.stale_after_periods`` x its period, the state period for
    a motor's feedback) is no longer goes stale between two frames on the bridge,
    where the simulator, which has no line, keeps it fresh."""
    line_s = state_wire_bytes(desc) * 10 / desc.bridge.baud
    if line_s <= desc.bridge.state_period:
        return []
    factor = desc.safety.stale_after_periods
    limits = [(factor * s.period, s.name) for b in desc.boards for s in b.sensors]
    if any(m.feedback.velocity or m.feedback.current for b in desc.boards for m in b.motors):
        limits.append((factor * desc.bridge.state_period, "a motor's feedback"))
    limit, name = min(limits, key=lambda item: item[0], default=(math.inf, ""))
    if limit > line_s:
        return []
    shown = name if name.startswith("a motor") else repr(name)
    return [
        (
            ("bridge", "baud"),
            f"a STATE frame of {state_wire_bytes(desc)} bytes takes {_fmt_ms(line_s)} at"
            f" {desc.bridge.baud} baud, so the bridge can send one only that often, and"
            f" readings of {shown} count as stale after {_fmt_ms(limit)}"
            " (safety.stale_after_periods x its period): every run on the bridge would stop"
            " on stale data; raise the baud",
        )
    ]


def board_poll_problems(desc: Workable) -> list[tuple[KeyPath, str]]:
    """The bridge polls each board once a state period, and a board stops itself after
    :data:`BOARD_SILENCE_S` without a poll: a state period of half that time or less
    leaves a poll room to run late in its period without stopping the robot."""
    period = desc.bridge.state_period
    most = BOARD_SILENCE_S / 2
    if period <= most * (1 + 1e-9):
        return []
    return [
        (
            ("bridge", "state_period"),
            f"a state period of {_fmt_ms(period)} is too long for the boards: the bridge"
            " polls each board once a state period, and a PICO board stops itself after"
            f" {_fmt_ms(BOARD_SILENCE_S)} without a poll (docs/board-bus.md, Board-side"
            " timeout), on which the bridge stops the whole robot; make it at most"
            f" {_fmt_ms(most)}, half that time, so that a poll running late stops nothing",
        )
    ]


def position_sensor_problems(desc: Workable, told: set[KeyPath]) -> list[tuple[KeyPath, str]]:
    """A motor with a ``position`` mode needs an angle sensor on its own board and slot:
    the board closes the position loop on it, and without one brakes the motor on
    every position setpoint (docs/board-bus.md, Modes on the board). A joint whose
    sensor the fitness rules already placed (``told``: its board and motor path) is not
    told twice."""
    out: list[tuple[KeyPath, str]] = []
    for b, board in enumerate(desc.boards):
        for j, motor in enumerate(board.motors):
            if motor.modes.position is None or ("boards", b, "motors", j) in told:
                continue
            if any(s.slot == motor.slot and s.kind is SensorKind.ANGLE for s in board.sensors):
                continue
            out.append(
                (
                    ("boards", b, "motors", j, "modes", "position"),
                    f"motor {motor.name!r} (board {board.id}, slot {motor.slot}) has a"
                    f" position mode, but its board has no angle sensor on slot"
                    f" {motor.slot}: the board closes the position loop on the angle sensor"
                    " of the motor's own slot, and without one brakes the motor on every"
                    f" position setpoint; put an angle sensor on slot {motor.slot} of board"
                    f" {board.id}, or remove the position mode",
                )
            )
    return out


def velocity_loop_problems(desc: Workable) -> list[tuple[KeyPath, str]]:
    """A motor with a ``velocity`` mode needs what its board's speed loop reads: the
    wheel's speed, from encoder counts through its module's ``wheel_radius``, in the
    unit of its ``feedback.velocity``. The reference PICO, without either, reads a speed
    of 0, and its loop winds up to full duty whatever speed is asked."""
    out: list[tuple[KeyPath, str]] = []
    radius = {m.name: m.wheel_radius for m in desc.modules}
    for b, board in enumerate(desc.boards):
        for j, motor in enumerate(board.motors):
            if motor.modes.velocity is None:
                continue
            lacks = []
            if motor.feedback.velocity is None:
                lacks.append("it has no velocity feedback")
            if radius.get(board.module) is None:
                lacks.append(f"its module {board.module!r} has no wheel_radius")
            if lacks:
                out.append(
                    (
                        ("boards", b, "motors", j, "modes", "velocity"),
                        f"motor {motor.name!r} has a velocity mode, but {' and '.join(lacks)}:"
                        " its board's speed loop works the wheel's speed out of the"
                        " wheel_radius, in feedback.velocity's unit, and without"
                        f" {'them' if len(lacks) > 1 else 'it'} reads 0 and drives at full"
                        " duty whatever speed is asked",
                    )
                )
    return out


def _fmt_ms(seconds: float) -> str:
    return f"{seconds * 1000:.4g} ms"
