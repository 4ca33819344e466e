"""The PICO boards on the RS485 board bus, for the bridge firmware running in simavr.

In board-bus mode the bridge is not simulated in Python: the real PIRATEbay
firmware runs in an AVR simulator (``firmware/simavr/``, the *harness*), and only
the boards behind it are Python. :class:`BoardBus` answers the firmware's bus
requests (``docs/board-bus.md``, version 2) with the same pipe physics as the
Python simulator, :class:`~pirate_bt.sim.model.PipeRobotModel`: an ``EXCHANGE``
applies the board's setpoints (raw -> SI with the robot's own
:class:`~pirate_bt.robot.commands.CommandCodec`) and returns its status and its slice
of the readings (SI -> raw with :class:`~pirate_bt.robot.state.StateBuilder`); a
``STOP`` applies its setpoints silently and ends a board's own stop. A board that
hears nothing from the master for :data:`BOARD_SILENCE_S` stops itself (drives
braked, joints holding) and holds that stop until a ``STOP``, reporting
``OWN_STOP`` meanwhile, as the reference PICO firmware (``firmware/pico/``) does:
both pass the same byte-level vectors (``tests/data/board_bus_vectors.json``,
:mod:`pirate_bt.sim.board_vectors`).

Time comes from the AVR: every bus frame carries the MCU cycle at which its last
byte left, and the physics steps one state period at a time up to that instant,
so the pipe moves in step with the firmware's clock even when the host machine
cannot keep simavr in real time.

:class:`FirmwareBridge` runs the harness as a child process and serves its board
bus from a thread. The channel is the harness's stdin/stdout, records of
``type u8, length u16 LE, payload`` (documented in ``firmware/simavr/harness.c``):
the harness sends ``P`` (the host pty's path), ``F`` (a bus frame and its cycle;
not sent when it repeats the last frame to that board byte for byte), ``T`` (the
MCU's cycle count, every 10 ms), ``R`` (an MCU reset) and ``S`` (figures); it
receives ``U`` (a board's current reply), ``Q`` (ask for figures), ``X``
(reset the MCU, as a DTR edge does), ``H`` and ``G`` (hold the MCU's clock, and
go on).

The harness answers an ``EXCHANGE`` itself, at once, with the board's latest
reply; this module refreshes every board's reply once per state period, after
the physics step. So the firmware never waits on Python (a round trip per poll,
900 a second, would not keep simavr in real time on a loaded machine), and the
readings a board returns are at most one period old, as a real board's samples
are; setpoints reach the physics as the frames stream in, a few ms later at most.
"""

from __future__ import annotations

import contextlib
import logging
import os
import queue
import struct
import subprocess
import threading
import time
from collections import Counter
from collections.abc import Iterable
from pathlib import Path
from typing import IO

from pirate_bt.errors import ConfigurationError, FrameError, InputError, LinkError
from pirate_bt.link.codec import MODE_CODES, MODE_KEEP, cobs_decode, cobs_encode, crc16
from pirate_bt.link.layout import StopRole, stop_role
from pirate_bt.robot.commands import CommandCodec, RawSetpoint
from pirate_bt.robot.description import ControlMode, Motor, RobotDescription
from pirate_bt.robot.state import StateBuilder
from pirate_bt.sim.model import PipeRobotModel

__all__ = [
    "BOARD_SILENCE_S",
    "BUS_CLOCK_HZ",
    "CMD_EXCHANGE",
    "CMD_STOP",
    "HARNESS_ENV",
    "STATUS_FAULT",
    "STATUS_MOTORS_OFF",
    "STATUS_OWN_STOP",
    "BoardBus",
    "FirmwareBridge",
    "find_harness",
]

_log = logging.getLogger(__name__)

BUS_CLOCK_HZ = 16_000_000
"""The ATmega2560's clock: bus frames are stamped in its cycles."""

