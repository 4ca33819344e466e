"""Shared by the firmware-in-simavr tests, the conformance fixture and the benchmark.

Builds the PIRATEbay ELF and the simavr harness (incrementally, with ``make``),
says why when the toolchain is missing, and drives the firmware from the host's
side of its pty: a session, and the robustness soak (random bytes and corrupted
frames at the full line rate).
"""

from __future__ import annotations

import os
import random
import select
import shutil
import subprocess
import sys
import time
import tty
from dataclasses import dataclass
from pathlib import Path

from pirate_bt.link.codec import PROTOCOL_MINOR, FrameCodec, FrameDecoder
from pirate_bt.link.messages import EStopReset, Hello, HelloReply, Message, Setpoint
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.sim.firmware_bridge import FirmwareBridge

ROOT = Path(__file__).resolve().parents[1]
ELF = ROOT / "firmware" / "piratebay" / "build" / "piratebay.elf"
HARNESS = ROOT / "firmware" / "simavr" / "build" / "pirate-simavr"
LINE_BYTES_PER_S = 11_520  # 115200 baud, 8N1


def missing_toolchain() -> str | None:
    """Why the firmware cannot run in simavr here, or None when it can."""
    for tool in ("avr-gcc", "cc", "make", "pkg-config"):
        if shutil.which(tool) is None:
            return f"{tool} missing (Debian: apt-get install gcc-avr avr-libc libsimavr-dev)"
    found = subprocess.run(
        ["pkg-config", "--print-errors", "--exists", "simavr"],
        check=False,
        capture_output=True,
        text=True,
    )
    if found.returncode != 0:
        why = " ".join(found.stderr.split()) or "simavr.pc not found"
        return (
            f"simavr not usable through pkg-config ({why}); Debian: apt-get install"
            " libsimavr-dev libelf-dev pkg-config (make test installs them as root)"
        )
    return None


_built: tuple[Path, Path] | None = None


def build() -> tuple[Path, Path]:
    """Build (or bring up to date) the ELF and the harness; return their paths.

    Raises:
        RuntimeError: a build failed (with its output).
    """
    global _built
    if _built is not None:
        return _built
    from firmware_host import build_lock

    env = {**os.environ, "MAKEFLAGS": ""}
    for cmd in (
        ["make", "-s", "-C", str(ELF.parents[1]), f"PIRATE_BT={sys.executable} -m pirate_bt"],
        ["make", "-s", "-C", str(HARNESS.parents[1])],
    ):
        with build_lock():
            done = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{done.stdout}\n{done.stderr}")
    _built = (ELF, HARNESS)
    return _built


