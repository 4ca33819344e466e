"""Firmware figures end to end: the PIRATEbay ELF in the simavr harness, through its pty.

Run: ``.venv/bin/python benchmarks/bench_firmware_sim.py [--soak SECONDS]`` (default
60). The same figures as ``bench_firmware.py`` (which runs a scripted host inside
simavr, in simulated time), measured here on the path a user takes: the harness of
``pirate-bt sim --firmware`` in real time, the host writing to its pty, the Python
boards with the pipe physics on its RS485 bus. Builds the ELF and the harness with
``make`` if needed (needs gcc-avr, avr-libc, libsimavr-dev; ``make test`` installs
them). Prints the figures that
``docs/performance.md`` quotes under "Bridge firmware in the simulator":

- flash and SRAM use (``avr-size -A``: flash = .text + .data, SRAM = .data +
  .bss + .noinit, against the ATmega2560's 256 KB and 8 KB);
- CPU cycles to encode one STATE frame and to decode and apply one
  BULK_SETPOINTS frame, from the firmware's GPIOR0 markers timed with simavr's
  cycle counter (docs/firmware.md), as a share of the 100 Hz cycle (160 000
  cycles at 16 MHz);
- the time from the last byte of an ESTOP frame entering USART0 to the first byte
  of a STOP frame written to USART1, in microseconds of MCU time (40 e-stops at
  spread phases of the state period);
- the stack's high-water mark (the firmware's painted stack, read from its
  ``pb_debug`` record);
- the robustness soak: random bytes and corrupted SETPOINT frames at the full
  115200-baud line rate, then: MCU resets other than the host's open, corrupted
  frames the boards saw applied, HELLO answered.

The harness runs in real time on a shared machine, so the soak's wall time is
the MCU's time only while the harness keeps up (``lag events`` counts the
times it fell more than 200 ms behind and skipped ahead).
"""

from __future__ import annotations

import argparse
import random
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from firmware_sim_support import (
    HostEnd,
    build,
    missing_toolchain,
    poison_for,
    release,
    soak,
    wait_line_drained,
)

from pirate_bt.link.messages import BulkSetpoints, EStop, EStopReset
from pirate_bt.pipes import load_network
from pirate_bt.robot import load_robot
from pirate_bt.robot.description import RobotDescription
from pirate_bt.sim.firmware_bridge import FirmwareBridge
from pirate_bt.sim.model import PipeRobotModel

CYCLE_100HZ = 160_000
FLASH, SRAM = 256 * 1024, 8 * 1024


def sizes(elf: Path) -> tuple[int, int]:
    out = subprocess.run(["avr-size", "-A", str(elf)], capture_output=True, text=True, check=True)
    sections: dict[str, int] = {}
    for line in out.stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sections[parts[0]] = int(parts[1])
    flash = sections.get(".text", 0) + sections.get(".data", 0)
    sram = sum(sections.get(s, 0) for s in (".data", ".bss", ".noinit"))
    return flash, sram


def full_bulk(robot: RobotDescription, seq: int) -> BulkSetpoints:
    """Every motor set (the most work a BULK_SETPOINTS asks): its first mode, value 0."""
    modes = []
    raws = []
    for slot in robot.setpoint_slots():
        mode = slot.motor.modes.available()[0]
        conversion = slot.motor.modes.get(mode)
        assert conversion is not None
        modes.append(mode)
        raws.append(conversion.to_raw(0.0))
    return BulkSetpoints(seq, tuple(modes), tuple(raws))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--soak", type=float, default=60.0, help="seconds of noise (default 60)")
    args = parser.parse_args()
    reason = missing_toolchain()
    if reason is not None:
        print(f"skipped: {reason}")
        return 0
    elf, harness = build()
    robot = load_robot()
    flash, sram = sizes(elf)
    print(f"flash            {flash:7d} B of {FLASH} ({100 * flash / FLASH:.1f} %)")
    print(f"SRAM (static)    {sram:7d} B of {SRAM} ({100 * sram / SRAM:.1f} %)")
    model = PipeRobotModel(robot, load_network("straight"))
    poison = poison_for(robot)
    with FirmwareBridge(elf, model, harness=harness, boot_ms=0) as bridge:
        host = HostEnd(bridge.start(), robot)
        time.sleep(0.1)
        assert host.hello() is not None, "no HELLO reply"
        assert release(host), "the boot latch was not released"
        for _ in range(200):  # 2 s of bulk setpoints at 100 Hz
            host.send(full_bulk(robot, host.next_seq()))
            host.read(0.01)
        rng = random.Random(14)
        for _ in range(40):  # e-stops at spread phases of the state period
            host.read(0.015 + rng.random() * 0.01)
            host.send(EStop(host.next_seq()))
            host.read(0.03)
            host.send(EStopReset(host.next_seq()))
        host.read(0.05)
        f = bridge.figures()
        state = f["state_encode_cycles_mean"]
        bulk = f["bulk_decode_apply_cycles_mean"]
        print(
            f"STATE encode     {state:7.0f} cycles (max {f['state_encode_cycles_max']:.0f},"
            f" n {f['state_encode_cycles_n']:.0f}) = {100 * state / CYCLE_100HZ:.2f} %"
            " of the 100 Hz cycle"
        )
        print(
            f"BULK decode+apply{bulk:7.0f} cycles (max {f['bulk_decode_apply_cycles_max']:.0f},"
            f" n {f['bulk_decode_apply_cycles_n']:.0f}) = {100 * bulk / CYCLE_100HZ:.2f} %"
            " of the 100 Hz cycle"
        )
        print(
            f"ESTOP -> STOP    {f['estop_to_bus_stop_us_mean']:7.0f} us mean"
            f" (min {f['estop_to_bus_stop_us_min']:.0f}, max {f['estop_to_bus_stop_us_max']:.0f},"
            f" n {f['estop_to_bus_stop_us_n']:.0f})"
        )
        assert release(host), "the e-stop latch was not released"
        t0 = time.monotonic()
        sent = soak(host, poison, args.soak)
        wall = time.monotonic() - t0
        drained_s = wait_line_drained(bridge)
        reply = host.hello()
        f = bridge.figures()
        hello_ok = reply is not None and reply.layout_digest == host.codec.layout.digest
        applied = bridge.boards.applied[poison.key()]
        print(
            f"soak             {wall:7.1f} s, {sent} bytes ({sent / wall:.0f} B/s);"
            f" unexpected MCU resets {f['unexpected_resets']:.0f};"
            f" corrupted frames applied {applied}; HELLO after: {'ok' if hello_ok else 'NONE'};"
            f" lag events {f['lag_events']:.0f} (the MCU caught up with the line in"
            f" {drained_s:.1f} s)"
        )
        print(
            f"stack high-water {f['stack_high_water_bytes']:7.0f} B"
            f" (room {f['stack_room_bytes']:.0f} B)"
        )
        host.close()
    ok = hello_ok and applied == 0 and f["unexpected_resets"] == 0
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
