"""Probe 17, the embedded side: what a user of the firmwares and their harnesses meets.

Each test here failed before the fix it names in its docstring.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from firmware_chain_support import build_chain, missing_chain

ROOT = Path(__file__).resolve().parents[1]
_PIRATE_BT = (sys.executable, "-m", "pirate_bt")


@pytest.fixture(scope="module")
def chain_builds() -> tuple[Path, Path, Path]:
    """(bridge ELF, PICO ELF, pirate-chain), built; the simavr harness beside it."""
    why = missing_chain()
    if why:
        pytest.skip(why)
    return build_chain()


def _sim(elf: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*_PIRATE_BT, "sim", "straight", "--firmware", str(elf), "--duration", "3"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )


def test_sim_refuses_the_pico_elf_as_the_bridge(chain_builds: tuple[Path, Path, Path]) -> None:
    """`pirate-bt sim --firmware pico.elf` ran the ATmega328p's code on the ATmega2560:
    a pty that never answered, exit 0 and '2029 unexpected MCU resets' in the summary."""
    _, pico, _ = chain_builds
    done = _sim(pico)
    assert done.returncode == 2, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert f"{pico} is built for avr5 (an ATmega328p: a PICO board's firmware?)" in line
    assert "not for the bridge's ATmega2560 (avr6)" in line
    assert "Traceback" not in done.stderr


def test_sim_names_a_hex_file_given_for_the_elf(chain_builds: tuple[Path, Path, Path]) -> None:
    """The .hex beside the ELF (the file a user flashes) said 'the AVR crashed at cycle
    131072 (pc 0x00000)', exit 3, as if the firmware were broken."""
    bridge, _, _ = chain_builds
    hex_file = bridge.with_suffix(".hex")
    assert hex_file.is_file()
    done = _sim(hex_file)
    assert done.returncode == 2, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.endswith(f"{hex_file} is Intel HEX, not an ELF file: give the .elf built beside it")


