"""Bridge firmware figures: flash and SRAM, CPU cycles, e-stop latency, stack, soak.

Run with ``.venv/bin/python benchmarks/bench_firmware.py [--soak SECONDS]``; it
prints a Markdown table (the one in ``docs/performance.md``, section Bridge
firmware). It builds ``firmware/piratebay`` for the default robot into a temporary
directory: flash and SRAM come from ``avr-size``; the rest from a scripted run in
simavr (``firmware/piratebay/host/figures.c``, which reads the firmware's GPIOR0
markers and its ``pb_debug`` record, see docs/firmware.md). Simulated time, so the
cycle figures do not depend on the machine's load. Needs gcc-avr, avr-libc and
libsimavr-dev; without simavr only the sizes are printed, without avr-gcc
nothing (``skipped: ...``, exit 0).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIRMWARE = ROOT / "firmware" / "piratebay"
FLASH_BYTES, SRAM_BYTES = 256 * 1024, 8 * 1024
CPU_HZ = 16_000_000


def make(build: Path, *targets: str, soak: float = 0.0) -> str:
    args = [
        "make",
        "-s",
        "-C",
        str(FIRMWARE),
        f"BUILD={build}",
        f"PIRATE_BT={sys.executable} -m pirate_bt",
        *targets,
    ]
    if soak > 0:
        args.append(f"SOAK={soak:g}")
    env = {**os.environ, "MAKEFLAGS": ""}
    result = subprocess.run(args, capture_output=True, text=True, env=env, check=False)
    if result.returncode != 0:
        raise SystemExit(f"bench_firmware: make {' '.join(targets)} failed:\n{result.stderr}")
    return result.stdout


def sizes(elf: Path) -> tuple[int, int]:
    """Flash (.text + .data) and static SRAM (.data + .bss + .noinit) in bytes."""
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True)
    section = {}
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            section[parts[0]] = int(parts[1])
    flash = section[".text"] + section.get(".data", 0)
    sram = section.get(".data", 0) + section.get(".bss", 0) + section.get(".noinit", 0)
    return flash, sram


def simavr_available() -> bool:
    pkg = shutil.which("pkg-config")
    if pkg is None:
        return False
    return subprocess.run([pkg, "--exists", "simavr"], check=False).returncode == 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--soak", type=float, default=60.0, help="seconds of noise (0: none)")
    args = parser.parse_args()
    if shutil.which("avr-gcc") is None:  # as bench_firmware_sim.py: make bench goes on
        print("skipped: avr-gcc is missing (make avr-toolchain installs it)")
        return
    with tempfile.TemporaryDirectory() as tmp:
        build = Path(tmp)
        make(build, "all")
        flash, sram = sizes(build / "piratebay.elf")
        rows = [
            ("flash (.text + .data)", f"{flash} B of 256 KB ({100 * flash / FLASH_BYTES:.1f} %)"),
            (
                "SRAM, static (.data + .bss + .noinit)",
                f"{sram} B of 8 KB ({100 * sram / SRAM_BYTES:.1f} %)",
            ),
        ]
        figures: dict[str, float] = {}
        if simavr_available():
            out = make(build, "figures", soak=args.soak)
            for line in out.splitlines():
                name, _, value = line.partition(" ")
                try:
                    figures[name] = float(value)
                except ValueError:
                    continue
        else:
            print("(libsimavr-dev missing: no cycle figures)", file=sys.stderr)
    if figures:
        period_cycles = CPU_HZ // 100

        def cycles(name: str, what: str) -> tuple[str, str]:
            mean, hi = figures[f"{name}_mean"], figures[f"{name}_max"]
            share = 100 * mean / period_cycles
            return (
                what,
                f"{mean:.0f} cycles mean, {hi:.0f} max"
                f" ({mean / 16:.0f} µs, {share:.1f} % of 10 ms)",
            )

        def micros(name: str, what: str) -> tuple[str, str]:
            return (
                what,
                f"{figures[f'{name}_mean']:.0f} µs mean, {figures[f'{name}_min']:.0f} min,"
                f" {figures[f'{name}_max']:.0f} max (n = {figures[f'{name}_n']:.0f})",
            )

        rows += [
            cycles("state_encode_cycles", "encode one STATE (74-byte body)"),
            cycles("bulk_decode_apply_cycles", "decode and apply one BULK_SETPOINTS (16 motors)"),
            micros("estop_to_stop_on_bus_us", "ESTOP last byte → first STOP byte on the bus"),
            micros("estop_to_stop_queued_us", "ESTOP last byte → STOP queued on the bus"),
            (
                "stack high-water mark",
                f"{figures['stack_high_water_bytes']:.0f} B"
                f" (room: {figures['stack_room_bytes']:.0f} B)",
            ),
            ("MCU resets during the run", f"{figures['mcu_resets']:.0f}"),
        ]
        if "soak_seconds" in figures:
            rows += [
                (
                    f"soak: {figures['soak_seconds']:.0f} s of noise at full line rate",
                    f"{figures['soak_bytes']:.0f} B; corrupted frames applied:"
                    f" {figures['soak_corrupted_applied']:.0f}; longest STATE gap"
                    f" {figures['soak_max_state_gap_ms']:.2f} ms; HELLO answered after:"
                    f" {'yes' if figures['soak_hello_answered'] == 1 else 'NO'}",
                ),
            ]
    print("| figure | value |")
    print("|---|---|")
    for name, value in rows:
        print(f"| {name} | {value} |")


if __name__ == "__main__":
    main()
