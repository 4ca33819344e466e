"""Groot2 figures: the live server's cost on the lab mission, the status reply at scale, coverage.

Run: ``.venv/bin/python benchmarks/bench_groot2.py [--pairs N] [--only PART ...]``.
Prints the figures ``docs/performance.md`` quotes under "Groot2 live and coverage".

Parts:

``mission``
    The lab mission, ``pirate-bt mission scenarios/lab.route --sim lab --quiet``,
    against the same command with ``--groot2 127.0.0.1:PORT`` and one client
    (pyzmq, in this process) that connects as soon as the command starts, asks
    for the tree once, then polls the statuses at 10 Hz until the run ends (what
    Groot2's monitor does; its polling interval is not documented, 10 Hz is our
    assumption) and, as a bound, at 100 Hz with a blackboard request on every
    poll. Wall time of the whole command, start-up included, in ABBA order (off,
    on, on, off) repeated, so a noisy shared machine hits both alike: the extra
    wall time per run, median and range over the pairs, and in % of the run
    without the server.
``account``
    The same cost counted where it is spent, free of the machine's load: the lab
    mission in this process with the server and a 10 Hz client; the CPU time of
    the server's thread (``Groot2Server.cpu_s``) and the time of its hooks on the
    tick thread (installing hooks, copying statuses), against the run's own CPU
    time. Three runs.
``scale``
    The 3,101-node tree of ``bench_scale.py`` (K = 100 copies of the 31-node PAB
    subtree), ticked by the runner on a simulated clock with the server attached:
    the status reply's size, and its round trip (request sent to reply read on
    loopback, the client a process of its own as Groot2 is) while the tree ticks,
    median and 99th percentile over 2,000 requests, and over 500 with the client a
    thread of the ticking process (which waits for the interpreter's lock); the
    runner's µs per tick with and without the server and a 10 Hz client.
``coverage``
    What counting coverage costs (every run counts it): the lab mission in this
    process with the coverage recorder and with it replaced by a stub, ABBA pairs
    of the runner's wall time, and the recorder's own time per tick.
"""

from __future__ import annotations

import argparse
import gc
import platform
import resource
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from report import positive, skip_without  # noqa: E402 - benchmarks/ is not a package

if __name__ == "__main__":
    skip_without(["zmq", "msgpack"], "groot2")
import zmq  # noqa: E402

PIRATE_BT = str(Path(sys.executable).with_name("pirate-bt"))
MISSION = [PIRATE_BT, "mission", "scenarios/lab.route", "--sim", "lab", "--quiet"]


def _free_pair() -> int:
    from pirate_bt.interop.groot2_server import Groot2Server

    with Groot2Server(port=0) as probe:  # two free neighbouring ports, released
        return probe.port


class Poller:
    """A Groot2-like client: the tree once, then statuses at ``rate_hz``."""

    def __init__(self, port: int, rate_hz: float, blackboard: bool = False) -> None:
        self.port, self.period_s, self.blackboard = port, 1.0 / rate_hz, blackboard
        self.stop = threading.Event()
        self.replies = 0
        self.bytes = 0
        self.times_s: list[float] = []
        self.cpu_s = 0.0
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> Poller:
        self.thread.start()
        return self

    def _run(self) -> None:
        from pirate_bt.interop.groot2_protocol import pack_request

        context = zmq.Context()
        sock = context.socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.RCVTIMEO, 200)
        sock.connect(f"tcp://127.0.0.1:{self.port}")
        asked_tree = False
        next_s = time.perf_counter()
        try:
            while not self.stop.is_set():
                kinds = [b"S"] if asked_tree else [b"T"]
                if asked_tree and self.blackboard:
                    kinds.append(b"B")
                for kind in kinds:
                    parts = [pack_request(kind[0])] + ([b""] if kind == b"B" else [])
                    started = time.perf_counter()
                    sock.send_multipart(parts)
                    try:
                        reply = sock.recv_multipart()
                    except zmq.Again:  # not up yet, or gone: a REQ socket must start over
                        sock.close()
                        sock = context.socket(zmq.REQ)
                        sock.setsockopt(zmq.LINGER, 0)
                        sock.setsockopt(zmq.RCVTIMEO, 200)
                        sock.connect(f"tcp://127.0.0.1:{self.port}")
                        break
                    if reply[0] == b"error":
                        break
                    self.times_s.append(time.perf_counter() - started)
                    self.replies += 1
                    self.bytes += sum(map(len, reply))
                    asked_tree = True
                next_s += self.period_s
                self.stop.wait(max(0.0, next_s - time.perf_counter()))
        finally:
            self.cpu_s = time.thread_time()
            context.destroy(linger=0)

    def finish(self) -> None:
        self.stop.set()
        self.thread.join(5)


