"""The board bus (docs/board-bus.md, version 2): one set of byte-level vectors, three ends.

``tests/data/board_bus_vectors.json`` (written by ``pirate_bt.sim.board_vectors`` from
the page) is passed by the Python boards (:class:`pirate_bt.sim.boardbus.BoardBus`),
by the reference PICO firmware (``firmware/pico/``, its own C built for the host with
its hardware file replaced), and, for the frames it sends and the replies it must
accept or refuse, by the bridge firmware (its host build). Then the PICO's own rules
that are not bytes: what each mode does to the H-bridge, the turnaround, the joints
kept through a watchdog reset; and its AVR build fits the ATmega328p.
"""

from __future__ import annotations

import ctypes
import json
import shutil
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from firmware_host import build_host_library
from pico_support import build_pico_host

from pirate_bt.link.codec import cobs_decode
from pirate_bt.pipes import load_network
from pirate_bt.robot.loader import load_robot
from pirate_bt.sim.board_vectors import build_vectors
from pirate_bt.sim.boardbus import BoardBus
from pirate_bt.sim.model import PipeRobotModel

VECTORS_FILE = Path(__file__).parent / "data" / "board_bus_vectors.json"
VECTORS: dict[str, Any] = json.loads(VECTORS_FILE.read_text())
SEQUENCES = {s["name"]: s for s in VECTORS["sequences"]}
FRAMES = {f["name"]: f for f in VECTORS["frames"]}
HAL_OFF, HAL_BRAKE, HAL_RUN = 0, 1, 2
PWM, TORQUE, POSITION, VELOCITY, KEEP = 0, 1, 2, 3, 0xFF


def test_the_vectors_file_is_up_to_date() -> None:
    assert build_vectors(load_robot()) == VECTORS, "python -m pirate_bt.sim.board_vectors"


def _slots(board: int) -> list[int]:
    return [s.slot for s in load_robot().setpoint_slots() if s.board == board]


def _frames(data: bytes) -> list[bytes]:
    return [chunk for chunk in data.split(b"\x00")[:-1] if chunk]


# -- the Python boards ---------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(SEQUENCES))
def test_the_python_boards_pass_the_vectors(name: str) -> None:
    sequence = SEQUENCES[name]
    board = sequence["board"]
    bus = BoardBus(PipeRobotModel(load_robot(), load_network("straight")))
    for number, step in enumerate(sequence["steps"], 1):
        where = f"{name} step {number}"
        now = step["at_ms"] / 1000
        bus.set_readings(board, step["channels"])
        bus.advance_to(now)
        reply = b""
        if step["send_hex"]:
            for frame in _frames(bytes.fromhex(step["send_hex"])):
                answer = bus.handle(now, frame)
                # these are all the robot's boards: only this board's answer counts
                if answer and cobs_decode(answer[:-1])[0] == board:
                    reply += answer
        assert (reply.hex() or None) == step["expect_reply_hex"], where
        motors = [bus.motor_state(board, slot) for slot in _slots(board)]
        assert [list(m) if m else None for m in motors] == step["expect_motors"], where


# -- the reference PICO firmware, host build -----------------------------------------------


