"""Helpers the trace tests share: a small PAB-like tree, a recorded run of it, and
the trace writer processes of a path (found through /proc)."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import py_trees
from py_trees.behaviours import StatusQueue
from py_trees.common import Status

from pirate_bt.clock import SimClock
from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState
from pirate_bt.trace import CommandRecord, TickExtras, TraceEvent, TraceRecorder
from pirate_bt.trace.structure import iter_with_ids

__all__ = [
    "live_statuses",
    "make_tree",
    "run_and_record",
    "state",
    "wait_for_writers",
    "writer_processes",
]


def make_tree() -> py_trees.trees.BehaviourTree:
    """A small PAB-like tree: steps under a root sequence, a guard, a selector."""
    py_trees.blackboard.Blackboard.clear()
    r, s, f = Status.RUNNING, Status.SUCCESS, Status.FAILURE
    root = py_trees.composites.Sequence(
        "pab",
        memory=True,
        children=[
            StatusQueue("clamp rear", [r, r, s], s),
            py_trees.decorators.Timeout(
                "within 5 s", StatusQueue("drive", [r, r, r, s], s), duration=5.0
            ),
            py_trees.composites.Selector(
                "bend or retry",
                memory=False,
                children=[StatusQueue("bend", [r, f], f), StatusQueue("fallback", [r, s], s)],
            ),
            StatusQueue("unclamp", [r, r, s], s),
        ],
    )
    return py_trees.trees.BehaviourTree(root)


def state(t_s: float, angle_rad: float) -> RobotState:
    readings = {"bend_1_angle": Reading(angle_rad, t_s)}
    return RobotState(
        stamp_s=t_s,
        readings=readings,
        joint_angle_rad={"bend_1": angle_rad, "bend_2": 0.1},
        clamp_force_n={"bend_1": 2.0 * angle_rad},
        rotation_rad=0.0,
        drive_velocity_mps={"bend_1_drive": 0.08},
    )


def live_statuses(tree: py_trees.trees.BehaviourTree) -> dict[str, Status]:
    return {node_id: node.status for node_id, node in iter_with_ids(tree)}


def run_and_record(path: Path, ticks: int = 14, **options: Any) -> list[dict[str, Status]]:
    tree = make_tree()
    clock = SimClock()
    live: list[dict[str, Status]] = [live_statuses(tree)]
    bb = py_trees.blackboard.Client(name="test")
    bb.register_key("progress", access=py_trees.common.Access.WRITE)
    with TraceRecorder(path, tree, clock=clock, scenario="straight", seed=7, **options) as rec:
        for n in range(1, ticks + 1):
            clock.advance(0.01)
            tree.tick()
            bb.progress = n // 3
            commands = [CommandRecord("drive(80 mm/s)", "pass", sent=(("d", "velocity", 0.08),))]
            if n == 5:
                commands.append(
                    CommandRecord("rotate(1 rad)", "refuse", "rotate_needs_one_clamped", "no")
                )
            rec.record_tick(
                TickExtras(
                    state=state(clock.now(), 0.1 * min(n, 10)),
                    commands=commands,
                    link=LinkHealth(connected=True, retries=n // 4),
                    sim={"frames": n * 2},
                    events=(TraceEvent("fault", "crc burst"),) if n == 9 else (),
                )
            )
            live.append(live_statuses(tree))
    return live


def writer_processes(path: Path) -> list[int]:
    """Pids of trace writer processes writing ``path``: their command line names
    ``sink.py`` and ``path``, or reads empty while they have ``path`` open.

    ``/proc/PID/cmdline`` reads empty while the process is busy with its memory (seen
    on a loaded machine for a writer at nice 10, just after the run was killed): the
    file it has open tells it then. (The run itself names ``path`` in its command line
    too, and may have it open, so neither alone makes a writer.)
    """
    target = str(path.resolve())
    pids = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit() or int(proc.name) == os.getpid():
            continue
        try:
            argv = (proc / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        named = str(path).encode() in argv and any(a.endswith(b"sink.py") for a in argv)
        if named or (argv == [b""] and _has_open(proc, target)):
            pids.append(int(proc.name))
    return pids


def _has_open(proc: Path, target: str) -> bool:
    try:
        fds = list((proc / "fd").iterdir())
    except OSError:
        return False
    for fd in fds:
        try:
            if os.readlink(fd) == target:
                return True
        except OSError:
            continue
    return False


def wait_for_writers(path: Path, timeout_s: float = 10.0) -> None:
    """Wait until no writer process is writing ``path`` any more."""
    deadline = time.monotonic() + timeout_s
    while writer_processes(path):
        assert time.monotonic() < deadline, f"the writer of {path} did not finish"
        time.sleep(0.02)
