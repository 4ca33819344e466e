"""The trees and per-tick inputs of the trace benchmark (``bench_trace.py``).

The sparse 50-node tree, a plausible robot state per tick, and each tick's extras
made as a run makes them (:class:`RunSnapshots`) or up front (the method before
2026-11-29). ``bench_trace``, ``bench_btcpp`` and ``bench_scale`` use them.
"""

from __future__ import annotations

import math
from pathlib import Path

import py_trees
from py_trees.common import Status

from pirate_bt.robot.port import LinkHealth
from pirate_bt.robot.state import Reading, RobotState
from pirate_bt.trace import CommandRecord, TickExtras

STEPS = 7
TICK_S = 0.01


class Step(py_trees.behaviour.Behaviour):
    """A leaf that runs for ``ticks`` ticks, reporting progress every 10 ticks."""

    def __init__(self, name: str, ticks: int) -> None:
        super().__init__(name)
        self.ticks = ticks
        self.count = 0

    def initialise(self) -> None:
        self.count = 0

    def update(self) -> Status:
        self.count += 1
        if self.count % 10 == 0:
            self.feedback_message = f"{self.count}/{self.ticks}"
        return Status.SUCCESS if self.count >= self.ticks else Status.RUNNING


def fifty_node_tree(step_ticks: int = 200) -> py_trees.trees.BehaviourTree:
    """1 root + 7 x (guard + sequence + selector with 2 leaves + 2 leaves) = 50 nodes."""
    steps = []
    for i in range(STEPS):
        parts: list[py_trees.behaviour.Behaviour] = [
            py_trees.composites.Selector(
                f"ready {i}",
                memory=False,
                children=[
                    py_trees.behaviours.Failure(f"clamped {i}?"),
                    py_trees.behaviours.Success(f"clamp {i}"),
                ],
            ),
            py_trees.behaviours.Success(f"link ok {i}?"),
            Step(f"act {i}", step_ticks),
        ]
        seq = py_trees.composites.Sequence(f"step {i}", memory=True, children=parts)
        steps.append(py_trees.decorators.Timeout(f"guard {i}", seq, duration=1e9))
    root = py_trees.composites.Sequence("pab", memory=True, children=steps)
    tree = py_trees.trees.BehaviourTree(root)
    assert sum(1 for _ in root.iterate()) == 50
    return tree


def robot_state(n: int, t_s: float) -> RobotState:
    """A plausible state: one half moving, noisy drive speeds and currents."""
    step = (n // 200) % STEPS
    moving = "front" if step % 2 == 0 else "rear"
    joints = {}
    forces = {}
    for module, half in (
        ("bend_1", "front"),
        ("bend_2", "front"),
        ("bend_3", "rear"),
        ("bend_4", "rear"),
    ):
        if half == moving:
            joints[module] = 1.4 * (1 - math.exp(-(n % 200) / 50))
            forces[module] = 8.0 * (1 - math.exp(-(n % 200) / 40))
        else:
            joints[module] = 1.57
            forces[module] = 9.5
    noise = ((n * 7919) % 13 - 6) * 1e-3
    drives = {f"bend_{k}_drive": 0.08 + noise for k in range(1, 5)}
    currents = {"bend_1_drive": 0.4 + noise, "bend_2_drive": 0.41 + noise}
    return RobotState(
        stamp_s=t_s,
        readings={"bend_1_angle": Reading(joints["bend_1"], t_s)},
        joint_angle_rad=joints,
        clamp_force_n=forces,
        rotation_rad=0.0,
        imu_rad={"roll": 0.0, "pitch": 0.02, "yaw": 0.0},
        drive_velocity_mps=drives,
        motor_current_a=currents,
    )


def extras_up_front(ticks: int) -> list[TickExtras]:
    # Snapshots made up front (the method before 2026-11-29, kept for bench_scale's row):
    # each tick then reads one that is out of the caches, which a run's fresh one is not.
    return [
        TickExtras(
            state=robot_state(n, n * TICK_S),
            commands=(CommandRecord("drive(80 mm/s)", "pass"),),
            link=LinkHealth(connected=True, retries=n // 1000),
        )
        for n in range(1, ticks + 2)
    ]


class RunSnapshots:
    """Each tick's extras, made as a run makes them, in the tick they are recorded.

    A run's link builds the tick's :class:`RobotState` from a STATE frame's raw values
    with the robot's :class:`StateBuilder` (here the reference robot,
    ``hardware/pirate.yaml``: 28 channels), asks the link for a fresh
    :class:`LinkHealth`, and the supervisor makes the tick's verdict, whether the run
    is traced or not; the trace then reads them while they are still in the caches.
    The raw values follow :func:`robot_state`'s motion (one half moving, noisy wheel
    speeds and currents), converted once up front as the bridge would send them.
    """

    def __init__(self, ticks: int) -> None:
        from pirate_bt.robot.loader import load_robot
        from pirate_bt.robot.state import StateBuilder

        repo = Path(__file__).resolve().parent.parent
        self.builder = StateBuilder(load_robot(repo / "hardware" / "pirate.yaml"))
        self.raw = [self._raw(n) for n in range(ticks + 2)]
        self.previous: RobotState | None = None

    def _raw(self, n: int) -> list[int | None]:
        state = robot_state(n, n * TICK_S)
        values = {f"{m}_angle": v for m, v in state.joint_angle_rad.items()}
        values |= {f"{m}_spring": v for m, v in state.clamp_force_n.items()}
        values |= {f"imu.{axis}": v for axis, v in state.imu_rad.items()}
        for name in self.builder.channel_names:
            motor, _, kind = name.partition(".")
            if kind == "velocity":
                values[name] = state.drive_velocity_mps.get(motor, 0.0)
            elif kind == "current":
                values[name] = state.motor_current_a.get(motor, 0.0)
            else:
                values.setdefault(name, 0.0)
        return self.builder.encode(values)

    def make(self, n: int) -> TickExtras:
        """Tick ``n``'s extras, made now."""
        state = self.previous = self.builder.build(self.raw[n], n * TICK_S, self.previous)
        return TickExtras(
            state=state,
            commands=(CommandRecord("drive(80 mm/s)", "pass"),),
            link=LinkHealth(connected=True, retries=n // 1000),
        )


def record_pab_ticks(path: Path, ticks: int) -> None:
    """Write ``path``: the 50-node tree's trace of ``ticks`` ticks, the PAB started
    again each time it ends, each tick's state, link health and a command every tenth
    tick made in the tick as a run makes them (``bench_trace``'s file sizes and
    ``bench_trace_read``'s large traces)."""
    from pirate_bt.clock import SimClock
    from pirate_bt.trace import TraceRecorder

    tree = fifty_node_tree(step_ticks=200)
    clock = SimClock()
    with TraceRecorder(path, tree, clock=clock) as rec:
        for n in range(1, ticks + 1):
            clock.advance(TICK_S)
            tree.tick()
            if tree.root.status != Status.RUNNING:
                tree.root.stop(Status.INVALID)  # start the PAB again
            rec.record_tick(
                TickExtras(
                    state=robot_state(n, clock.now()),
                    commands=(CommandRecord("drive(80 mm/s)", "pass"),) if n % 10 == 0 else (),
                    link=LinkHealth(connected=True, retries=n // 3000),
                )
            )
