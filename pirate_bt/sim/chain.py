"""The whole embedded chain in simavr: the bridge and every PICO board, each its own ELF.

The PIRATEbay firmware (``firmware/piratebay/``) on a simulated ATmega2560 and the
reference PICO firmware (``firmware/pico/``) on one simulated ATmega328p per board,
all on one simulated RS485 line, run by the ``pirate-chain`` harness
(``firmware/simavr/chain.c``). Behind the PICO boards' pins is the pipe physics of
:class:`~pirate_bt.sim.model.PipeRobotModel`: :class:`ChainPhysics` turns each
H-bridge's output (off, brake, or a signed duty) into the model's motor command and
the model's readings into the boards' inputs (ADC readings, encoder edges, the IMU's
registers), so every loop a board closes is closed through its own firmware.

Ten cores cannot run in step at 16 MHz in real time on a modest machine, so the chain
runs in **virtual time**: nothing moves between steps, and the host reaches the
bridge through an in-process port (``chain://NAME``, like ``sim://``) on a
:class:`~pirate_bt.clock.SimClock`: whenever the host waits on the clock, the chain
steps by the same time. :meth:`FirmwareChain.figures` reports how fast that went
against the wall clock.

Records between the harness and this module are documented at the top of
``firmware/simavr/chain.c``.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import math
import os
import struct
import subprocess
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import serial

from pirate_bt.clock import SimClock
from pirate_bt.errors import ConfigurationError, InputError, LinkError
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, MotorFunction, RobotDescription
from pirate_bt.robot.header import board_io
from pirate_bt.sim.chain_elf import CPR_SYMBOL, check_built_for, elf_u32
from pirate_bt.sim.model import PipeRobotModel

__all__ = [
    "CHAIN_HARNESS_ENV",
    "CHAIN_SCHEME",
    "PICO_ENCODER_CPR",
    "ChainPhysics",
    "FirmwareChain",
    "StopTimes",
    "find_chain_harness",
    "lookup_chain",
    "watched_motors",
]

_log = logging.getLogger(__name__)

HZ = 16_000_000
CHAIN_SCHEME = "chain"
"""URL scheme of in-process chains: ``chain://NAME``."""
CHAIN_HARNESS_ENV = "PIRATE_CHAIN"
"""Environment variable naming the chain harness (default: the repository's build)."""
PICO_ENCODER_CPR = 3072
"""Encoder counts per wheel revolution: the PICO firmware's ``ENCODER_CPR`` build option."""
OFF, BRAKE, RUN = 0, 1, 2
HOST_BYTES_PER_STEP = 16_384
"""Host bytes sent to the harness with one step at most (1.4 s of a 115200-baud line;
its queue to the bridge's USART0 holds 64 KB and takes what fits, the rest waits here)."""

_REPO = Path(__file__).resolve().parents[2]
_REGISTRY: dict[str, FirmwareChain] = {}
_REGISTRY_LOCK = threading.Lock()
_NAMES = itertools.count(1)

if "pirate_bt.sim" not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append("pirate_bt.sim")


def find_chain_harness(path: str | os.PathLike[str] | None = None) -> Path:
    """The chain harness: ``path``, ``$PIRATE_CHAIN``, or the repository's build.

    Raises:
        ConfigurationError: it is not built (with the command that builds it).
    """
    chosen = path or os.environ.get(CHAIN_HARNESS_ENV)
    candidate = Path(chosen) if chosen else _REPO / "firmware" / "simavr" / "build" / "pirate-chain"
    if not candidate.is_file() or not os.access(candidate, os.X_OK):
        raise ConfigurationError(
            f"the chain harness is not built ({candidate} missing): run `make firmware`"
            " (needs libsimavr-dev and pkg-config)"
        )
    return candidate


def lookup_chain(name: str) -> FirmwareChain:
    """The open chain called ``name`` (the NAME of ``chain://NAME``).

    Raises:
        KeyError: none of that name in this process.
    """
    with _REGISTRY_LOCK:
        found = _REGISTRY.get(name)
    if found is None:
        raise KeyError(f"no firmware chain named {name!r} in this process")
    return found