def _command(extra: list[str], poller: Poller | None = None) -> tuple[float, float]:
    """Run the mission command: (wall seconds, CPU seconds of the command's process)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    proc = subprocess.Popen([*MISSION, *extra], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)  # fmt: skip
    if poller is not None:
        poller.start()
    code = proc.wait()
    elapsed = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if poller is not None:
        poller.finish()
    if code != 0:
        raise SystemExit(f"the lab mission failed (exit {code})")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return elapsed, cpu


Measure = Callable[[], tuple[float, ...]]


def _pairs(pairs: int, on: Measure, off: Measure) -> list[tuple[float, float, float, float]]:
    """ABBA pairs of two measurements: per figure, (median extra, least, most, median off)."""
    extra: list[list[float]] = []
    base: list[list[float]] = []
    for i in range(pairs):
        order = (off, on, on, off) if i % 2 == 0 else (on, off, off, on)
        got: dict[int, list[tuple[float, ...]]] = {id(off): [], id(on): []}
        for fn in order:
            got[id(fn)].append(fn())
        mean_on = [statistics.mean(v) for v in zip(*got[id(on)], strict=True)]
        mean_off = [statistics.mean(v) for v in zip(*got[id(off)], strict=True)]
        extra.append([a - b for a, b in zip(mean_on, mean_off, strict=True)])
        base.append(mean_off)
    out = []
    for k in range(len(extra[0])):
        values = [e[k] for e in extra]
        out.append(
            (
                statistics.median(values),
                min(values),
                max(values),
                statistics.median(b[k] for b in base),
            )
        )
    return out


def part_mission(pairs: int) -> None:
    print(f"\n# the lab mission with --groot2 and one client ({pairs} ABBA pairs, whole command)")
    print("| client | extra wall time per run | extra CPU time per run | replies |")
    print("|---|---|---|---|")
    cases = ((10.0, False, "statuses at 10 Hz"), (100.0, True, "statuses and blackboard, 100 Hz"))
    for rate_hz, blackboard, label in cases:
        pollers: list[Poller] = []

        def on(
            rate_hz: float = rate_hz, blackboard: bool = blackboard, pollers: list[Poller] = pollers
        ) -> tuple[float, float]:
            port = _free_pair()
            poller = Poller(port, rate_hz, blackboard)
            pollers.append(poller)
            return _command(["--groot2", f"127.0.0.1:{port}"], poller)

        wall, cpu = _pairs(pairs, on, lambda: _command([]))
        replies = statistics.median(p.replies for p in pollers)
        cells = [
            f"{m:+.2f} s ({lo:+.2f} to {hi:+.2f}), **{100 * m / b:+.1f} %** of {b:.2f} s"
            for m, lo, hi, b in (wall, cpu)
        ]
        print(f"| {label} | {cells[0]} | {cells[1]} | {replies:.0f} a run |")


def part_account(rate_hz: float = 10.0) -> None:
    """The server's own CPU in the lab mission, counted where it is spent: its thread
    (``Groot2Server.cpu_s``) and its hooks on the tick thread (timed)."""
    import pirate_bt
    from pirate_bt.interop import groot2_server as gs

    spent = {"apply_hooks": 0.0, "_on_tick": 0.0}
    originals = {name: getattr(gs.Groot2Server, name) for name in spent}

    def timed(name: str) -> Callable[..., None]:
        original = originals[name]

        def wrapper(self: Any, *args: Any) -> None:
            started = time.perf_counter()
            original(self, *args)
            spent[name] += time.perf_counter() - started

        return wrapper

    for name in spent:
        setattr(gs.Groot2Server, name, timed(name))
    try:
        with gs.Groot2Server(port=0) as server:
            poller = Poller(server.port, rate_hz).start()
            cpu0 = time.process_time()
            result = pirate_bt.simulate_mission("lab.route", groot2=server)
            cpu = time.process_time() - cpu0
            poller.finish()
            server_cpu = server.cpu_s
    finally:
        for name, original in originals.items():
            setattr(gs.Groot2Server, name, original)
    hooks = sum(spent.values())
    own = server_cpu + hooks
    run_cpu = cpu - own - poller.cpu_s
    print(f"\n# the server's own CPU in the lab mission, one client at {rate_hz:g} Hz (in process)")
    print(
        f"server thread {server_cpu:.3f} s + its hooks in the tick {hooks:.3f} s"
        f" (apply_hooks {spent['apply_hooks']:.3f} s, statuses {spent['_on_tick']:.3f} s)"
        f" = {own:.3f} s, **{100 * own / run_cpu:.1f} %** of the run's own {run_cpu:.2f} s CPU"
        f" ({result.run.ticks} ticks, {poller.replies} replies, {poller.bytes:,} bytes)"
    )


def part_scale(ticks: int) -> None:
    import bench_scale

    from pirate_bt.clock import SimClock
    from pirate_bt.interop.groot2_protocol import pack_request
    from pirate_bt.interop.groot2_server import Groot2Server, attach_groot2
    from pirate_bt.runner import Runner
    from pirate_bt.trace.coverage import attach_coverage

    last_cpu = [0.0]
    build_s = [0.0]

    def run(with_server: bool) -> tuple[float, list[float], int]:
        runner = Runner(bench_scale.mission_tree(100), clock=SimClock(), period_s=0.01,
                        max_time_s=ticks * 0.01)  # fmt: skip
        attach_coverage(runner)
        marks: dict[int, float] = {}

        def mark(info: Any) -> None:
            if info.tick in (bench_scale.WARM_UP, ticks):
                marks[info.tick] = time.perf_counter()

        runner.add_post_tick(mark)
        if not with_server:
            gc.collect()
            runner.run()
            return (marks[ticks] - marks[bench_scale.WARM_UP]) / (ticks - 100) * 1e6, [], 0
        with Groot2Server(port=0) as server:
            attach_groot2(runner, server)
            started = time.perf_counter()
            server.served()  # made here, timed apart from the run (a client's first ask)
            build_s[0] = time.perf_counter() - started
            times: list[float] = []
            size = [0]
            stop = threading.Event()

            def client() -> None:
                context = zmq.Context()
                sock = context.socket(zmq.REQ)
                sock.connect(f"tcp://127.0.0.1:{server.port}")
                while not stop.is_set():
                    started = time.perf_counter()
                    sock.send(pack_request(ord("S")))
                    reply = sock.recv_multipart()
                    times.append(time.perf_counter() - started)
                    size[0] = sum(map(len, reply))
                    stop.wait(0.1)
                context.destroy(linger=0)

            thread = threading.Thread(target=client, daemon=True)
            thread.start()
            gc.collect()
            runner.run()
            stop.set()
            thread.join(10)
            last_cpu[0] = server.cpu_s
        return (marks[ticks] - marks[bench_scale.WARM_UP]) / (ticks - 100) * 1e6, times, size[0]

    nodes = bench_scale.count_nodes(bench_scale.mission_tree(100))
    print(f"\n# the status reply of the {nodes:,}-node tree of bench_scale.py")
    answer_s, size = _answer_time(5000)
    times = sorted(_round_trips(2000)[0])
    threaded = sorted(_round_trips(500, in_process=True)[0])
    print(
        f"status reply: {size:,} bytes (22-byte header + 3 bytes x {nodes:,} nodes);"
        f" the server answers in {1e6 * answer_s:.1f} µs (median of 5,000);"
        f" round trip while the tree ticks, the client a process of its own (as Groot2):"
        f" median {1e6 * statistics.median(times):.0f} µs,"
        f" p99 {1e6 * times[int(0.99 * len(times))]:.0f} µs over {len(times)} requests;"
        f" the client a thread of the run's process (its interpreter's lock):"
        f" median {1e6 * statistics.median(threaded):.0f} µs,"
        f" p99 {1e6 * threaded[int(0.99 * len(threaded))]:.0f} µs over {len(threaded)}"
    )
    from pirate_bt.interop import groot2_server as gs

    spent = {"apply_hooks": 0.0, "_on_tick": 0.0}
    originals = {name: getattr(gs.Groot2Server, name) for name in spent}

    def timed(name: str) -> Callable[..., None]:
        original = originals[name]

        def wrapper(self: Any, *args: Any) -> None:
            started = time.perf_counter()
            original(self, *args)
            spent[name] += time.perf_counter() - started

        return wrapper

    for name in spent:
        setattr(gs.Groot2Server, name, timed(name))
    try:
        base = statistics.median(run(False)[0] for _ in range(3))
        wall0 = time.perf_counter()
        run(True)
        wall = time.perf_counter() - wall0
    finally:
        for name, original in originals.items():
            setattr(gs.Groot2Server, name, original)
    print(
        f"runner with coverage: {base:.1f} µs/tick; the server's hooks on the tick thread"
        f" {1e6 * sum(spent.values()) / ticks:.2f} µs/tick"
        f" ({100 * 1e6 * sum(spent.values()) / ticks / base:.1f} %), its thread"
        f" {1e3 * last_cpu[0] / wall:.2f} ms of CPU per second of the run with a 10 Hz"
        f" client ({ticks} ticks); making what Groot2 sees, once: {1e3 * build_s[0]:.0f} ms"
    )


def _answer_time(requests: int) -> tuple[float, int]:
    """The server's own time to answer a status request of the scale tree (no transport)."""
    import bench_scale
    import py_trees

    from pirate_bt.interop.groot2_protocol import pack_request
    from pirate_bt.interop.groot2_server import Groot2Server

    tree = py_trees.trees.BehaviourTree(bench_scale.mission_tree(100))
    with Groot2Server(port=0) as server:
        server.serve(tree)
        server.served()
        request = [pack_request(ord("S"))]
        reply = server._answer(request)
        times = []
        for _ in range(requests):
            started = time.perf_counter()
            server._answer(request)
            times.append(time.perf_counter() - started)
    return statistics.median(times), sum(map(len, reply))