@pytest.fixture(scope="module")
def pico_library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_pico_host(tmp_path_factory.mktemp("pico-host"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the PICO logic cannot be built")
        raise


class PicoDebug(ctypes.Structure):
    """``struct pico_debug`` (firmware/pico/pico.h), host layout."""

    _fields_ = [
        ("magic", ctypes.c_uint16),
        ("board_id", ctypes.c_uint8),
        ("known", ctypes.c_uint8),
        ("resets", ctypes.c_uint16),
        ("last_mcusr", ctypes.c_uint8),
        ("warm", ctypes.c_uint8),
        ("stack_low", ctypes.c_uint16),
        ("exchanges", ctypes.c_uint16),
        ("stops", ctypes.c_uint16),
        ("bad_frames", ctypes.c_uint16),
        ("own_stops", ctypes.c_uint16),
        ("refused", ctypes.c_uint16),
        ("others", ctypes.c_uint16),
        ("own_stop", ctypes.c_uint8),
        ("reserved", ctypes.c_uint8),
        ("motor_mode", ctypes.c_uint8 * 2),
        ("motor_raw", ctypes.c_int16 * 2),
        ("reserved2", ctypes.c_uint16),
    ]


class Pico:
    """One PICO board's host build, a private copy (its own static state)."""

    def __init__(self, library: Path, workdir: Path) -> None:
        copy = workdir / f"pico-{id(self)}.so"
        shutil.copy(library, copy)
        self.lib = ctypes.CDLL(str(copy), mode=ctypes.RTLD_LOCAL)
        self.lib.pk_now_us.restype = ctypes.c_uint64
        self.now_us = 0

    def boot(self, board: int, warm: bool = False) -> None:
        self.lib.pk_boot(board, int(warm))

    def run_to(self, us: int) -> None:
        if us > self.now_us:
            self.lib.pk_run_us(ctypes.c_uint32(us - self.now_us))
            self.now_us = us

    def run(self, us: int) -> None:
        self.run_to(self.now_us + us)

    def inputs(self, pico: dict[str, list[int]]) -> None:
        for i, value in enumerate(pico["adc"]):
            self.lib.pk_adc(i, value)
        self.lib.pk_imu(*pico["imu"])

    def write(self, data: bytes) -> None:
        self.lib.pk_write(data, len(data))

    def read(self) -> bytes:
        buf = ctypes.create_string_buffer(4096)
        n = self.lib.pk_read(buf, len(buf))
        return buf.raw[:n]

    def state(self, k: int) -> list[int] | None:
        out = (ctypes.c_int16 * 2)()
        self.lib.pk_state(k, out)
        return None if out[0] == 0xFE else [out[0], out[1]]

    def output(self, slot: int) -> tuple[int, int]:
        out = (ctypes.c_int16 * 2)()
        self.lib.pk_motor(slot, out)
        return out[0], out[1]

    def debug(self) -> PicoDebug:
        record = PicoDebug()
        self.lib.pk_debug(ctypes.byref(record))
        return record

    def ask(self, frame: bytes, us: int = 300) -> bytes:
        self.write(frame)
        self.run(us)
        return self.read()


@pytest.fixture()
def pico(pico_library: Path, tmp_path: Path) -> Iterator[Pico]:
    yield Pico(pico_library, tmp_path)


@pytest.mark.parametrize("name", sorted(SEQUENCES))
def test_the_pico_firmware_passes_the_vectors(pico: Pico, name: str) -> None:
    sequence = SEQUENCES[name]
    board = sequence["board"]
    pico.boot(board)
    for number, step in enumerate(sequence["steps"], 1):
        where = f"{name} step {number}"
        pico.inputs(step["pico_inputs"])
        pico.run_to(step["at_ms"] * 1000)
        reply = pico.ask(bytes.fromhex(step["send_hex"])) if step["send_hex"] else pico.read()
        assert (reply.hex() or None) == step["expect_reply_hex"], where
        motors = [pico.state(k) for k in range(len(_slots(board)))]
        assert motors == step["expect_motors"], where


def _request(addr: int, cmd: int, setpoints: list[tuple[int, int]]) -> bytes:
    from pirate_bt.sim.board_vectors import request_hex

    return bytes.fromhex(request_hex(addr, cmd, setpoints))


def test_each_mode_drives_the_h_bridge_as_the_page_says(pico: Pico) -> None:
    pico.boot(22)
    pico.inputs({"adc": [2048 // 4, 0, 0, 0], "imu": [0, 0, 0]})
    pico.run(2000)
    assert pico.output(0) == (HAL_OFF, 0) and pico.output(1) == (HAL_OFF, 0)  # never commanded
    pico.ask(_request(22, 1, [(TORQUE, 512), (VELOCITY, 0)]))
    pico.run(2000)
    assert pico.output(0) == (HAL_RUN, 127)  # torque: 512 of 1023 at full duty
    assert pico.output(1) == (HAL_BRAKE, 0)  # velocity 0 is a brake, not a loop
    pico.ask(_request(22, 1, [(PWM, -255), (VELOCITY, 600)]))
    pico.run(2000)
    assert pico.output(0) == (HAL_RUN, -255)
    drive, duty = pico.output(1)
    assert drive == HAL_RUN and duty >= 600 * 255 // 1200  # the feed-forward, plus the PI
    # position: the loop on the angle sensor of the same slot, limited to the hold torque
    pico.ask(_request(22, 1, [(POSITION, 1000), (PWM, 0)]))
    pico.run(2000)
    assert pico.output(0) == (HAL_RUN, 100)  # far from 1000: the hold duty (0.4 of 1.023 N·m)
    assert pico.output(1) == (HAL_BRAKE, 0)
    pico.inputs({"adc": [(2048 + 1000) // 4, 0, 0, 0], "imu": [0, 0, 0]})
    pico.run(2000)
    assert pico.output(0) == (HAL_BRAKE, 0)  # in the dead band: brake


def test_the_reply_waits_its_turnaround_and_comes_within_300_us(pico: Pico) -> None:
    pico.boot(22)
    pico.run(2000)
    pico.write(_request(22, 1, [(KEEP, 0), (KEEP, 0)]))
    pico.run(10)
    assert pico.read() == b""  # the master's stop bit must be over first
    pico.run(290)
    assert pico.read().endswith(b"\x00")


def test_a_watchdog_reset_keeps_the_clamp_and_brakes_the_rest(pico: Pico) -> None:
    pico.boot(22)
    pico.run(2000)
    pico.ask(_request(22, 1, [(TORQUE, 700), (VELOCITY, 500)]))
    pico.boot(22, warm=True)  # the AVR's watchdog: .noinit survives
    pico.run(2000)
    assert pico.state(0) == [TORQUE, 700] and pico.output(0) == (HAL_RUN, 174)
    assert pico.state(1) == [PWM, 0] and pico.output(1) == (HAL_BRAKE, 0)
    assert pico.debug().warm == 1
    pico.boot(22, warm=False)  # a power-on: everything off (limp), as the page says
    pico.run(2000)
    assert pico.state(0) is None and pico.output(0) == (HAL_OFF, 0)


def test_a_board_without_a_known_id_stays_silent(pico: Pico) -> None:
    pico.boot(99)
    pico.run(2000)
    assert pico.ask(_request(99, 1, [(PWM, 0)])) == b""
    assert pico.debug().known == 0


# -- the bridge firmware: the frames it sends, the replies it takes -------------------------


@pytest.fixture(scope="module")
def bridge_library(tmp_path_factory: pytest.TempPathFactory) -> Path:
    try:
        return build_host_library(tmp_path_factory.mktemp("fw-host-bus"))
    except RuntimeError as exc:
        if "no host C compiler" in str(exc):
            pytest.skip(f"{exc}: the firmware core cannot be built")
        raise


@pytest.fixture()
def bridge(bridge_library: Path, tmp_path: Path) -> Iterator[Any]:
    from test_firmware_core import Bridge

    copy = tmp_path / "bridge.so"
    shutil.copy(bridge_library, copy)
    yield Bridge(copy, load_robot())


def _body(frame: dict[str, Any]) -> bytes:
    """A vector frame's body without its CRC, as the bridge's bus log holds it."""
    return cobs_decode(bytes.fromhex(frame["hex"])[:-1])[:-2]


def test_the_bridge_sends_the_vector_frames(bridge: Any) -> None:
    from test_firmware_core import ESTOP, SETPOINT, frame, setpoint

    bridge.start()
    assert bridge.ask(setpoint(3, 22, 1, VELOCITY, 800), ms=12)[0].kind != SETPOINT
    to_22 = [b for b in bridge.bus() if b[:2] == bytes([22, 1])]
    assert to_22[-1] == _body(FRAMES["exchange"])
    bridge.ask(frame(ESTOP, 4), ms=2)
    stops = {b[0]: b for b in bridge.bus() if b[1] == 2}
    for name in ("stop_drive_and_bend", "stop_rotate_and_drive", "stop_leds"):
        vector = FRAMES[name]
        assert stops[vector["addr"]] == _body(vector), name


def _reply_from(bridge: Any, board: int, wire: bytes) -> None:
    index = bridge.boards.index(board)
    bridge.lib.fw_board_reply(index, wire, len(wire))


def test_the_bridge_takes_the_vector_replies(bridge: Any) -> None:
    fault, motors_off, online = 0x2, 0x8, 0x1
    for name in ("reply", "reply_fault_and_motors_off"):
        vector = FRAMES[name]
        _reply_from(bridge, vector["addr"], bytes.fromhex(vector["hex"]))
        bridge.run(25)
        _, fresh, _, status, values = bridge.state(bridge.states()[-1])
        mine = [c.index for c in bridge.channels if c.board == vector["addr"]]
        assert [values[i] for i in mine] == vector["channels"], name
        assert all(fresh >> i & 1 for i in mine), name
        nibble = status[bridge.boards.index(vector["addr"])]
        assert nibble & online
        if vector["status"] & 0x01:
            assert nibble & fault and nibble & motors_off


@pytest.mark.parametrize("refused", VECTORS["refused_replies"], ids=lambda r: r["name"])
def test_the_bridge_refuses_the_bad_vector_replies(bridge: Any, refused: dict[str, Any]) -> None:
    from test_firmware_core import COUNTERS_REQUEST, frame

    _reply_from(bridge, refused["addr"], bytes.fromhex(refused["hex"]))
    bridge.run(25)
    _, fresh, _, status, _ = bridge.state(bridge.states()[-1])
    mine = [c.index for c in bridge.channels if c.board == refused["addr"]]
    assert not any(fresh >> i & 1 for i in mine)
    assert status[bridge.boards.index(refused["addr"])] & 0x4  # TIMEOUT
    counters = bridge.ask(frame(COUNTERS_REQUEST, 9))[0]
    j = bridge.boards.index(refused["addr"])
    _, _timeouts, crc, _retries = struct.unpack(
        "<BIII", counters.payload[20 + 13 * j : 33 + 13 * j]
    )
    assert crc >= 1


# -- the AVR build ------------------------------------------------------------------------


def test_the_pico_firmware_builds_with_werror_and_fits_the_atmega328p(tmp_path: Path) -> None:
    import subprocess

    from pico_support import build_pico_elf

    if shutil.which("avr-gcc") is None or shutil.which("avr-size") is None:
        pytest.skip("avr-gcc/avr-size missing: install Debian's gcc-avr and avr-libc")
    elf = build_pico_elf(tmp_path)
    sizes = {}
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True)
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sizes[parts[0]] = int(parts[1])
    flash = sizes[".text"] + sizes.get(".data", 0)
    sram = sizes.get(".data", 0) + sizes.get(".bss", 0) + sizes.get(".noinit", 0)
    assert flash < 32 * 1024 // 2 and sram < 2048 - 1024  # half the flash, 1 KB of stack
    fuses = subprocess.run(
        ["avr-objcopy", "-O", "binary", "-j", ".fuse", str(elf), "/dev/stdout"],
        capture_output=True,
        check=True,
    ).stdout
    assert fuses == bytes([0xFF, 0xD1, 0xFC])
    symbols = subprocess.run(["avr-nm", str(elf)], capture_output=True, text=True, check=True)
    assert " pico_debug" in symbols.stdout


def test_the_encoder_resolution_is_one_number_for_the_firmware_and_the_physics() -> None:
    """ENCODER_CPR, the one board figure the robot description lacks: the PICO's build
    option and the chain's physics (pirate_bt.sim.chain) must agree."""
    import re

    from pirate_bt.sim.chain import PICO_ENCODER_CPR

    makefile = (Path(__file__).resolve().parents[1] / "firmware" / "pico" / "Makefile").read_text()
    match = re.search(r"^ENCODER_CPR \?= (\d+)$", makefile, re.MULTILINE)
    assert match and int(match.group(1)) == PICO_ENCODER_CPR
