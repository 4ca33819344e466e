"""What ``--ros2`` costs on the lab mission, as ratios within one run of this script.

Run: ``.venv/bin/python benchmarks/bench_ros2.py [PAIRS]`` (default 4 ABBA pairs).

The lab mission (``pirate-bt mission scenarios/lab.route --sim lab --quiet``)
is run as a command without and with ``--ros2 tcp/127.0.0.1:PORT``, in ABBA
order (off, on, on, off) repeated, so that a noisy, shared machine hits both
alike. A Zenoh router runs in this process (as ``rmw_zenohd`` would), and an
independent ROS 2 client (``zenoh-ros2-sdk``) is subscribed to every topic and
decodes everything it gets, so the figure includes real subscribers.

Two figures per pair, each as *on / off - 1*:

- **command**: the wall time of the whole command (Python start, imports, the
  Zenoh session and the type store included, the same start-up on both sides
  but for what ``--ros2`` adds);
- **run**: the mission's own wall time as the command reports it (``s wall``
  in its summary), which leaves out start-up.

Printed: the median and range over the pairs, and the messages received.
"""

from __future__ import annotations

import json
import re
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


def _run(extra: list[str]) -> tuple[float, float]:
    started = time.perf_counter()
    done = subprocess.run([*MISSION, *extra], cwd=ROOT, check=True, capture_output=True, text=True)
    command = time.perf_counter() - started
    found = _WALL.search(done.stdout + done.stderr)
    return command, float(found.group(1)) if found else float("nan")


def _consumer(port: int) -> tuple[Any, list[Any], dict[str, list[Any]]]:
    import zenoh
    from zenoh_ros2_sdk import ROS2Subscriber, message_registry

    from pirate_bt.interop.rmw_zenoh import qualified_name
    from pirate_bt.interop.ros2_topics import TOPIC_TYPES

    config = zenoh.Config()
    for key, value in (
        ("mode", "router"),
        ("listen/endpoints", [f"tcp/127.0.0.1:{port}"]),
        ("scouting/multicast/enabled", False),
    ):
        config.insert_json5(key, json.dumps(value))
    router = zenoh.open(config)
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


def main(pairs: int) -> None:
    port = _free_port()
    router, subs, got = _consumer(port)
    on = ["--ros2", f"tcp/127.0.0.1:{port}"]
    _run([])  # warm the file cache
    command: list[float] = []
    run: list[float] = []
    for _ in range(pairs):
        a1 = _run([])
        b1 = _run(on)
        b2 = _run(on)
        a2 = _run([])
        command.append((b1[0] + b2[0]) / (a1[0] + a2[0]) - 1.0)
        run.append((b1[1] + b2[1]) / (a1[1] + a2[1]) - 1.0)
        print(
            f"pair: off {a1[0]:.2f}/{a2[0]:.2f} s, on {b1[0]:.2f}/{b2[0]:.2f} s (command);"
            f" run {a1[1]:.2f}/{a2[1]:.2f} vs {b1[1]:.2f}/{b2[1]:.2f} s",
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

    print(f"--ros2 on the lab mission, {pairs} ABBA pairs, one subscriber on every topic:")
    print(f"  whole command: {figure(command)}")
    print(f"  the run itself: {figure(run)}")
    print(f"  messages received by the independent client: {received} over {2 * pairs} runs")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 4)
