"""``pirate-bt sim [NETWORK]``: the simulator on a pty or TCP port, in real time.

Prints where a host can connect (a device path, or a ``socket://`` URL) on the
first line of stdout, then serves until interrupted or ``--duration`` has
passed, and prints the simulator's counters when it stops.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from pirate_bt.errors import InputError


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
    parser.add_argument("--seed", type=int, default=0, help="seed of the sensor noise")
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


def run(args: argparse.Namespace) -> int:
    from pirate_bt.robot import load_robot
    from pirate_bt.sim import SensorNoise, Simulator
    from pirate_bt.sim.server import SimServer

    if args.speed <= 0:
        raise InputError("--speed must be positive")
    robot = load_robot(args.robot)
    noise = SensorNoise.typical() if args.noise else None
    sim = Simulator(args.network, robot, seed=args.seed, noise=noise, faults=args.fault)
    server = SimServer(sim, speed=args.speed)
    try:
        if args.tcp is not None:
            host, port = server.open_tcp(args.tcp)
            print(f"socket://{host}:{port}", flush=True)
        else:
            print(server.open_pty(), flush=True)
        with contextlib.suppress(KeyboardInterrupt):
            server.serve_forever(args.duration)
    finally:
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
    return 0
