"""Builds the reference PICO board firmware (``firmware/pico/``) for the tests.

:func:`build_pico_host` makes the host build of the board logic (``make host``: the
firmware's own C with ``host/host_hal.c`` for the hardware, a shared library driven
through ctypes); :func:`build_pico_elf` the ATmega328p ELF. Both incremental, one
build at a time on this checkout (:func:`firmware_host.build_lock`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from firmware_host import build_lock

__all__ = ["PICO", "build_pico_elf", "build_pico_host"]

PICO = Path(__file__).resolve().parents[1] / "firmware" / "pico"


def _make(*args: str) -> subprocess.CompletedProcess[str]:
    with build_lock():
        return subprocess.run(
            ["make", "-s", "-C", str(PICO), f"PIRATE_BT={sys.executable} -m pirate_bt", *args],
            capture_output=True,
            text=True,
            env={**os.environ, "MAKEFLAGS": ""},
            check=False,
        )


def build_pico_host(
    build: Path, *, encoder_cpr: int | None = None, robot: Path | None = None
) -> Path:
    """The host library of the board logic, built into ``build``.

    ``encoder_cpr``: the build option ``ENCODER_CPR``; ``robot``: the robot description
    (default: the Makefile's, 3072 and ``hardware/pirate.yaml``).

    Raises:
        RuntimeError: no C compiler or make (the message says so), or the build failed.
    """
    if shutil.which("cc") is None or shutil.which("make") is None:
        raise RuntimeError("no host C compiler (cc) or make")
    options = [f"ENCODER_CPR={encoder_cpr}"] if encoder_cpr is not None else []
    options += [f"ROBOT={robot}"] if robot is not None else []
    done = _make(f"BUILD={build}", *options, "host")
    if done.returncode != 0:
        raise RuntimeError(f"building the PICO host library failed:\n{done.stderr}")
    return build / "libpico_host.so"


def build_pico_elf(build: Path | None = None) -> Path:
    """The ATmega328p ELF (default: ``firmware/pico/build/pico.elf``).

    Raises:
        RuntimeError: the build failed (avr-gcc missing, or an error).
    """
    args = [f"BUILD={build}"] if build is not None else []
    done = _make(*args)
    if done.returncode != 0:
        raise RuntimeError(f"building the PICO firmware failed:\n{done.stdout}\n{done.stderr}")
    return (build or PICO / "build") / "pico.elf"