@dataclass(frozen=True)
class _Motor:
    name: str
    function: MotorFunction
    free_mps: float  # a drive's wheel speed at full duty (the top of its velocity range)


@dataclass(frozen=True)
class _Channel:
    index: int
    source: str
    slot: int
    lo: int
    hi: int
    zero: int
    scale_q16: int


class ChainPhysics:
    """The pipe physics behind the PICO boards' pins.

    Outputs to the model, per motor: off (the H-bridge off) makes the motor limp; a
    brake is ``pwm 0``; a duty d of 255 is, for a drive, a wheel speed of d/255 of the
    top of its velocity range (a DC motor's no-load speed grows with its voltage), for
    a joint ``pwm d/255`` (the model moves it at its rate limit with d/255 of its stall
    torque). Inputs from the model: every channel's raw value, as ADC readings (the
    board's ADC spans the channel's raw range), IMU registers (1/16 degree) and
    encoder counts (the wheel's travel / its circumference x counts per revolution).

    Args:
        model: The robot in the pipe.
        encoder_cpr: Encoder counts per wheel revolution (the PICO's ``ENCODER_CPR``).
    """

    def __init__(self, model: PipeRobotModel, *, encoder_cpr: int = PICO_ENCODER_CPR) -> None:
        robot = model.robot
        self.model = model
        self.robot = robot
        self.boards = robot.board_ids()
        self.encoder_cpr = encoder_cpr
        channels, motors_io = board_io(robot)
        specs = robot.state_channels()
        self._conversions = [
            (s.conversion.zero_raw, s.conversion.per_raw, *s.conversion.raw) for s in specs
        ]
        self._channels: dict[int, list[_Channel]] = {b: [] for b in self.boards}
        for c in channels:
            self._channels[self.boards[c.board_index]].append(
                _Channel(c.index, c.source, c.slot, c.raw_lo, c.raw_hi, c.zero_raw, c.scale_q16)
            )
        self._motors: dict[tuple[int, int], _Motor] = {}
        self._circumference: dict[tuple[int, int], float] = {}
        for slot, io in zip(robot.setpoint_slots(), motors_io, strict=True):
            motor = slot.motor
            velocity = motor.modes.velocity
            free = max(velocity.si_range) if velocity is not None else 0.0
            self._motors[(slot.board, slot.slot)] = _Motor(motor.name, motor.function, free)
            self._circumference[(slot.board, slot.slot)] = io.circumference_um * 1e-6
        self._velocity_index = {
            (self.boards[c.board_index], c.slot): c.index
            for c in channels
            if c.source == "velocity"
        }
        self._counts: dict[tuple[int, int], float] = dict.fromkeys(self._motors, 0.0)
        self._last: dict[tuple[int, int], tuple[int, int]] = {}
        self._values = model.reading_values()

    def apply(self, outputs: dict[tuple[int, int], tuple[int, int]]) -> None:
        """The H-bridges' outputs ((board, slot) -> (drive, mean duty)) into the model."""
        for key, (drive, duty) in outputs.items():
            motor = self._motors.get(key)
            if motor is None or self._last.get(key) == (drive, duty):
                continue
            self._last[key] = (drive, duty)
            if drive == OFF:
                self.model.motors_off([motor.name])
            elif drive == BRAKE:
                self.model.command(MotorCommand(motor.name, ControlMode.PWM, 0.0))
            elif motor.function is MotorFunction.DRIVE:
                speed = duty / 255 * motor.free_mps
                self.model.command(MotorCommand(motor.name, ControlMode.VELOCITY, speed))
            else:
                self.model.command(MotorCommand(motor.name, ControlMode.PWM, duty / 255))

    def step(self, dt_s: float) -> None:
        """Advance the model; integrate the wheels' travel into encoder counts."""
        self.model.step(dt_s)
        values = self.model.reading_values()
        for key, index in self._velocity_index.items():
            circumference = self._circumference.get(key, 0.0)
            if circumference > 0:
                self._counts[key] += values[index] * dt_s / circumference * self.encoder_cpr
        self._values = values

    def raw(self, index: int) -> int:
        zero, per_raw, lo, hi = self._conversions[index]
        value = self._values[index]
        raw = round(value / per_raw + zero) if math.isfinite(value) else zero
        return lo if raw < lo else hi if raw > hi else raw

    def inputs(self, board: int) -> bytes:
        """This board's pin inputs for the next step, as the harness's record wants them."""
        adc = [0, 0, 0, 0]
        imu = [0, 0, 0]
        for c in self._channels[board]:
            if c.source in ("adc", "current"):
                reading = (self.raw(c.index) - c.lo) * 1024 // (c.hi - c.lo + 1)
                adc[c.slot if c.source == "adc" else 2 + c.slot] = max(0, min(1023, reading))
            elif c.source.startswith("imu_") and c.scale_q16:
                lsb = round((self.raw(c.index) - c.zero) * 65536 / c.scale_q16)
                if c.source == "imu_yaw":  # a BNO055's heading: 0..360 degrees clockwise
                    imu[0] = -lsb % 5760
                else:
                    axis = {"imu_roll": 1, "imu_pitch": 2}[c.source]
                    imu[axis] = max(-32768, min(32767, lsb))
        encoders = [round(self._counts.get((board, slot), 0.0)) for slot in (0, 1)]
        return struct.pack("<4H2i3hB", *adc, *encoders, *imu, 0)