CMD_EXCHANGE = 0x01
CMD_STOP = 0x02
STATUS_FAULT = 0x01
STATUS_MOTORS_OFF = 0x02
"""A motor of the board was never commanded since its boot (it coasts)."""
STATUS_OWN_STOP = 0x04
"""The board stopped itself (the master fell silent) and holds that stop until a STOP."""
BOARD_SILENCE_S = 0.1
"""A board that hears no frame addressed to it for this long stops itself."""
_REPLY = 0x80
_MAX_BODY = 32
_MODE_BY_CODE = {code: mode for mode, code in MODE_CODES.items()}

HARNESS_ENV = "PIRATE_SIMAVR"
"""Environment variable naming the harness executable (default: the repository's build)."""

_REPO_HARNESS = Path(__file__).resolve().parents[2] / "firmware" / "simavr" / "build"


class BoardBus:
    """The robot's PICO boards: bus requests in, bus replies out, physics in step.

    Args:
        model: The robot-in-pipe model the boards drive and read.
        silent: Board ids that never answer (a disconnected board).
        board_timeout: Boards stop themselves after :data:`BOARD_SILENCE_S` without a
            frame addressed to them. Off behind the real-time simavr harness, which
            answers a repeated exchange itself and does not pass it on.
    """

    def __init__(
        self, model: PipeRobotModel, *, silent: Iterable[int] = (), board_timeout: bool = True
    ) -> None:
        robot = model.robot
        self.model = model
        self.robot = robot
        self.period_s = robot.bridge.state_period
        self._commands = CommandCodec(robot)
        self._states = StateBuilder(robot)
        channels = robot.state_channels()
        self._slots: dict[int, list[int]] = {b: [] for b in robot.board_ids()}
        self._motors: dict[tuple[int, int], Motor] = {}
        for slot in robot.setpoint_slots():
            self._slots[slot.board].append(slot.slot)
            self._motors[(slot.board, slot.slot)] = slot.motor
        self._channel_range: dict[int, tuple[int, int]] = {}
        for i, channel in enumerate(channels):
            lo, _ = self._channel_range.get(channel.board, (i, i))
            self._channel_range[channel.board] = (lo, i + 1)
        self.silent: set[int] = set(silent)
        self.now_s = model.time_s
        self.board_timeout = board_timeout
        self.own_stop: set[int] = set()
        """Boards holding their own stop (the master fell silent), until a STOP."""
        self.own_stops = 0
        self._heard_s = dict.fromkeys(self._slots, self.now_s)
        self._state: dict[tuple[int, int], tuple[int, int]] = {}
        self._pinned: dict[int, list[int]] = {}
        self._next_step_s = self.now_s + self.period_s
        self._raw: list[int] | None = None
        self.steps = 0
        # figures: the frames this object handled. Behind the simavr harness that is
        # not every frame on the bus (a frame repeating the last one to its board is
        # not forwarded); the harness's own figures (bus_replies, bus_stops) count all.
        self.exchanges = 0
        self.stops = 0
        self.bad_frames = 0
        self.unanswered = 0
        self.setpoints_applied = 0
        self.applied: Counter[tuple[int, int, int, int]] = Counter()
        """(board, slot, mode code, raw value) of every setpoint applied, with counts."""

    def advance_to(self, now_s: float) -> None:
        """Step the physics, one state period at a time, up to ``now_s``; boards that
        heard no master for :data:`BOARD_SILENCE_S` stop themselves on the way."""
        while self._next_step_s <= now_s + 1e-12:
            self._check_silence(self._next_step_s)
            self.model.step(self.period_s)
            self._next_step_s += self.period_s
            self._raw = None
            self.steps += 1
        self.now_s = max(self.now_s, now_s)
        self._check_silence(self.now_s)

    def _check_silence(self, now_s: float) -> None:
        if not self.board_timeout:
            return
        for board, heard in self._heard_s.items():
            if board not in self.own_stop and now_s - heard > BOARD_SILENCE_S + 1e-9:
                self.own_stop.add(board)
                self.own_stops += 1
                self._raw = None
                self._stop_board(board)
                _log.info("board %d heard no master for %.3f s: own stop", board, now_s - heard)

    def _stop_board(self, board: int) -> None:
        """The stop category in the board's own modes: brake, joints hold."""
        for slot in self._slots[board]:
            motor = self._motors[(board, slot)]
            role = stop_role(motor)
            if role is StopRole.BEND:
                continue
            if motor.modes.pwm is not None:
                self._command(board, slot, MODE_CODES[ControlMode.PWM], 0)
            elif role is StopRole.DRIVE:
                self._command(board, slot, MODE_CODES[ControlMode.VELOCITY], 0)

    def handle(self, now_s: float, encoded: bytes) -> bytes:
        """One frame from the bridge (COBS, no delimiter) at ``now_s``; the wire reply or b"".

        A frame that does not decode, fails its CRC, is addressed to no board or
        carries a payload of the wrong length is ignored, as a board would.
        """
        self.advance_to(now_s)
        try:
            body = cobs_decode(encoded)
        except FrameError:
            self.bad_frames += 1
            return b""
        if (
            len(body) < 4
            or len(body) > _MAX_BODY
            or crc16(body[:-2]) != int.from_bytes(body[-2:], "little")
        ):
            self.bad_frames += 1
            return b""
        addr, cmd, payload = body[0], body[1], body[2:-2]
        slots = self._slots.get(addr)
        if slots is None or cmd not in (CMD_EXCHANGE, CMD_STOP) or len(payload) != 3 * len(slots):
            self.bad_frames += 1
            return b""
        if addr in self.silent:
            self.unanswered += 1
            return b""
        self._heard_s[addr] = now_s
        if cmd == CMD_STOP:
            self.own_stop.discard(addr)  # the master took over the stop
            self._apply(addr, slots, payload)
            self.stops += 1
            return b""
        if addr not in self.own_stop:
            self._apply(addr, slots, payload)
        self.exchanges += 1
        return self._reply(addr)

    def _apply(self, board: int, slots: list[int], payload: bytes) -> None:
        for slot, (code, raw_value) in zip(slots, struct.iter_unpack("<Bh", payload), strict=True):
            if code != MODE_KEEP:
                self._command(board, slot, code, raw_value)

    def _command(self, board: int, slot: int, code: int, raw_value: int) -> None:
        mode = _MODE_BY_CODE.get(code)
        conversion = None if mode is None else self._motors[(board, slot)].modes.get(mode)
        if mode is None or conversion is None:
            _log.warning("board %d slot %d: mode code %d refused", board, slot, code)
            return
        lo, hi = conversion.raw
        if not lo <= raw_value <= hi:
            _log.warning(
                "board %d slot %d: %d outside %d..%d refused", board, slot, raw_value, lo, hi
            )
            return
        try:
            command = self._commands.to_si(RawSetpoint(board, slot, mode, raw_value))
        except InputError as exc:
            _log.warning("board %d: %s", board, exc)
            return
        self.model.command(command)
        self._state[(board, slot)] = (code, raw_value)
        self.setpoints_applied += 1
        self.applied[(board, slot, code, raw_value)] += 1

    def motor_state(self, board: int, slot: int) -> tuple[int, int] | None:
        """(mode code, raw value) motor ``slot`` of ``board`` executes; None: never commanded."""
        return self._state.get((board, slot))

    def status(self, board: int) -> int:
        """The status byte of ``board``'s reply (``STATUS_*`` bits)."""
        status = 0
        if any((board, slot) not in self._state for slot in self._slots[board]):
            status |= STATUS_MOTORS_OFF
        if board in self.own_stop:
            status |= STATUS_OWN_STOP
        return status

    def set_readings(self, board: int, raw: Iterable[int] | None) -> None:
        """Pin ``board``'s replies to these raw channel values (None: the physics again).

        For the shared vectors, where a reply's bytes are given.
        """
        if raw is None:
            self._pinned.pop(board, None)
        else:
            self._pinned[board] = list(raw)

    def raw_readings(self) -> list[int]:
        """Every state channel's raw value now, in layout order (computed once per period)."""
        if self._raw is None:
            encoded = self._states.encode(self.model.readings())
            self._raw = [0 if v is None else v for v in encoded]
        return self._raw

    def replies(self) -> dict[int, bytes]:
        """Every board's reply to an EXCHANGE now (wire bytes; b"" for a silent board)."""
        return {b: b"" if b in self.silent else self._reply(b) for b in self._slots}

    def _reply(self, board: int) -> bytes:
        lo, hi = self._channel_range.get(board, (0, 0))
        readings = self._pinned.get(board) or self.raw_readings()[lo:hi]
        body = bytes((board, CMD_EXCHANGE | _REPLY, self.status(board))) + struct.pack(
            f"<{len(readings)}h", *readings
        )
        body += crc16(body).to_bytes(2, "little")
        return cobs_encode(body) + b"\x00"


