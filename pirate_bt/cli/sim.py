"""``pirate-bt sim [NETWORK]``: the simulator on a pty or TCP port, in real time.

Prints where a host can connect (a device path, or a ``socket://`` URL) on the
first line of stdout, then serves until interrupted or ``--duration`` has
passed, and prints the simulator's counters when it stops.

With ``--firmware PATH.elf`` the bridge is the real PIRATEbay firmware in simavr
(``firmware/simavr/``) on a pty, and only the boards on its RS485 bus are
simulated in Python (:mod:`pirate_bt.sim.boardbus`), with the same physics.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import signal
import sys
import time
from typing import TYPE_CHECKING

from pirate_bt.errors import InputError, LinkError

__all__ = ["configure", "run"]

if TYPE_CHECKING:
    from pathlib import Path

    from pirate_bt.robot.description import RobotDescription


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "network",
        nargs="?",
        default="lab",
        help="pipe network file, or a bundled name (default: lab)",
    )
    parser.add_argument("--robot", metavar="FILE", help="robot description (default: bundled)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--pty", action="store_true", help="serve on a pseudo-terminal (default)")
    where.add_argument(
        "--tcp", type=int, metavar="PORT", help="serve on 127.0.0.1:PORT (0 picks a free port)"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=None,
        metavar="N",
        help="seed of --noise's sensor noise (default 0); nothing else in the simulator is random",
    )
    parser.add_argument("--noise", action="store_true", help="add typical sensor noise")
    parser.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="KIND[:TARGET]@AT[+DUR]",
        help="inject a fault, e.g. board_reset:22@10s or link_loss@5s+1s (repeatable)",
    )
    parser.add_argument(
        "--speed", type=float, default=1.0, help="simulated seconds per wall second (default 1)"
    )
    parser.add_argument(
        "--duration", type=float, metavar="SECONDS", help="stop after this many wall seconds"
    )
    parser.add_argument(
        "--firmware",
        metavar="ELF",
        help="run this bridge firmware (piratebay.elf) in simavr on the pty instead of"
        " the Python bridge; needs `make -C firmware/simavr`",
    )
    parser.add_argument(
        "--boot-ms",
        type=int,
        default=None,
        metavar="MS",
        help="with --firmware: bootloader time after the DTR reset a host's open causes"
        " (default 500; the host waits the robot's reset_time)",
    )
    from pirate_bt.interop.foxglove_option import add_foxglove_option

    add_foxglove_option(parser)
    from pirate_bt.interop.ros2_option import add_ros2_options

    add_ros2_options(parser)


MAX_SPEED = 100.0
"""The fastest ``--speed``: the physics and its 100 Hz frames keep up with it on the
project's machine (a simulator in process runs about 130 times real time), and a host
on the line must read every frame as fast."""


def run(args: argparse.Namespace) -> int:
    from pirate_bt.robot import load_robot
    from pirate_bt.sim import SensorNoise, Simulator
    from pirate_bt.sim.server import SimServer

    if not (math.isfinite(args.speed) and 0 < args.speed <= MAX_SPEED):
        # 1e308 was taken: every turn of the serving loop then asked the physics for
        # ever more simulated time and the simulator fell behind the wall clock for good
        raise InputError(
            f"--speed must be more than 0 and at most {MAX_SPEED:g} simulated seconds per"
            f" wall second, not {args.speed:g}"
        )
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, not {args.duration:g}")
    from pirate_bt.api.options import seed_value

    if args.seed is not None:
        seed_value(args.seed, "--seed")  # as run, mission and teleop: it served seed -1
        if not args.noise:
            # it seeds the sensor noise and nothing else: without --noise it was taken
            # and served the same simulator whatever it was, without a word
            raise InputError(
                "--seed is for --noise (it seeds the sensor noise; without noise nothing"
                " in the simulator is random): add --noise or leave it out"
            )
    else:
        args.seed = 0
    if args.tcp is not None and not 0 <= args.tcp <= 65535:
        raise InputError(f"--tcp {args.tcp}: a port is 0 to 65535 (0 picks a free one)")
    if args.firmware is None and args.boot_ms is not None:
        raise InputError(
            "--boot-ms is for --firmware (the bridge's bootloader time):"
            " add --firmware ELF or drop it"
        )
    args.network = _network_file(args.network)
    robot = load_robot(args.robot)
    if args.firmware is not None:
        return _run_firmware(args, robot)
    from pirate_bt.cli.faults_option import check_fault_options

    check_fault_options(args.fault, robot)  # named as typed: it said "faults: ..."
    noise = SensorNoise.typical() if args.noise else None
    from pirate_bt.cli.run import open_foxglove, open_ros2

    # the simulator first: its network's faults are checked as it is made, and a bad one
    # said after a live view had been opened and announced (and left open)
    sim = Simulator(args.network, robot, seed=args.seed, noise=noise, faults=args.fault)
    try:
        server = SimServer(sim, speed=args.speed)
        foxglove = open_foxglove(args)
        try:
            ros2 = open_ros2(args, estop=False)  # no supervisor: no e-stop to hear
        except BaseException:
            if foxglove is not None:
                foxglove.close()
            raise
    except BaseException:
        sim.close()
        raise
    halt = None
    if foxglove is not None:
        from pirate_bt.interop.foxglove_live import publish_simulator

        halt = publish_simulator(foxglove, sim)
    halt_ros2 = None
    if ros2 is not None:
        from pirate_bt.interop.ros2_live import publish_simulator as publish_ros2

        halt_ros2 = publish_ros2(ros2, sim)
    try:
        if args.tcp is not None:
            host, port = server.open_tcp(args.tcp)
            print(f"socket://{host}:{port}", flush=True)
        else:
            print(server.open_pty(), flush=True)
        with contextlib.suppress(KeyboardInterrupt):
            server.serve_forever(args.duration)
    finally:
        if halt is not None:
            halt()
        if foxglove is not None:
            foxglove.close()
        if halt_ros2 is not None:
            halt_ros2()
        if ros2 is not None:
            ros2.close()
        server.close()
        sim.close()
    c = sim.counters()
    print(
        f"simulated {sim.clock.now():.1f} s: {c.distance_m:.2f} m travelled,"
        f" {c.violation_count} violations, {c.damage_count} damage, {c.stuck_events} stuck,"
        f" {c.frames_received} frames in, {c.frames_rejected} rejected,"
        f" {c.commands_executed} commands",
        file=sys.stderr,
    )
    from pirate_bt.sim.server import BACKLOG_BYTES, end_state

    if server.frames_dropped:  # whole frames, beyond the backlog a host left unread
        print(
            f"{server.frames_dropped} frames dropped ({server.bytes_dropped} bytes): a host"
            f" did not read while {BACKLOG_BYTES // 1024} KiB of them waited",
            file=sys.stderr,
        )

    print(end_state(sim), file=sys.stderr)
    return 0


def _network_file(name: str) -> Path:
    """The network file ``NETWORK`` names, found as ``run --sim`` finds it: an unknown
    name is told with the bundled names, not as a bundled path nobody typed."""
    from pirate_bt.task.networks import resolve_network_path

    try:
        return resolve_network_path(str(name))
    except FileNotFoundError as exc:
        raise InputError(str(exc)) from None


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _run_firmware(args: argparse.Namespace, robot: RobotDescription) -> int:
    """``--firmware``: the ELF in simavr on a pty, the boards in Python."""
    from pirate_bt.pipes import load_network
    from pirate_bt.sim import SensorNoise
    from pirate_bt.sim.firmware_bridge import FirmwareBridge
    from pirate_bt.sim.model import PipeRobotModel

    if args.tcp is not None:
        raise InputError("--firmware serves on a pty only (the Arduino's USB serial); drop --tcp")
    if args.fault:
        raise InputError("--fault is not supported with --firmware (the bridge is the firmware)")
    for option in ("foxglove", "ros2"):
        if getattr(args, option) is not None:  # it was dropped without a word, exit 0
            raise InputError(
                f"--{option} is not served with --firmware (it shows the Python"
                " simulator); drop one of them"
            )
    boot_ms = 500 if args.boot_ms is None else args.boot_ms
    if boot_ms < 0:
        raise InputError("--boot-ms must not be negative")
    network = load_network(args.network)
    noise = SensorNoise.typical() if args.noise else None
    model = PipeRobotModel(robot, network, seed=args.seed, noise=noise)
    bridge = FirmwareBridge(args.firmware, model, boot_ms=boot_ms, speed=args.speed)
    signal.signal(signal.SIGTERM, _interrupt)  # a terminated server still reports
    print(bridge.start(), flush=True)
    try:
        with contextlib.suppress(KeyboardInterrupt):
            deadline = None if args.duration is None else time.monotonic() + args.duration
            while bridge.running and (deadline is None or time.monotonic() < deadline):
                time.sleep(0.05)
    finally:
        bridge.close()
    if bridge.error is not None:
        raise LinkError(bridge.error)
    c = model.counters()
    f = bridge.final_figures or {}
    # Every bus frame with a good CRC, as the harness counts them: the boards in
    # Python see only the frames that differ from the last one to their board.
    exchanges = int(f.get("bus_replies", 0) + f.get("bus_unanswered", 0))
    print(
        f"simulated {model.time_s:.1f} s: {c.distance_m:.2f} m travelled,"
        f" {c.violation_count} violations, {c.damage_count} damage, {c.stuck_events} stuck;"
        f" firmware: {int(f.get('unexpected_resets', 0))} unexpected MCU resets,"
        f" {int(f.get('dtr_resets', 0))} DTR resets, stack high-water"
        f" {int(f.get('stack_high_water_bytes', 0))} B, {exchanges} board exchanges,"
        f" {int(f.get('bus_stops', 0))} stops, {int(f.get('lag_events', 0))} times"
        " behind real time",
        file=sys.stderr,
    )
    return 0