_CLIENT = """
import json, sys, time
import zmq
port, requests, request = int(sys.argv[1]), int(sys.argv[2]), bytes.fromhex(sys.argv[3])
context = zmq.Context()
sock = context.socket(zmq.REQ)
sock.setsockopt(zmq.RCVTIMEO, 60000)
sock.connect(f"tcp://127.0.0.1:{port}")
times, size = [], 0
for _ in range(requests):
    started = time.perf_counter()
    sock.send(request)
    reply = sock.recv_multipart()
    times.append(time.perf_counter() - started)
    size = sum(map(len, reply))
context.destroy(linger=0)
print(json.dumps([times, size]))
"""


def _round_trips(requests: int, in_process: bool = False) -> tuple[list[float], int]:
    """Status round trips, as fast as the client can ask, while the scale tree ticks.

    The client is a process of its own, as Groot2 is (``in_process``: a thread of the
    run's process). A client thread shares the interpreter's lock with the ticking tree:
    each time its ``recv`` returns it waits for the tick thread to let go of the lock,
    up to Python's switch interval (5 ms), and the server's thread does too; that wait,
    not the server nor the relay, was the 15-22 ms round trip measured so until
    2026-12-01 (with ``sys.setswitchinterval`` at 0.5 ms it was 1.6 ms, at 20 ms 50 ms).
    """
    import json

    import bench_scale
    import py_trees

    from pirate_bt.interop.groot2_protocol import pack_request
    from pirate_bt.interop.groot2_server import Groot2Server
    from pirate_bt.runner import tick_tree
    from pirate_bt.trace.coverage import CoverageRecorder

    tree = py_trees.trees.BehaviourTree(bench_scale.mission_tree(100))
    tree.root.setup_with_descendants()
    recorder = CoverageRecorder(tree)
    times: list[float] = []
    size = [0]
    done = threading.Event()
    request = pack_request(ord("S"))
    with Groot2Server(port=0) as server:
        server.serve(tree, recorder=recorder)
        server.served()  # made before the first request (the scale part times it apart)

        def client() -> None:
            context = zmq.Context()
            sock = context.socket(zmq.REQ)
            sock.connect(f"tcp://127.0.0.1:{server.port}")
            for _ in range(requests):
                started = time.perf_counter()
                sock.send(request)
                reply = sock.recv_multipart()
                times.append(time.perf_counter() - started)
                size[0] = sum(map(len, reply))
            context.destroy(linger=0)
            done.set()

        if in_process:
            thread = threading.Thread(target=client, daemon=True)
            thread.start()
            while not done.is_set():
                tick_tree(tree)
                recorder.record_tick()
            thread.join(10)
            return times, size[0]
        command = [sys.executable, "-c", _CLIENT, str(server.port), str(requests), request.hex()]
        proc = subprocess.Popen(command, stdout=subprocess.PIPE)
        try:
            while proc.poll() is None:
                tick_tree(tree)
                recorder.record_tick()
            out, _ = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        if proc.returncode != 0:
            raise SystemExit(f"the round-trip client failed (exit {proc.returncode})")
        got, got_size = json.loads(out)
    return [float(t) for t in got], int(got_size)


