"""The bridge firmware in simavr (the *harness*) as a child process, its bus served.

The boards on the bus are :class:`~pirate_bt.sim.boardbus.BoardBus`.

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
import subprocess
import threading
import time
from collections.abc import Iterable
from pathlib import Path
from typing import IO

from pirate_bt.errors import ConfigurationError, InputError, LinkError
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.boardbus import BUS_CLOCK_HZ, BoardBus
from pirate_bt.sim.chain_elf import check_built_for
from pirate_bt.sim.model import PipeRobotModel

__all__ = ["HARNESS_ENV", "FirmwareBridge", "find_harness"]

_log = logging.getLogger(__name__)

HARNESS_ENV = "PIRATE_SIMAVR"
"""Environment variable naming the harness executable (default: the repository's build)."""

_REPO_HARNESS = Path(__file__).resolve().parents[2] / "firmware" / "simavr" / "build"


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
        InputError: the ELF is missing, or built for another robot description.
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
        if not 0 < speed <= 100:  # NaN too: the harness paced the MCU to NaN cycles
            raise InputError(f"speed must be more than 0 and at most 100, not {speed}")
        if isinstance(boot_ms, bool) or not isinstance(boot_ms, int) or not 0 <= boot_ms <= 60000:
            # the harness took -5 as 4294967291 ms: a bootloader eating host bytes for ever
            raise InputError(
                "the bootloader time (--boot-ms) must be a whole number of milliseconds"
                f" from 0 to 60000, not {boot_ms!r}"
            )
        check_built_for(self.elf, model.robot)
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
