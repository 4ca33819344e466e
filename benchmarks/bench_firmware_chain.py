"""Figures of the whole embedded chain: the bridge and nine PICO boards in simavr.

Run: ``.venv/bin/python benchmarks/bench_firmware_chain.py [--pabs]``. Builds the
bridge ELF, the PICO ELF and the ``pirate-chain`` harness if needed (needs gcc-avr,
avr-libc, libsimavr-dev; ``make test`` installs them) and prints the figures that
``docs/performance.md`` quotes under "The whole chain in simavr":

- flash and static SRAM of both firmwares (``avr-size -A``: flash = .text + .data,
  SRAM = .data + .bss + .noinit);
- the stack's high-water mark of the bridge and of the worst PICO board (painted
  stacks, read from ``pb_debug`` and ``pico_debug`` after a second of running);
- the bus cycle: from the start of the request to the first board to the end of the
  last board's reply, with nine boards at 1 Mbaud (min, mean, max over a second);
- a host ``ESTOP`` (from its frame's last byte entering the bridge), the hardware
  e-stop input (from the contact opening) and a killed bridge (from its halt) to
  every drive, rotate and other motor's H-bridge off or braking, with every drive
  running at 5 cm/s and both halves clamped before;
- the chain's speed against real time (simulated seconds per wall second, the
  Python physics and host included), and, with ``--pabs``, the straight and bend
  PABs through the chain with their simulated and wall times.

All times but the speed are simulated (MCU cycles), so the machine's load does not
change them.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from firmware_chain_support import (
    build_chain,
    missing_chain,
    open_chain,
    run_tree,
    stop_scenario,
)


def _size(elf: Path, flash_total: int, sram_total: int) -> str:
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True)
    sizes = {}
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sizes[parts[0]] = int(parts[1])
    flash = sizes[".text"] + sizes.get(".data", 0)
    sram = sizes.get(".data", 0) + sizes.get(".bss", 0) + sizes.get(".noinit", 0)
    return (
        f"flash {flash} B of {flash_total // 1024} KB ({100 * flash / flash_total:.1f} %), "
        f"static SRAM {sram} B of {sram_total // 1024} KB ({100 * sram / sram_total:.1f} %)"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pabs", action="store_true", help="also run the PABs (minutes)")
    args = parser.parse_args()
    why = missing_chain()
    if why:
        print(f"skipped: {why}")
        return 0
    bridge, pico, _ = build_chain()
    print(f"bridge (ATmega2560): {_size(bridge, 256 * 1024, 8 * 1024)}")
    print(f"PICO (ATmega328p):   {_size(pico, 32 * 1024, 2 * 1024)}")

    with open_chain() as (chain, _clock):
        start = time.perf_counter()
        chain.advance_to(1.0)
        wall = time.perf_counter() - start
        figures = chain.figures()
    print(
        f"stack high-water: bridge {figures['bridge_stack_high_water_bytes']:.0f} B, "
        f"worst PICO {figures['pico_stack_high_water_bytes']:.0f} B"
    )
    print(
        f"bus cycle, 9 boards at 1 Mbaud: {figures['bus_cycle_us_min']:.0f} us min, "
        f"{figures['bus_cycle_us_mean']:.0f} mean, {figures['bus_cycle_us_max']:.0f} max"
        f" (n {figures['bus_cycle_us_n']:.0f}; the max is the boot's cycle, STOPs first)"
    )
    print(f"speed, 1 s idle: {1.0 / wall:.2f} x real time ({wall:.2f} s wall)")

    for cause, what in (
        ("host", "host ESTOP (frame's last byte in)"),
        ("input", "e-stop input (contact opens)"),
        ("master_silent", "bridge killed"),
    ):
        scenario = stop_scenario(cause)
        times = scenario.times.per_motor_s
        drives = {k: v for k, v in times.items() if k in scenario.running_before}
        held = all(drive == 2 for drive, _ in scenario.joints_after.values())
        print(
            f"{what} -> every PWM at 0: {1000 * scenario.times.all_stopped_s:.2f} ms "
            f"(drives {1000 * min(drives.values()):.2f}..{1000 * max(drives.values()):.2f} ms;"
            f" clamps {'held' if held else 'RELEASED'})"
        )

    if args.pabs:
        for network, tree, params in (
            ("straight", "straight", {"distance": "1m"}),
            ("bend-right", "bend", {"roll": "90deg"}),
        ):
            with open_chain(network) as (chain, clock):
                start = time.perf_counter()
                result = run_tree(chain, clock, tree, params, "120 s")
                wall = time.perf_counter() - start
            print(
                f"PAB {tree} in {network}: {'SUCCESS' if result.succeeded else 'FAILURE'},"
                f" {chain.now_s:.1f} s simulated in {wall:.1f} s wall"
                f" ({chain.now_s / wall:.2f} x real time)"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