def test_sim_names_a_file_that_is_no_elf(
    chain_builds: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    """Any other file was loaded as an empty flash: 'the AVR crashed', exit 3."""
    text = tmp_path / "notes.elf"
    text.write_text("not firmware\n")
    done = _sim(text)
    assert done.returncode == 2, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.endswith(f"{text} is not an ELF file")


def test_the_chain_refuses_its_two_elfs_swapped(chain_builds: tuple[Path, Path, Path]) -> None:
    """pirate-chain loaded the bridge's ELF into every PICO core (and the other way
    round) and ran it."""
    bridge, pico, chain = chain_builds
    done = subprocess.run(
        [str(chain), str(pico), str(bridge), "22"],
        input="",
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.strip() == (
        f"pirate-chain: {pico} is built for avr5 (an ATmega328p: a PICO board's firmware?),"
        " not for the bridge's ATmega2560 (avr6)"
    )
    done = subprocess.run(
        [str(chain), "-", str(bridge), "22"],
        input="",
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.strip() == (
        f"pirate-chain: {bridge} is built for avr6 (an ATmega2560: the bridge's firmware?),"
        " not for the PICO board's ATmega328p (avr5)"
    )


def _eighteen_boards(folder: Path) -> Path:
    """The default robot with nine more sensor boards: one more than COUNTERS carries."""
    text = (ROOT / "hardware" / "pirate.yaml").read_text()
    assert text.count("\nclamp:") == 1
    extra = "".join(
        f"  - id: {i}\n    module: rear\n    sensors:\n"
        f"      - {{<<: *angle_sensor, slot: 0, name: extra_{i}_angle}}\n\n"
        for i in range(29, 38)
    )
    path = folder / "eighteen.yaml"
    path.write_text(text.replace("\nclamp:", "\n" + extra + "clamp:"))
    return path


@pytest.mark.skipif(shutil.which("make") is None, reason="make missing")
@pytest.mark.parametrize("firmware", ["piratebay", "pico"])
def test_a_robot_the_protocol_cannot_carry_is_refused_at_its_line(
    firmware: str, tmp_path: Path
) -> None:
    """`make firmware ROBOT=...` with 18 boards wrote the header and failed in the C
    compiler: 'txq.h:24:1: error: static assertion failed: "COUNTERS fits one frame"'
    among the compiler's include trail. `pirate-bt validate` named the file's line."""
    robot = _eighteen_boards(tmp_path)
    build = tmp_path / "build"
    done = subprocess.run(
        [
            *("make", "-s", "-C", str(ROOT / "firmware" / firmware), f"BUILD={build}"),
            *(f"ROBOT={robot}", f"PIRATE_BT={sys.executable} -m pirate_bt"),
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
        timeout=120,
        check=False,
    )
    assert done.returncode != 0
    assert f"{robot}:62:1: robot 'PIRATE 2018': the robot description does not fit" in done.stderr
    assert "18 boards need a 254-byte COUNTERS payload (max 247: 17 boards)" in done.stderr
    assert "static assertion" not in done.stdout + done.stderr
    assert not (build / "layout.h").exists()


@pytest.fixture(scope="module")
def id_build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One build folder for the `make id` tests: its layout.h is generated once."""
    return tmp_path_factory.mktemp("pico-id") / "build"


def _make_id(board_id: str, build: Path) -> subprocess.CompletedProcess[str]:
    """`make -C firmware/pico id ID=...` with `echo` for avrdude: what it would run."""
    return subprocess.run(
        [
            *("make", "-s", "-C", str(ROOT / "firmware" / "pico"), "id", f"ID={board_id}"),
            *(f"BUILD={build}", "AVRDUDE=echo", f"PIRATE_BT={sys.executable} -m pirate_bt"),
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
        timeout=120,
        check=False,
    )


@pytest.mark.skipif(shutil.which("make") is None, reason="make missing")
@pytest.mark.parametrize("board_id", ["300", "29", "022", "22 23", "0x16"])
def test_make_id_writes_only_a_board_of_the_robot(board_id: str, id_build: Path) -> None:
    """`make -C firmware/pico id ID=300` had avrdude write 0x12c,0x...ffd3 to the EEPROM,
    ID=022 wrote id 18 (printf read it as octal), and ID=29 an id no board of the robot
    has: each a board that never answers on the bus."""
    done = _make_id(board_id, id_build)
    assert done.returncode == 2
    assert "eeprom:w:" not in done.stdout
    robot = ROOT / "hardware" / "pirate.yaml"
    assert (
        f"make id: ID={board_id} is not a board of {robot}"
        " (its boards: 20 21 22 23 24 25 26 27 28): nothing written"
    ) in done.stderr


@pytest.mark.skipif(shutil.which("make") is None, reason="make missing")
def test_make_id_writes_the_id_and_its_complement(id_build: Path) -> None:
    done = _make_id("22", id_build)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("-U eeprom:w:0x16,0xe9:m")


@pytest.mark.skipif(
    shutil.which("avr-gcc") is None or shutil.which("avr-size") is None,
    reason="avr-gcc/avr-size missing: install Debian's gcc-avr and avr-libc (make firmware does)",
)
@pytest.mark.parametrize("firmware", ["piratebay", "pico"])
def test_the_sizes_docs_firmware_md_shows_are_the_builds(firmware: str, tmp_path: Path) -> None:
    """docs/firmware.md showed `make firmware` printing flash 8966 and 8152 bytes; the
    builds took 8970 and 8216 (the last firmware commits did not update it)."""
    done = subprocess.run(
        [
            *("make", "-s", "-C", str(ROOT / "firmware" / firmware), f"BUILD={tmp_path}"),
            f"PIRATE_BT={sys.executable} -m pirate_bt",
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    (line,) = [x for x in done.stdout.splitlines() if x.startswith(f"{firmware}.elf: flash ")]
    assert line in (ROOT / "docs" / "firmware.md").read_text().splitlines()


@pytest.mark.skipif(shutil.which("make") is None, reason="make missing")
@pytest.mark.parametrize(
    ("option", "message"),
    [
        ("ESTOP_INPUT=None", "ESTOP_INPUT=None: choose d22 (the button input on D22) or none"),
        ("ESTOP_INPUT=no", "ESTOP_INPUT=no: choose d22 (the button input on D22) or none"),
        (
            "HOST_LINK=USB",
            "HOST_LINK=USB: choose usb (the Mega's USB port) or adapter"
            " (a USB-serial adapter on D0/D1)",
        ),
    ],
)
def test_a_misspelt_build_option_is_refused(option: str, message: str, tmp_path: Path) -> None:
    """`make firmware ESTOP_INPUT=None` built the bridge with its e-stop input (only the
    exact word `none` drops it): a bench Mega without a button then boots latched and
    answers every ESTOP_RESET `NACK NOT_READY`."""
    done = subprocess.run(
        [
            *("make", "-s", "-C", str(ROOT / "firmware" / "piratebay"), f"BUILD={tmp_path}"),
            *(option, f"PIRATE_BT={sys.executable} -m pirate_bt"),
        ],
        capture_output=True,
        text=True,
        env={**os.environ, "MAKEFLAGS": ""},
        timeout=120,
        check=False,
    )
    assert done.returncode == 2
    assert f"*** {message}.  Stop." in done.stderr
    assert not (tmp_path / "piratebay.elf").exists()