class HostEnd:
    """The host's end of the firmware's pty: raw bytes and messages in, messages out.

    Opening it is the DTR edge: the harness resets the MCU.
    """

    def __init__(self, device: str, robot: RobotDescription) -> None:
        self.fd = os.open(device, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        self.codec = FrameCodec.for_robot(robot)
        self.decoder = FrameDecoder(self.codec)
        self.robot = robot
        self.seq = 1

    def next_seq(self) -> int:
        self.seq = (self.seq + 1) & 0xFFFF
        return self.seq

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            written = os.write(self.fd, view)
            view = view[written:]

    def send(self, msg: Message) -> None:
        self.write(self.codec.encode(msg))

    def read(self, timeout_s: float) -> list[Message]:
        """Messages decoded within ``timeout_s`` (frame errors dropped)."""
        out: list[Message] = []
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                for item in self.decoder.feed(os.read(self.fd, 65536)):
                    if not isinstance(item, Exception):
                        out.append(item)
        return out

    def hello(self, timeout_s: float = 0.5, attempts: int = 6) -> HelloReply | None:
        """HELLO (after a 0x00 that ends any half-received frame), retried as a host does.

        Returns:
            The reply, or None when none came.
        """
        for _ in range(attempts):
            seq = self.next_seq()
            hello = Hello(seq, self.codec.layout.digest, PROTOCOL_MINOR)
            self.write(b"\x00" + self.codec.encode(hello))
            for msg in self.read(timeout_s):
                if isinstance(msg, HelloReply) and msg.seq == seq:
                    return msg
        return None

    def close(self) -> None:
        os.close(self.fd)


@dataclass(frozen=True)
class Poison:
    """A valid SETPOINT of the first drive motor with a distinctive value."""

    board: int
    slot: int
    raw_value: int

    def frame(self, host: HostEnd, seq: int) -> bytes:
        return host.codec.encode(
            Setpoint(seq, self.board, self.slot, ControlMode.VELOCITY, self.raw_value)
        )

    def key(self) -> tuple[int, int, int, int]:
        """How the boards record it applied: (board, slot, mode code, raw)."""
        return (self.board, self.slot, 3, self.raw_value)


def poison_for(robot: RobotDescription, raw_value: int = 777) -> Poison:
    slot = next(s for s in robot.setpoint_slots() if s.motor.function == "drive")
    return Poison(slot.board, slot.slot, raw_value)


def corrupt(frame: bytes, rng: random.Random) -> bytes:
    """A copy of ``frame`` with damage CRC-16 is sure to detect.

    1 to 3 flipped bits, or a burst of at most 16 bits, in the encoded bytes before
    the delimiter (CRC-16/XMODEM catches all of these in frames this short).
    """
    body = bytearray(frame[:-1])
    bits = len(body) * 8
    if rng.random() < 0.5:
        for bit in rng.sample(range(bits), rng.randint(1, 3)):
            body[bit // 8] ^= 1 << (bit % 8)
    else:
        length = rng.randint(2, 16)
        start = rng.randrange(bits - length + 1)
        for bit in (start, start + length - 1):
            body[bit // 8] ^= 1 << (bit % 8)
        for bit in range(start + 1, start + length - 1):
            if rng.random() < 0.5:
                body[bit // 8] ^= 1 << (bit % 8)
    return bytes(body) + b"\x00"


def soak_bytes(seconds: float) -> int:
    """What ``seconds`` of a 115200-baud line carries: the bytes :func:`soak` sends."""
    return int(seconds * LINE_BYTES_PER_S)


def soak(host: HostEnd, poison: Poison, seconds: float, seed: int = 14) -> int:
    """Random bytes and corrupted poison frames at the full line rate; returns bytes sent.

    Written in 10 ms chunks of the line's rate (115.2 bytes), so the pty carries what
    a 115200-baud line would, no more; what the bridge sends back is read and dropped.
    Sends :func:`soak_bytes` of ``seconds`` in all: when the machine stalls the host
    (or the harness, whose pty then fills), the line catches up afterwards, so the
    amount does not depend on the machine's speed. Gives up at 3 x ``seconds`` + 10 s
    (then fewer bytes were sent).
    """
    rng = random.Random(seed)
    seq = 1000
    sent = 0
    total = soak_bytes(seconds)
    give_up_s = 3 * seconds + 10
    start = time.monotonic()
    pending = bytearray()
    while sent < total and (elapsed := time.monotonic() - start) < give_up_s:
        due = min(int(elapsed * LINE_BYTES_PER_S), total) - sent
        while len(pending) < due:
            if rng.random() < 0.5:
                pending += rng.randbytes(rng.randint(1, 40))
            else:
                seq = (seq + 1) & 0xFFFF
                pending += corrupt(poison.frame(host, seq), rng)
        if due > 0:
            host.write(bytes(pending[:due]))
            del pending[:due]
            sent += due
        ready, _, _ = select.select([host.fd], [], [], 0.01)
        if ready:
            os.read(host.fd, 65536)
    return sent


def wait_line_drained(bridge: FirmwareBridge, timeout_s: float = 20.0) -> float:
    """Wait until the harness has fed the MCU every byte the host wrote; returns the wait.

    A 115200-baud line cannot fall behind, but the harness can: when the host machine
    stalls it (a lag event), the bytes the host wrote meanwhile queue for the MCU.
    """
    start = time.monotonic()
    while bridge.figures()["host_queue_bytes"] > 0 and time.monotonic() - start < timeout_s:
        time.sleep(0.05)
    return time.monotonic() - start


def release(host: HostEnd) -> bool:
    """Release the e-stop latch the bridge boots with; True when acknowledged."""
    seq = host.next_seq()
    host.send(EStopReset(seq))
    return any(getattr(m, "seq", None) == seq for m in host.read(0.3))
