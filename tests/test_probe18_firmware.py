"""Probe 18, the embedded side: the firmwares and their simulators as a user meets them.

Each test here failed before the fix it names in its docstring.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from firmware_chain_support import build_chain, missing_chain

from pirate_bt.errors import InputError
from pirate_bt.pipes import load_network
from pirate_bt.robot import load_robot
from pirate_bt.sim.chain import FirmwareChain
from pirate_bt.sim.chain_elf import elf_layout_digest
from pirate_bt.sim.model import PipeRobotModel

ROOT = Path(__file__).resolve().parents[1]
LONG = ROOT / "hardware" / "variants" / "pirate-long.yaml"


@pytest.fixture(scope="module")
def elfs() -> tuple[Path, Path]:
    """(bridge ELF, PICO ELF) for the default robot, built."""
    why = missing_chain()
    if why:
        pytest.skip(why)
    bridge, pico, _ = build_chain()
    return bridge, pico


def test_both_elfs_say_which_description_they_were_built_for(elfs: tuple[Path, Path]) -> None:
    """Nothing in an ELF said which robot description it was built for: a simulator
    could not tell a bridge or a PICO of another robot from the right one."""
    want = load_robot().layout_digest()
    for elf in elfs:
        assert elf_layout_digest(elf) == want, elf
    assert elf_layout_digest(elfs[0].with_suffix(".hex")) is None  # no ELF: says nothing
    for elf in elfs:  # in the ELF only: the chip's image (and the sizes) do not change
        headers = subprocess.run(
            ["avr-objdump", "-h", str(elf)], capture_output=True, text=True, check=True
        ).stdout.splitlines()
        (at,) = (i for i, line in enumerate(headers) if " .pb_layout " in line)
        assert "ALLOC" not in headers[at + 1], headers[at : at + 2]


def test_sim_refuses_a_bridge_built_for_another_robot(elfs: tuple[Path, Path]) -> None:
    """`pirate-bt sim --robot pirate-long.yaml --firmware` with the default robot's
    bridge ran (exit 0): the bridge polled nine boards of eleven, and a host with the
    long robot was told only 'the bridge reports its e-stop latched'."""
    bridge, _ = elfs
    args = ["sim", "straight", "--robot", str(LONG), "--firmware", str(bridge), "--duration", "1"]
    done = subprocess.run(
        [sys.executable, "-m", "pirate_bt", *args],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    assert done.stdout == ""  # no pty was offered
    (line,) = done.stderr.strip().splitlines()
    digest = load_robot().layout_digest()
    assert f"{bridge} was built for another robot description" in line
    assert f"its layout digest 0x{digest:08x}" in line
    assert "(--robot)" in line


def test_chain_refuses_a_pico_built_for_another_robot(
    elfs: tuple[Path, Path], tmp_path: Path
) -> None:
    """The chain put a PICO ELF of another description behind the robot's boards (its
    channel and motor tables another robot's), and nothing noticed."""
    bridge, pico = elfs
    other = tmp_path / "pico.elf"
    shutil.copy(pico, other)
    data = bytearray(other.read_bytes())
    built = load_robot().layout_digest().to_bytes(4, "little")
    assert data.count(built) == 1  # the digest's own four bytes, in flash
    data[data.index(built) : data.index(built) + 4] = bytes(4)
    other.write_bytes(bytes(data))
    assert elf_layout_digest(other) == 0
    model = PipeRobotModel(load_robot(), load_network("straight"))
    chain: FirmwareChain | None = None
    try:
        with pytest.raises(InputError, match="was built for another robot description") as err:
            chain = FirmwareChain(bridge, other, model)
        assert str(other) in str(err.value)
        assert "0x00000000" in str(err.value)
    finally:
        if chain is not None:
            chain.close()
    # the right pair is taken: the bridge is checked the same way and passes
    long_model = PipeRobotModel(load_robot(LONG), load_network("straight"))
    with pytest.raises(InputError, match=f"{bridge} was built for another"):
        FirmwareChain(bridge, pico, long_model)