@dataclass(frozen=True)
class StopTimes:
    """How long after a stop's cause every watched motor's H-bridge stopped driving.

    Attributes:
        cause: What started the clock: ``"host"`` (the ``ESTOP`` frame's last byte
            entered the bridge), ``"input"`` (the e-stop contact opened) or
            ``"master_silent"`` (the bridge's core was halted).
        per_motor_s: (board, slot) -> seconds to its first off or brake output.
    """

    cause: str
    per_motor_s: dict[tuple[int, int], float]

    @property
    def all_stopped_s(self) -> float:
        """The time to the last of them."""
        return max(self.per_motor_s.values())


class FirmwareChain:
    """The bridge and the PICO boards, each running its own ELF in simavr, in virtual time.

    Args:
        bridge_elf: ``firmware/piratebay/build/piratebay.elf``.
        pico_elf: ``firmware/pico/build/pico.elf``.
        model: The robot in the pipe behind the boards' pins.
        clock: The host's clock: the chain steps whenever it advances (default: a new one).
        harness: The ``pirate-chain`` executable (default: :func:`find_chain_harness`).
        step_s: Physics step (and the boards' inputs' refresh), default 1 ms.
        name: Registry name, the NAME of ``chain://NAME``.

    Raises:
        InputError: an ELF is missing, or built for another robot description.
        ConfigurationError: the harness is not built.
    """

    def __init__(
        self,
        bridge_elf: str | os.PathLike[str],
        pico_elf: str | os.PathLike[str],
        model: PipeRobotModel,
        *,
        clock: SimClock | None = None,
        harness: str | os.PathLike[str] | None = None,
        step_s: float = 0.001,
        name: str | None = None,
    ) -> None:
        for elf in (bridge_elf, pico_elf):
            if not Path(elf).is_file():
                raise InputError(f"{elf}: no such firmware ELF (build it with `make firmware`)")
            check_built_for(elf, model.robot)  # boards of another layout: refused here
        self.harness = find_chain_harness(harness)
        # the encoder resolution the PICO was built with (make firmware ENCODER_CPR=...):
        # the physics counted 3072 a revolution whatever it was, so speeds were off by
        # the ratio; an ELF that does not say is taken to have the default
        cpr = elf_u32(pico_elf, CPR_SYMBOL)
        self.physics = ChainPhysics(model, encoder_cpr=cpr or PICO_ENCODER_CPR)
        self.robot: RobotDescription = model.robot
        self.clock = clock if clock is not None else SimClock()
        self.step_cycles = round(step_s * HZ)
        self.cycle = 0
        self._start_s = self.clock.now()
        self._in = bytearray()
        self._out = bytearray()
        self._lock = threading.RLock()
        self._watch: StopTimes | None = None
        self._watch_keys: list[tuple[int, int]] = []
        self._watch_cause = ""
        self.wall_s = 0.0
        cmd = [str(self.harness), str(bridge_elf), str(pico_elf), *map(str, self.physics.boards)]
        try:
            self._proc = subprocess.Popen(
                cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE
            )
        except OSError as exc:
            raise LinkError(f"cannot run the chain harness {self.harness}: {exc}") from exc
        assert self._proc.stdout is not None and self._proc.stdin is not None
        self._stdout: IO[bytes] = self._proc.stdout
        self._stdin: IO[bytes] = self._proc.stdin
        kind, payload = self._record()
        if kind != ord("P"):
            raise LinkError(f"the chain harness did not start: {self._stderr()}")
        self.name = name or f"chain-{next(_NAMES)}"
        with _REGISTRY_LOCK:
            if self.name in _REGISTRY:
                raise ConfigurationError(f"a chain named {self.name!r} is already open")
            _REGISTRY[self.name] = self
        self.clock.add_listener(self._on_clock)
        self._closed = False
        _log.info("firmware chain %s: %s", self.name, payload.decode())

    @property
    def url(self) -> str:
        """The pyserial URL of the bridge's host port (``chain://NAME``)."""
        return f"{CHAIN_SCHEME}://{self.name}"

    @property
    def now_s(self) -> float:
        """The chain's time since its start (the cores' cycle count / 16 MHz)."""
        return self.cycle / HZ

    # -- records ------------------------------------------------------------------------

    def _stderr(self) -> str:
        proc = self._proc
        if proc.poll() is None:
            return "no answer"
        err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
        return err.strip().splitlines()[-1] if err.strip() else f"exit {proc.returncode}"

    def _record(self) -> tuple[int, bytes]:
        head = self._stdout.read(3)
        if len(head) < 3:
            raise LinkError(f"the chain harness stopped: {self._stderr()}")
        n = head[1] | head[2] << 8
        payload = self._stdout.read(n) if n else b""
        return head[0], payload

    def _send(self, kind: str, payload: bytes = b"") -> None:
        try:
            self._stdin.write(bytes((ord(kind),)) + len(payload).to_bytes(2, "little") + payload)
            self._stdin.flush()
        except (BrokenPipeError, OSError) as exc:
            raise LinkError(f"the chain harness stopped: {self._stderr()}") from exc

    # -- time ---------------------------------------------------------------------------

    def _on_clock(self, now_s: float) -> None:
        self.advance_to(now_s - self._start_s)

    def advance_to(self, t_s: float) -> None:
        """Run the chain and the physics, step by step, up to its time ``t_s``."""
        with self._lock:
            target = round(t_s * HZ)
            while self.cycle + self.step_cycles <= target:
                self._step(self.cycle + self.step_cycles)

    def _step(self, until: int) -> None:
        started = time.perf_counter()
        physics = self.physics
        # a record's length is a u16: a host that wrote more since the last step (faster
        # than the line) has the rest sent in later steps, as a serial driver holds it
        host = bytes(self._in[:HOST_BYTES_PER_STEP])
        payload = bytearray(struct.pack("<QH", until, len(host)))
        payload += host
        for board in physics.boards:
            payload += physics.inputs(board)
        self._send("A", bytes(payload))
        while True:
            kind, data = self._record()
            if kind == ord("a"):
                break
            if kind == ord("w"):
                self._watch_done(data)
        self.cycle = struct.unpack_from("<Q", data)[0]
        n = struct.unpack_from("<H", data, 8)[0]
        self._out += data[10 : 10 + n]
        outputs: dict[tuple[int, int], tuple[int, int]] = {}
        at = 10 + n
        for board in physics.boards:
            for slot in (0, 1):
                drive, duty = struct.unpack_from("<Bh", data, at)
                outputs[(board, slot)] = (drive, duty)
                at += 3
        # the host bytes the harness's queue to the line took; the others wait here
        taken = struct.unpack_from("<H", data, at)[0] if len(data) >= at + 2 else len(host)
        del self._in[:taken]
        self.outputs = outputs
        physics.apply(outputs)
        physics.step(self.step_cycles / HZ)
        self.wall_s += time.perf_counter() - started

    # -- the host's port ------------------------------------------------------------------

    def write(self, data: bytes) -> None:
        """Bytes from the host to the bridge (fed at the line's rate)."""
        with self._lock:
            self._in += data

    def read(self, size: int = -1) -> bytes:
        """Bytes the bridge sent to the host (up to ``size``; all when negative)."""
        with self._lock:
            if size < 0 or size >= len(self._out):
                data = bytes(self._out)
                self._out.clear()
            else:
                data = bytes(self._out[:size])
                del self._out[:size]
            return data

    @property
    def in_waiting(self) -> int:
        return len(self._out)

    # -- what a test does to the chain ------------------------------------------------------

    def set_estop_input(self, pressed: bool) -> None:
        """Open (``pressed``) or close the bridge's hardware e-stop contact (D22)."""
        with self._lock:
            self._send("E", bytes((int(pressed),)))

    def halt_bridge(self) -> None:
        """Kill the bridge: its core stops and never drives the bus again."""
        with self._lock:
            self._send("K")

    def power_board(self, board: int, on: bool) -> None:
        """Cut the power of PICO ``board`` (its core stops, off the line, its motors limp),
        or give it back (a power-on reset: a cold boot, its id kept in its EEPROM)."""
        index = self.physics.boards.index(board)
        with self._lock:
            self._send("O", bytes((index, int(on))))

    def watch_stops(self, cause: str, motors: Sequence[tuple[int, int]]) -> None:
        """Start timing until every motor in ``motors`` ((board, slot)) stops driving.

        Args:
            cause: ``"host"``: from the next host frame's last byte entering the
                bridge (send the ``ESTOP`` right after); ``"input"`` or
                ``"master_silent"``: from now (press the input, or halt the bridge,
                right after). The result is :attr:`stop_times` once all have stopped.
        """
        index = {b: i for i, b in enumerate(self.physics.boards)}
        with self._lock:
            self._watch = None
            self._watch_keys = list(motors)
            self._watch_cause = cause
            queued = min(255, bytes(self._in).count(0))  # frames written, not yet sent
            payload = bytes((0 if cause == "host" else 1, queued, len(motors)))
            payload += b"".join(bytes((index[b], s)) for b, s in motors)
            self._send("W", payload)

    def _watch_done(self, data: bytes) -> None:
        start = struct.unpack_from("<Q", data)[0]
        times = [struct.unpack_from("<Q", data, 8 + 8 * k)[0] for k in range(len(self._watch_keys))]
        self._watch = StopTimes(
            self._watch_cause,
            {key: (t - start) / HZ for key, t in zip(self._watch_keys, times, strict=True)},
        )

    @property
    def stop_times(self) -> StopTimes | None:
        """The last watch's result, once every watched motor has stopped."""
        return self._watch

    def figures(self) -> dict[str, float]:
        """The harness's figures: line, bus cycle, stacks, boards' counters, speed."""
        with self._lock:
            self._send("Q")
            while True:
                kind, data = self._record()
                if kind == ord("S"):
                    break
                if kind == ord("w"):
                    self._watch_done(data)
        out: dict[str, float] = {}
        for line in data.decode(errors="replace").splitlines():
            key, _, value = line.partition(" ")
            with contextlib.suppress(ValueError):
                out[key] = float(value)
        out["python_wall_s"] = self.wall_s
        out["chain_speed_vs_real_time"] = self.now_s / self.wall_s if self.wall_s else 0.0
        return out

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called: a ``chain://`` port to it then fails as a
        device unplugged does."""
        return bool(getattr(self, "_closed", True))

    def close(self) -> None:
        """Stop the harness and free the name (idempotent)."""
        if getattr(self, "_closed", True):
            return
        self._closed = True
        self.clock.remove_listener(self._on_clock)
        with _REGISTRY_LOCK:
            if _REGISTRY.get(self.name) is self:
                del _REGISTRY[self.name]
        with contextlib.suppress(OSError):
            self._stdin.close()
        try:
            self._proc.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()

    def __enter__(self) -> FirmwareChain:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def watched_motors(robot: RobotDescription, roles: Iterable[str]) -> list[tuple[int, int]]:
    """(board, slot) of every motor whose stop role is one of ``roles``."""
    from pirate_bt.link.layout import stop_role

    wanted = set(roles)
    return [(s.board, s.slot) for s in robot.setpoint_slots() if stop_role(s.motor).value in wanted]