def find_harness(path: str | os.PathLike[str] | None = None) -> Path:
    """The simavr harness executable: ``path``, ``$PIRATE_SIMAVR``, or the repository's build.

    Raises:
        ConfigurationError: it is not there (with the command that builds it).
    """
    chosen = path or os.environ.get(HARNESS_ENV)
    candidate = Path(chosen) if chosen else _REPO_HARNESS / "pirate-simavr"
    if not candidate.is_file() or not os.access(candidate, os.X_OK):
        raise ConfigurationError(
            f"the simavr harness is not built ({candidate} missing): run"
            " `make -C firmware/simavr` (needs libsimavr-dev and pkg-config)"
        )
    return candidate


class FirmwareBridge:
    """The bridge firmware in simavr behind a pty, with Python boards on its bus.

    Args:
        elf: The firmware (``firmware/piratebay/build/piratebay.elf``).
        model: The robot-in-pipe model behind the boards.
        harness: The harness executable (default: :func:`find_harness`).
        boot_ms: How long the MCU stays in its bootloader after a DTR reset.
        speed: Simulated seconds per wall second (1.0 = real time).
        silent: Board ids that never answer.

    Raises:
        InputError: the ELF is missing.
        ConfigurationError: the harness is not built.
    """

    def __init__(
        self,
        elf: str | os.PathLike[str],
        model: PipeRobotModel,
        *,
        harness: str | os.PathLike[str] | None = None,
        boot_ms: int = 0,
        speed: float = 1.0,
        silent: Iterable[int] = (),
    ) -> None:
        self.elf = Path(elf)
        if not self.elf.is_file():
            raise InputError(f"{self.elf}: no such firmware ELF (build it with `make firmware`)")
        if speed <= 0:
            raise InputError("speed must be positive")
        self.harness = find_harness(harness)
        # the harness answers a repeated exchange itself and passes it on only when it
        # differs: the boards here do not see every poll, so they keep no silence timer
        self.boards = BoardBus(model, silent=silent, board_timeout=False)
        self.boot_ms = boot_ms
        self.speed = speed
        self.device: str | None = None
        self.mcu_resets_seen = 0
        self._holds = 0
        self.mcu_time_s = 0.0
        """The MCU's clock (cycles / 16 MHz) as last reported, within 10 ms."""
        self._proc: subprocess.Popen[bytes] | None = None
        self._thread: threading.Thread | None = None
        self._write_lock = threading.Lock()
        self._figures: queue.Queue[dict[str, float]] = queue.Queue()
        self._error: str | None = None
        self._closing = False
        self._stderr_tail = b""
        self.final_figures: dict[str, float] | None = None

    @property
    def robot(self) -> RobotDescription:
        return self.boards.robot

    def start(self, timeout_s: float = 10.0) -> str:
        """Start the harness; return the pty path a host opens.

        Raises:
            InputError: the harness cannot read the ELF.
            LinkError: the harness failed to start (libsimavr missing).
        """
        cmd = [str(self.harness), "--boot-ms", str(self.boot_ms), "--speed", str(self.speed)]
        cmd.append(str(self.elf))
        try:
            proc = subprocess.Popen(
                cmd,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                preexec_fn=_raise_priority,
            )
        except OSError as exc:
            raise LinkError(f"cannot run the simavr harness {self.harness}: {exc}") from exc
        self._proc = proc
        assert proc.stdout is not None and proc.stderr is not None
        threading.Thread(target=self._drain_stderr, args=(proc.stderr,), daemon=True).start()
        record = self._read_record(proc.stdout)
        if record is None or record[0] != ord("P"):
            proc.wait(timeout=timeout_s)
            time.sleep(0.05)  # the stderr reader takes the last line
            if proc.returncode == 2:  # the harness's usage error: a bad ELF
                raise InputError(self._start_failure(proc.returncode))
            raise LinkError(self._start_failure(proc.returncode))
        self.device = record[1].decode()
        self._thread = threading.Thread(target=self._serve, name="pirate-boardbus", daemon=True)
        self._thread.start()
        return self.device

    def _start_failure(self, returncode: int | None) -> str:
        tail = self._stderr_tail.decode(errors="replace").strip().splitlines()
        last = tail[-1] if tail else f"exit status {returncode}"
        if "libsimavr" in last and "shared librar" in last:
            return "libsimavr is missing (Debian: apt-get install libsimavr-dev): " + last
        return f"the simavr harness failed: {last}"

    def _drain_stderr(self, stream: IO[bytes]) -> None:
        for line in stream:
            self._stderr_tail = (self._stderr_tail + line)[-4096:]
            _log.info("harness: %s", line.decode(errors="replace").rstrip())

    @staticmethod
    def _read_record(stream: IO[bytes]) -> tuple[int, bytes] | None:
        head = stream.read(3)
        if len(head) < 3:
            return None
        n = head[1] | head[2] << 8
        payload = stream.read(n) if n else b""
        if len(payload) < n:
            return None
        return head[0], payload

    def _send(self, kind: str, payload: bytes = b"") -> None:
        self._send_raw(bytes((ord(kind),)) + len(payload).to_bytes(2, "little") + payload)

    def _send_raw(self, data: bytes) -> None:
        proc = self._proc
        if proc is None or proc.stdin is None:
            return
        with self._write_lock:
            try:
                proc.stdin.write(data)
                proc.stdin.flush()
            except (BrokenPipeError, ValueError, OSError):
                if not self._closing:  # close() shuts the pipe under the serving thread
                    self._error = self._error or "the simavr harness stopped"

    def _push_replies(self) -> None:
        out = bytearray()
        for board, reply in self.boards.replies().items():
            payload = bytes((board,)) + reply
            out += b"U" + len(payload).to_bytes(2, "little") + payload
        self._send_raw(bytes(out))

    def _serve(self) -> None:
        proc = self._proc
        assert proc is not None and proc.stdout is not None
        boards = self.boards
        steps = boards.steps
        self._push_replies()
        while True:
            record = self._read_record(proc.stdout)
            if record is None:
                break
            kind, payload = record
            if kind == ord("F"):
                cycle = int.from_bytes(payload[:8], "little")
                self.mcu_time_s = cycle / BUS_CLOCK_HZ
                try:
                    boards.handle(cycle / BUS_CLOCK_HZ, payload[8:])
                    if boards.steps != steps:
                        steps = boards.steps
                        self._push_replies()
                except Exception as exc:  # a bug in the boards must not stop the bus
                    _log.exception("board bus: %s", exc)
            elif kind == ord("T"):
                self.mcu_time_s = int.from_bytes(payload[:8], "little") / BUS_CLOCK_HZ
                boards.advance_to(self.mcu_time_s)
                if boards.steps != steps:
                    steps = boards.steps
                    self._push_replies()
            elif kind == ord("h"):
                self.mcu_time_s = int.from_bytes(payload[:8], "little") / BUS_CLOCK_HZ
                self._holds += 1
            elif kind == ord("S"):
                self._figures.put(_parse_figures(payload))
            elif kind == ord("R"):
                self.mcu_resets_seen += 1
                _log.info("MCU reset (DTR) at cycle %d", int.from_bytes(payload[:8], "little"))
        if proc.poll() is None or proc.returncode == 0:
            return
        self._error = self._error or self._start_failure(proc.returncode)

    @property
    def error(self) -> str | None:
        """Why the harness stopped, when it stopped by itself."""
        return self._error

    @property
    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def figures(self, timeout_s: float = 5.0) -> dict[str, float]:
        """The harness's figures now (cycles, resets, stack, markers; see figures.c).

        Raises:
            LinkError: the harness does not answer.
        """
        self._send("Q")
        try:
            return self._figures.get(timeout=timeout_s)
        except queue.Empty:
            raise LinkError(self._error or "the simavr harness does not answer") from None

    def set_silent(self, board: int, silent: bool) -> None:
        """Make a board stop answering its polls (``silent``) or answer again."""
        if silent:
            self.boards.silent.add(board)
        else:
            self.boards.silent.discard(board)
        self._push_replies()

    def set_estop_input(self, pressed: bool) -> None:
        """Open (``pressed``) or close the hardware e-stop contact on the bridge's D22."""
        self._send("E", bytes((int(pressed),)))

    def hold(self, timeout_s: float = 5.0) -> None:
        """Stop the MCU's clock; returns once stopped, with everything it sent on the pty.

        The pty is still served while held (host bytes queue for the MCU, an open
        still resets it).

        Raises:
            LinkError: the harness did not answer within ``timeout_s``.
        """
        holds = self._holds
        self._send("H")
        deadline = time.monotonic() + timeout_s
        while self._holds == holds:
            if time.monotonic() > deadline:
                raise LinkError(self._error or "the simavr harness did not hold")
            time.sleep(0.0005)

    def go(self) -> None:
        """Let the MCU's clock run again after :meth:`hold`, paced from now."""
        self._send("G")

    def wait_resets(self, count: int, timeout_s: float = 5.0) -> None:
        """Wait until the harness has reported ``count`` MCU resets in all.

        Raises:
            LinkError: it did not within ``timeout_s``.
        """
        deadline = time.monotonic() + timeout_s
        while self.mcu_resets_seen < count:
            if time.monotonic() > deadline:
                raise LinkError(self._error or "the simavr harness did not reset the MCU")
            time.sleep(0.001)

    def reset_mcu(self, timeout_s: float = 2.0) -> None:
        """Reset the MCU now, as a DTR edge does; returns once the harness has done it.

        Raises:
            LinkError: the harness did not reset within ``timeout_s``.
        """
        seen = self.mcu_resets_seen
        self._send("X")
        deadline = time.monotonic() + timeout_s
        while self.mcu_resets_seen == seen:
            if time.monotonic() > deadline:
                raise LinkError(self._error or "the simavr harness did not reset the MCU")
            time.sleep(0.001)

    def close(self) -> None:
        """Stop the harness (its last figures land in :attr:`final_figures`); idempotent."""
        proc = self._proc
        if proc is None:
            return
        if proc.poll() is None:
            with contextlib.suppress(LinkError):
                self.final_figures = self.figures(timeout_s=5.0)
        self._closing = True
        if proc.stdin is not None:
            with contextlib.suppress(OSError):
                proc.stdin.close()
        try:
            proc.wait(timeout=3.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self._proc = None

    def __enter__(self) -> FirmwareBridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _raise_priority() -> None:
    """In the harness's child process: ask for a higher CPU priority, where allowed.

    The MCU is paced to the wall clock; on a loaded machine a harness that waits its
    turn falls behind, and the host sees stale readings. Ordinary users may not raise
    priority: then it runs at the normal one.
    """
    with contextlib.suppress(OSError):
        os.nice(-10)


def _parse_figures(payload: bytes) -> dict[str, float]:
    out: dict[str, float] = {}
    for line in payload.decode(errors="replace").splitlines():
        name, _, value = line.partition(" ")
        with contextlib.suppress(ValueError):
            out[name] = float(int(value, 16)) if value.startswith("0x") else float(value)
    return out
