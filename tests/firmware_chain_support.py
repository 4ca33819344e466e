"""The whole embedded chain in simavr, for the tests and the benchmark.

Builds the bridge ELF, the PICO ELF and the ``pirate-chain`` harness; opens a chain
(:class:`pirate_bt.sim.chain.FirmwareChain`) on a :class:`~pirate_bt.clock.SimClock`;
runs a tree through it with the host's own supervisor, as on a real robot; and the
stop scenarios whose latencies docs/firmware-sim.md reports: a host ``ESTOP``, the
hardware e-stop input, and the bridge killed mid-drive (the boards stop on their own).
"""

from __future__ import annotations

import struct
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from firmware_sim_support import build, missing_toolchain
from pico_support import build_pico_elf

from pirate_bt.clock import SimClock
from pirate_bt.link import open_link
from pirate_bt.link.robot_link import RobotLink
from pirate_bt.pipes import load_network
from pirate_bt.robot import load_robot
from pirate_bt.robot.commands import MotorCommand
from pirate_bt.robot.description import ControlMode, RobotDescription
from pirate_bt.sim.chain import FirmwareChain, StopTimes, find_chain_harness, watched_motors
from pirate_bt.sim.model import PipeRobotModel

__all__ = [
    "PicoAlone",
    "StopScenario",
    "build_chain",
    "clamp_and_drive",
    "missing_chain",
    "open_chain",
    "run_tree",
    "stop_scenario",
    "wait",
]

ROOT = Path(__file__).resolve().parents[1]
CLAMP_NM = 0.7
DRIVE_MPS = 0.05


def missing_chain() -> str | None:
    """Why the chain cannot run here, or None."""
    return missing_toolchain()


_built: tuple[Path, Path, Path] | None = None


def build_chain() -> tuple[Path, Path, Path]:
    """(bridge ELF, PICO ELF, chain harness), built or brought up to date."""
    global _built
    if _built is None:
        bridge, _ = build()  # the bridge ELF and both harnesses (make -C firmware/simavr)
        _built = (bridge, build_pico_elf(), find_chain_harness())
    return _built


@contextmanager
def open_chain(network: str = "straight") -> Iterator[tuple[FirmwareChain, SimClock]]:
    """A chain in ``network`` on a fresh simulated clock; closed afterwards."""
    bridge, pico, harness = build_chain()
    robot = load_robot()
    clock = SimClock()
    chain = FirmwareChain(
        bridge, pico, PipeRobotModel(robot, load_network(network)), clock=clock, harness=harness
    )
    try:
        yield chain, clock
    finally:
        chain.close()


def run_tree(
    chain: FirmwareChain, clock: SimClock, tree: str, params: dict[str, str], max_time: str
) -> Any:
    """Run a bundled tree through the chain, supervised as on a robot; its RunResult."""
    from pirate_bt.api.connection import Connection
    from pirate_bt.api.running import as_loaded, run_on
    from pirate_bt.safety.factory import open_supervisor

    robot = chain.robot
    supervisor = open_supervisor(robot, url=chain.url, clock=clock)
    connection = Connection(
        robot,
        clock,
        supervisor,
        simulated=True,
        target=chain.url,
        seed=None,
        description=f"firmware chain {chain.name}",
    )
    try:
        return run_on(connection, as_loaded(tree, robot, params), max_time=max_time)
    finally:
        connection.close()


def wait(link: RobotLink, clock: SimClock, seconds: float) -> None:
    """Let ``seconds`` pass with the host link served (heartbeats out, states in)."""
    end = clock.now() + seconds
    while clock.now() < end:
        clock.sleep(0.005)
        link.poll()


def clamp_and_drive(link: RobotLink, robot: RobotDescription) -> None:
    """Both halves clamped (torque on every bend joint), every drive at 5 cm/s."""
    commands = [
        MotorCommand(m.name, ControlMode.TORQUE, CLAMP_NM)
        for _, m in robot.motors()
        if m.function == "bend"
    ]
    commands += [
        MotorCommand(m.name, ControlMode.VELOCITY, DRIVE_MPS)
        for _, m in robot.motors()
        if m.function == "drive"
    ]
    link.send_and_wait(commands)


