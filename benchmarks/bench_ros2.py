"""What ``--ros2`` costs on the lab mission, as ratios within one run of this script.

Run: ``.venv/bin/python benchmarks/bench_ros2.py [PAIRS] [--no-subscriber]`` (default 4
ABBA pairs), and ``.venv/bin/python benchmarks/bench_ros2.py --estop [COUNT]`` for the
e-stop's latency.

The lab mission (``pirate-bt mission scenarios/lab.route --sim lab --quiet``)
is run as a command without and with ``--ros2 tcp/127.0.0.1:PORT``, in ABBA
order (off, on, on, off) repeated, so that a noisy, shared machine hits both
alike. A Zenoh router runs in this process (as ``rmw_zenohd`` would), and an
independent ROS 2 client (``zenoh-ros2-sdk``) is subscribed to every topic and
decodes everything it gets, so the figure includes real subscribers on the same
machine (``--no-subscriber``: the router alone, as when the tools that watch run
elsewhere).

Two figures per pair, each as *on / off - 1*:

- **command**: the wall time of the whole command (Python start, imports, the
  Zenoh session and the type store included, the same start-up on both sides
  but for what ``--ros2`` adds);
- **run**: the mission's own wall time as the command reports it (``s wall``
  in its summary), which leaves out start-up.

Also the CPU time (user and system) of the command with its child processes,
the publishing process included, as seconds added per run (the median over the
pairs): what ``--ros2`` costs the machine rather than the run; and the CPU time
this process (the router and the subscriber) spent during the runs with
``--ros2``.

Printed: the median and range over the pairs, the load average before and
after, and the messages received.

``--estop``: a simulated run (the straight pipe, paced to wall time, 20 Hz) with
the node, and COUNT ``std_msgs/Bool`` ``true`` messages put on ``/pirate/estop``
by a Zenoh publisher in this process, 0.20-0.25 s apart; for each, how long it took
to reach the publishing process, to be queued for the supervisor in the run's
process, and to be applied by the supervisor's next tick (median and maximum).
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import resource
import socket
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
PIRATE_BT = str(Path(sys.executable).with_name("pirate-bt"))
MISSION = [PIRATE_BT, "mission", "scenarios/lab.route", "--sim", "lab", "--quiet"]
_WALL = re.compile(r"([0-9.]+) s wall")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _run(extra: list[str]) -> tuple[float, float, float]:
    cpu = _cpu()
    started = time.perf_counter()
    done = subprocess.run([*MISSION, *extra], cwd=ROOT, check=True, capture_output=True, text=True)
    command = time.perf_counter() - started
    found = _WALL.search(done.stdout + done.stderr)
    return command, float(found.group(1)) if found else float("nan"), _cpu() - cpu


def _router(port: int) -> Any:
    import zenoh

    config = zenoh.Config()
    for key, value in (
        ("mode", "router"),
        ("listen/endpoints", [f"tcp/127.0.0.1:{port}"]),
        ("scouting/multicast/enabled", False),
    ):
        config.insert_json5(key, json.dumps(value))
    return zenoh.open(config)


def _consumer(port: int) -> tuple[Any, list[Any], dict[str, list[Any]]]:
    from zenoh_ros2_sdk import ROS2Subscriber, message_registry

    from pirate_bt.interop.rmw_zenoh import qualified_name
    from pirate_bt.interop.ros2_topics import TOPIC_TYPES

    router = _router(port)
    message_registry._registry = message_registry.MessageRegistry(
        str(ROOT / "tests" / "data" / "ros2_msgs")
    )
    got: dict[str, list[Any]] = {}
    subs = []
    for topic, type_name in TOPIC_TYPES.items():
        got[topic] = []
        subs.append(
            ROS2Subscriber(
                topic=qualified_name("/pirate", topic),
                msg_type=type_name,
                callback=got[topic].append,
                router_ip="127.0.0.1",
                router_port=port,
                domain_id=0,
            )
        )
    return router, subs, got


def _own_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main(pairs: int, *, subscriber: bool = True) -> None:
    port = _free_port()
    if subscriber:
        router, subs, got = _consumer(port)
    else:
        router, subs, got = _router(port), [], {}
    on = ["--ros2", f"tcp/127.0.0.1:{port}"]
    load = os.getloadavg()
    _run([])  # warm the file cache
    command: list[float] = []
    run: list[float] = []
    cpu: list[float] = []
    listener: list[float] = []

    def run_on() -> tuple[float, float, float]:
        before = _own_cpu()
        result = _run(on)
        listener.append(_own_cpu() - before)
        return result

    for _ in range(pairs):
        a1 = _run([])
        b1 = run_on()
        b2 = run_on()
        a2 = _run([])
        command.append((b1[0] + b2[0]) / (a1[0] + a2[0]) - 1.0)
        run.append((b1[1] + b2[1]) / (a1[1] + a2[1]) - 1.0)
        cpu.append((b1[2] + b2[2] - a1[2] - a2[2]) / 2)
        print(
            f"pair: off {a1[0]:.2f}/{a2[0]:.2f} s, on {b1[0]:.2f}/{b2[0]:.2f} s (command);"
            f" run {a1[1]:.2f}/{a2[1]:.2f} vs {b1[1]:.2f}/{b2[1]:.2f} s;"
            f" CPU {a1[2]:.2f}/{a2[2]:.2f} vs {b1[2]:.2f}/{b2[2]:.2f} s;"
            f" load {os.getloadavg()[0]:.2f}",
            flush=True,
        )
    time.sleep(0.5)
    received = sum(len(v) for v in got.values())
    for sub in subs:
        sub.close()
    router.close()

    def figure(values: list[float]) -> str:
        return (
            f"{statistics.median(values) * 100:+.1f} %"
            f" ({min(values) * 100:+.1f} to {max(values) * 100:+.1f} %)"
        )

    who = "one subscriber on every topic" if subscriber else "a router, no subscriber"
    print(f"--ros2 on the lab mission, {pairs} ABBA pairs, {who}:")
    print(f"  whole command: {figure(command)}")
    print(f"  the run itself: {figure(run)}")
    print(
        "  CPU added per run, the run's process and the node's:"
        f" {statistics.median(cpu):+.3f} s ({min(cpu):+.3f} to {max(cpu):+.3f} s)"
    )
    print(
        "  CPU of the router and the subscriber (this process) per run:"
        f" {statistics.median(listener):.3f} s"
    )
    if subscriber:
        print(f"  messages received by the independent client: {received} over {2 * pairs} runs")
    after = os.getloadavg()
    print(
        f"  load average (1, 5, 15 min) before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f},"
        f" after {after[0]:.2f} {after[1]:.2f} {after[2]:.2f} on {os.cpu_count()} CPUs"
    )


def estop_latency(count: int) -> None:
    """See the module docstring (``--estop``)."""
    import threading

    import pirate_bt
    from pirate_bt.interop import rmw_zenoh
    from pirate_bt.interop.ros2_cdr import bool_message
    from pirate_bt.interop.ros2_live import Ros2Node
    from pirate_bt.interop.ros2_types import dds_type_name, type_hash

    port = _free_port()
    router = _router(port)
    node = Ros2Node(f"tcp/127.0.0.1:{port}")
    assert node.wait_ready() and node.estop is not None
    estop = node.estop
    key = rmw_zenoh.data_key(
        0, "/pirate/estop", dds_type_name("std_msgs/msg/Bool"), type_hash("std_msgs/msg/Bool")
    )
    publisher = router.declare_publisher(key)
    rows: list[tuple[float, float, float]] = []
    warmed = threading.Event()

    def press() -> None:
        while estop.received == 0:  # until routing is up (each one is an e-stop too)
            publisher.put(bool_message(True))
            time.sleep(0.05)
        warmed.set()
        for _ in range(count):
            time.sleep(0.2 + random.uniform(0.0, 0.05))  # at any phase of the 50 ms tick
            before = estop.estops
            sent = time.monotonic_ns()
            publisher.put(bool_message(True))
            deadline = time.monotonic() + 5.0
            while estop.estops == before and time.monotonic() < deadline:
                time.sleep(0.0005)
            if estop.estops > before:
                rows.append(
                    (
                        (estop.heard_ns - sent) / 1e6,
                        (estop.queued_ns - sent) / 1e6,
                        (estop.drained_ns - sent) / 1e6,
                    )
                )

    thread = threading.Thread(target=press, daemon=True)
    load = os.getloadavg()
    thread.start()
    # An e-stop latches and the tree's step runs on (its commands refused) to the limit.
    pirate_bt.simulate_tree(
        "straight",
        params={"distance": "10 m"},
        ros2=node,
        realtime=True,
        max_time=f"{count * 0.2 + 8:.0f} s",
    )
    thread.join()
    node.close()
    publisher.undeclare()
    router.close()
    print(f"e-stop from the graph, {len(rows)} of {count} (20 Hz run paced to wall time):")
    for index, label in enumerate(
        ("reached the publishing process", "queued in the run's process", "applied by a tick")
    ):
        values = sorted(r[index] for r in rows)
        if values:
            print(f"  {label}: median {statistics.median(values):.2f} ms, max {values[-1]:.2f} ms")
    print(f"  load average before {load[0]:.2f}, after {os.getloadavg()[0]:.2f}")


def cli(argv: list[str] | None = None) -> int:
    """The command line of the module docstring."""
    from report import positive, skip_without

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("pairs", nargs="?", type=positive, default=4, help="ABBA pairs (4)")
    parser.add_argument("--no-subscriber", action="store_true", help="the router alone")
    parser.add_argument(
        "--estop", nargs="?", type=positive, const=20, metavar="COUNT", help="e-stop latency"
    )
    args = parser.parse_args(argv)
    skip_without(["zenoh"], "ros2")
    if args.estop is None and not args.no_subscriber:  # the independent client
        skip_without(["zenoh_ros2_sdk"], "dev")
    if args.estop is not None:
        estop_latency(args.estop)
    else:
        main(args.pairs, subscriber=not args.no_subscriber)
    return 0


if __name__ == "__main__":
    raise SystemExit(cli())