def part_coverage(pairs: int) -> None:
    import pirate_bt
    import pirate_bt.task.mission as mission
    from pirate_bt.trace import coverage

    class _Stub:
        def coverage(self) -> None:
            return None

    real = coverage.attach_coverage
    spent = [0.0, 0]
    original = coverage.CoverageRecorder.record_tick

    def timed(self: Any, info: object = None) -> None:
        started = time.perf_counter()
        original(self, info)
        spent[0] += time.perf_counter() - started
        spent[1] += 1

    def run(counted: bool) -> tuple[float, float]:
        mission.attach_coverage = real if counted else (lambda runner, name=None: _Stub())  # type: ignore[assignment]
        gc.collect()
        cpu = time.process_time()
        result = pirate_bt.simulate_mission("lab.route")
        return float(result.run.wall_time_s), time.process_time() - cpu

    coverage.CoverageRecorder.record_tick = timed  # type: ignore[method-assign]
    try:
        wall, cpu = _pairs(pairs, lambda: run(True), lambda: run(False))
    finally:
        mission.attach_coverage = real
        coverage.CoverageRecorder.record_tick = original  # type: ignore[method-assign]
    print(f"\n# counting coverage on the lab mission ({pairs} ABBA pairs, the runner's wall time)")
    for label, (m, lo, hi, b) in (("wall", wall), ("CPU", cpu)):
        print(f"extra {label} time per run {m:+.3f} s ({lo:+.3f} to {hi:+.3f}),"
              f" {100 * m / b:+.1f} % of {b:.2f} s")  # fmt: skip
    print(f"the recorder itself: {1e6 * spent[0] / max(spent[1], 1):.1f} µs per tick on average"
          f" ({spent[1]} ticks)")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=positive, default=3, help="ABBA pairs (default 3)")
    parser.add_argument("--ticks", type=positive, default=20000, help="ticks of a scale run")
    parser.add_argument("--only", nargs="+", choices=["mission", "account", "scale", "coverage"])
    args = parser.parse_args()
    print(f"Python {platform.python_version()}, {platform.machine()}, pyzmq {zmq.__version__},"
          f" libzmq {zmq.zmq_version()}")  # fmt: skip
    parts = args.only or ["mission", "account", "scale", "coverage"]
    if "mission" in parts:
        part_mission(args.pairs)
    if "account" in parts:
        for _ in range(3):
            part_account()
    if "scale" in parts:
        part_scale(args.ticks)
    if "coverage" in parts:
        part_coverage(args.pairs)


if __name__ == "__main__":
    main()