@dataclass(frozen=True)
class StopScenario:
    """What a stop did, measured in the chain.

    Attributes:
        times: From the cause to each drive, rotate and other motor's H-bridge
            stopping (off or brake); see :class:`StopTimes`.
        running_before: The drives that were running (a duty) before the stop.
        joints_after: Each bend joint's output after the stop, ``(drive, duty)``:
            still running (holding its torque), never off or braked.
        figures: The chain's figures after the stop.
    """

    times: StopTimes
    running_before: list[tuple[int, int]]
    joints_after: dict[tuple[int, int], tuple[int, int]]
    figures: dict[str, float]


def stop_scenario(cause: str, network: str = "straight") -> StopScenario:
    """Clamp and drive, then stop by ``cause`` (``host``, ``input``, ``master_silent``)."""
    with open_chain(network) as (chain, clock):
        robot = chain.robot
        link = open_link(chain.url, robot, clock)
        clamp_and_drive(link, robot)
        wait(link, clock, 1.0)
        drives = watched_motors(robot, ("drive",))
        running = [k for k in drives if chain.outputs[k][0] == 2]
        watched = watched_motors(robot, ("drive", "rotate", "other"))
        chain.watch_stops(cause, watched)
        if cause == "host":
            link.estop()
        elif cause == "input":
            chain.set_estop_input(True)
        else:
            chain.halt_bridge()
        deadline = chain.now_s + (0.5 if cause == "master_silent" else 0.2)
        while chain.stop_times is None and chain.now_s < deadline:
            if cause == "master_silent":
                chain.advance_to(chain.now_s + 0.01)  # the host would only see a lost link
            else:
                wait(link, clock, 0.01)
        times = chain.stop_times
        assert times is not None, f"{cause}: not every motor stopped in time"
        if cause == "master_silent":
            chain.advance_to(chain.now_s + 0.05)
        else:
            wait(link, clock, 0.05)
        joints = {k: chain.outputs[k] for k in watched_motors(robot, ("bend",))}
        figures = chain.figures()
        if cause != "master_silent":
            link.close()
        return StopScenario(times, running, joints, figures)


class PicoAlone:
    """One PICO ELF in simavr with Python as the bus master (``pirate-chain - PICO.elf ID``).

    For the board bus's vectors: the master's bytes go to the board at 1 Mbaud, what
    the board puts on the line comes back, and its ``pico_debug`` record says which
    setpoint each motor executes.
    """

    HZ = 16_000_000

    def __init__(self, board: int) -> None:
        _, pico, harness = build_chain()
        self.proc = subprocess.Popen(
            [str(harness), "-", str(pico), str(board)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        self.board = board
        self.cycle = 0
        kind, _ = self._record()
        assert kind == ord("P")

    def _record(self) -> tuple[int, bytes]:
        assert self.proc.stdout is not None
        head = self.proc.stdout.read(3)
        n = head[1] | head[2] << 8
        return head[0], self.proc.stdout.read(n) if n else b""

    def _send(self, kind: str, payload: bytes) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(bytes((ord(kind),)) + len(payload).to_bytes(2, "little") + payload)
        self.proc.stdin.flush()

    def run_to(self, at_s: float, inputs: dict[str, list[int]], send: bytes = b"") -> bytes:
        """Inputs held, ``send`` on the bus, time runs to ``at_s``; what the board sent."""
        until = round(at_s * self.HZ)
        board = struct.pack("<4H2i3hB", *inputs["adc"], 0, 0, *inputs["imu"], 0)
        self._send("A", struct.pack("<QH", until, len(send)) + send + board)
        kind, data = self._record()
        assert kind == ord("a")
        self.cycle = struct.unpack_from("<Q", data)[0]
        n = struct.unpack_from("<H", data, 8)[0]
        return data[10 : 10 + n]

    def motors(self, count: int) -> list[list[int] | None]:
        """The setpoint each motor executes ([mode, raw], or None: never commanded)."""
        self._send("Q", b"")
        kind, data = self._record()
        assert kind == ord("S")
        figures = dict(line.split(" ", 1) for line in data.decode().splitlines())
        out: list[list[int] | None] = []
        for k in range(count):
            mode = int(figures[f"pico_{self.board}_motor{k}_mode"])
            raw = int(figures[f"pico_{self.board}_motor{k}_raw"])
            out.append(None if mode == 0xFE else [mode, raw])
        return out

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait(timeout=10)