def test_firmware_sim_page_does_not_say_the_firmware_never_sleeps(
    elfs: tuple[Path, Path],
) -> None:
    """docs/firmware-sim.md said the harness needs half a core because 'the firmware's
    main loop never sleeps'; the bridge sleeps between interrupts (a SLEEP instruction
    in its main loop), and the harness took about a fifth of a core."""
    bridge, _ = elfs
    disassembly = subprocess.run(
        ["avr-objdump", "-d", str(bridge)], capture_output=True, text=True, check=True
    ).stdout
    assert "\tsleep" in disassembly
    page = (ROOT / "docs" / "firmware-sim.md").read_text()
    limits = page[page.index("## Limits") :]
    assert "about half a CPU core" not in limits
    assert "a fifth of a CPU core" in limits


@pytest.mark.parametrize(
    ("ids", "words"),
    [
        (["300"], "board id '300' is not a number from 0 to 255"),  # was board 44
        (["22x"], "board id '22x' is not a number from 0 to 255"),  # was 22
        (["20", "abc"], "board id 'abc' is not a number from 0 to 255"),  # was 0
        (["20", "21", "20"], "board id 20 given twice"),
        ([str(i) for i in range(20, 38)], "18 board ids given, at most 17"),
    ],
)
def test_the_chain_harness_refuses_board_ids_it_would_misread(
    elfs: tuple[Path, Path], ids: list[str], words: str
) -> None:
    """pirate-chain read its board ids with atoi ('300' ran board 44, 'abc' board 0) and
    kept the first 16 of them: a 17-board robot (the protocol's most) ran without its
    last PICO, and the bridge could never release its boot latch."""
    _, pico = elfs
    harness = build_chain()[2]
    done = subprocess.run(
        [str(harness), "-", str(pico), *ids],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 2, done
    assert done.stderr.decode().strip().splitlines() == [f"pirate-chain: {words}"]
    assert not done.stdout.startswith(b"P")  # no chain was started


def test_the_chain_harness_runs_seventeen_boards(elfs: tuple[Path, Path]) -> None:
    """The wire protocol carries 17 boards (docs/protocol.md); the chain ran 16."""
    _, pico = elfs
    ids = [str(i) for i in range(20, 37)]
    done = subprocess.run(
        [str(build_chain()[2]), "-", str(pico), *ids],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    n = int.from_bytes(done.stdout[1:3], "little")
    assert done.stdout[:1] == b"P"
    assert done.stdout[3 : 3 + n].decode() == "boards " + " ".join(ids)


def test_the_led_shows_the_latch_in_a_bridge_built_without_the_estop_input(
    tmp_path: Path,
) -> None:
    """docs/firmware.md: D13 is lit while the e-stop is latched, any cause. A bridge
    built `make firmware ESTOP_INPUT=none` (the bench without a button) never lit it:
    the LED was driven only by the button's sampling, so it stayed dark while the bridge
    sat latched from boot, and through a host ESTOP."""
    if shutil.which("cc") is None or shutil.which("make") is None:
        pytest.skip("no host C compiler (cc) or make")
    from firmware_host import FIRMWARE, build_lock
    from test_firmware_core import ESTOP, ESTOP_RESET, Bridge, frame

    build = tmp_path / "none"
    with build_lock():
        options = ["HOST_OPT=-O1 -DPB_ESTOP_INPUT=0", f"PIRATE_BT={sys.executable} -m pirate_bt"]
        made = subprocess.run(
            ["make", "-s", "-C", str(FIRMWARE), "host", f"BUILD={build}", *options],
            capture_output=True,
            text=True,
            check=False,
        )
    assert made.returncode == 0, made.stderr
    bridge = Bridge(build / "libpiratebay_host.so", load_robot())
    bridge.run(5)
    assert bridge.lib.fw_led() == 1  # booted latched
    bridge.start()  # hello, ESTOP_RESET acknowledged: released
    assert bridge.lib.fw_led() == 0
    bridge.ask(frame(ESTOP, 3))
    assert bridge.lib.fw_led() == 1
    assert bridge.ask(frame(ESTOP_RESET, 4))[0].payload == bytes([ESTOP_RESET, 0])
    assert bridge.lib.fw_led() == 0


@pytest.mark.parametrize("value", ["5ms", "40000", "50", "0100"])
def test_a_bus_timeout_the_build_cannot_use_stops_it_in_one_line(
    tmp_path: Path, value: str
) -> None:
    """`make firmware BUS_TIMEOUT_US=5ms` (or 40000, past the 16-bit timer) stopped in
    avr-gcc: 'invalid suffix "msu" on integer constant' under an include trail."""
    if shutil.which("make") is None:
        pytest.skip("make missing")
    from firmware_host import FIRMWARE

    done = subprocess.run(
        [
            "make",
            "-s",
            "-C",
            str(FIRMWARE),
            f"BUILD={tmp_path}",
            f"BUS_TIMEOUT_US={value}",
            f"PIRATE_BT={sys.executable} -m pirate_bt",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert f"BUS_TIMEOUT_US={value}: the board bus's reply timeout" in line
    assert "from 100 to 30000" in line
    assert not list(tmp_path.iterdir())  # nothing generated, nothing compiled


@pytest.mark.parametrize("value", ["0", "-3072", "3072.5", "40000"])
def test_an_encoder_cpr_the_pico_cannot_use_stops_its_build_in_one_line(
    tmp_path: Path, value: str
) -> None:
    """`make -C firmware/pico ENCODER_CPR=0` built a board dividing every speed by zero,
    `-3072` one whose measured speed had the wrong sign (its velocity loop ran a moving
    wheel up to full duty), both exit 0; `3072.5` compiled floating point in."""
    if shutil.which("make") is None:
        pytest.skip("make missing")
    done = subprocess.run(
        [
            "make",
            "-s",
            "-C",
            str(ROOT / "firmware" / "pico"),
            f"BUILD={tmp_path}",
            f"ENCODER_CPR={value}",
            f"PIRATE_BT={sys.executable} -m pirate_bt",
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 2, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert f"ENCODER_CPR={value}: the drive encoders' counts per wheel revolution" in line
    assert "from 1 to 32768" in line
    assert not list(tmp_path.iterdir())


def test_the_chain_counts_encoder_edges_at_the_picos_own_resolution(
    elfs: tuple[Path, Path], tmp_path: Path
) -> None:
    """`make firmware ENCODER_CPR=1024` (docs/board-bus.md: a build option) and the chain:
    its physics turned wheel travel into 3072 counts a revolution whatever the PICO
    divided by, so every speed the boards reported, and the odometry, was 3 times off."""
    bridge, _ = elfs
    made = subprocess.run(
        [
            "make",
            "-s",
            "-C",
            str(ROOT / "firmware" / "pico"),
            f"BUILD={tmp_path}",
            "ENCODER_CPR=1024",
            f"PIRATE_BT={sys.executable} -m pirate_bt",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert made.returncode == 0, made.stderr
    pico = tmp_path / "pico.elf"
    with FirmwareChain(bridge, pico, PipeRobotModel(load_robot(), load_network("straight"))) as c:
        assert c.physics.encoder_cpr == 1024
    with FirmwareChain(*elfs, PipeRobotModel(load_robot(), load_network("straight"))) as c:
        assert c.physics.encoder_cpr == 3072


@pytest.mark.parametrize(
    ("option", "value"),
    [("boot_ms", -5), ("boot_ms", 1.5), ("boot_ms", 120_000), ("speed", float("nan"))],
)
def test_the_firmware_bridge_refuses_a_boot_time_or_speed_the_harness_misreads(
    elfs: tuple[Path, Path], option: str, value: float
) -> None:
    """FirmwareBridge(boot_ms=-5) started: the harness read it as 4294967291 ms, so the
    pty ate every host byte for ever (a HELLO never answered); speed=nan passed its
    `speed <= 0` and paced the MCU to NaN cycles."""
    from pirate_bt.sim.firmware_bridge import FirmwareBridge

    model = PipeRobotModel(load_robot(), load_network("straight"))
    with pytest.raises(InputError, match="must be"):
        FirmwareBridge(elfs[0], model, **{option: value})  # type: ignore[arg-type]


@pytest.mark.parametrize("args", [["--boot-ms", "-5"], ["--boot-ms", "abc"], ["--speed", "nan"]])
def test_the_simavr_harness_refuses_a_boot_time_or_speed_it_would_misread(
    elfs: tuple[Path, Path], args: list[str]
) -> None:
    """pirate-simavr read --boot-ms with atoi ('-5': a bootloader for 49 days) and took
    --speed nan."""
    from pirate_bt.sim.firmware_bridge import find_harness

    done = subprocess.run(
        [str(find_harness()), *args, str(elfs[0])],
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 2, done
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("usage: pirate-simavr")
    assert done.stdout == ""
