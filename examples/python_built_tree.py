"""A tree built in Python from the library's primitives, plus one behaviour of your own.

Run from the repository root: ``python examples/python_built_tree.py``.

Every node built with ``Cls.build(name, ctx, **params)`` is checked exactly as the
same node in a YAML file (unknown keys, units, the robot's limits), and a problem
is reported at the line of this file that built it.
"""

import math

import py_trees
from py_trees.common import Status
from pydantic import Field

import pirate_bt
from pirate_bt.behaviours.base import Leaf, NodeParams
from pirate_bt.behaviours.primitives import Clamp, Drive, MoveFrontClear
from pirate_bt.units import Angle


class LevelParams(NodeParams):
    # numbers are SI (radians); text with a unit ("10 deg") is parsed
    max_roll: Angle = Field(0.2, gt=0, description="largest roll counted as level")


class Level(Leaf):
    """A condition of our own: succeed while the robot's IMU roll is within ``max_roll``.

    It reads the robot's state through the supervisor (the only road to the robot)
    and never sends a command.
    """

    Params = LevelParams
    params: LevelParams  # for type checkers: built with checked LevelParams
    needs_robot = True  # it reads the robot: a run without one is refused

    def update(self) -> Status:
        state = self.context.supervisor.state()
        roll = state.imu_rad.get("roll") if state is not None else None
        if roll is None:
            self.feedback_message = "no IMU reading yet"
            return Status.FAILURE
        self.feedback_message = f"roll {math.degrees(roll):.1f} deg"
        return Status.SUCCESS if abs(roll) <= self.params.max_roll else Status.FAILURE


with pirate_bt.connect("sim:straight") as robot:
    ctx = robot.context()  # the robot, its clock and its supervisor

    # Bad parameters are refused when the node is built, located at this file's line.
    try:
        Clamp.build("too hard", ctx, half="front", torque="50 N*m")
    except pirate_bt.ValidationFailed as exc:
        print(f"refused: {exc}")

    level = Level.build("level?", ctx, max_roll="10 deg")
    root = py_trees.composites.Sequence(name="my straight", memory=True)
    root.add_children(
        [
            Clamp.build("clamp rear", ctx, half="rear", torque="0.7 N*m"),
            MoveFrontClear.build("front clear", ctx),
            Clamp.build("clamp front", ctx, half="front", torque="0.7 N*m"),
            level,
            Drive.build("drive", ctx, velocity="80 mm/s", distance="0.2 m"),
        ]
    )
    result = robot.run(root, max_time="60 s")

print(result.summary())
print(f"status: {result.status}, why: {result.why}")
print(f"our condition said: {level.feedback_message}")
c = result.counters
print(f"counters: {c.violations} violations, {c.refusals} refusals, {c.clips} clips")
