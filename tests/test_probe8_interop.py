"""Probe 8, interop: what a hostile or careless peer of Groot2, ROS 2, MCAP and
Foxglove sends, and what pirate_bt must do with it (regressions of the bugs found)."""

from __future__ import annotations

from pirate_bt.clock import SimClock
from pirate_bt.interop.ros2_node import EStopInput
from pirate_bt.robot import Half, load_robot
from pirate_bt.safety import Mode, Supervisor
from pirate_bt.safety.testing import FakePort

ROBOT = load_robot()


# -- ROS 2 ----------------------------------------------------------------------------------


def test_a_flood_on_the_estop_topic_is_one_estop_per_tick() -> None:
    # A peer publishing `true` on /pirate/estop as fast as Zenoh goes queued one
    # EStop per message: the supervisor's next tick then sent thousands of e-stop
    # frames to the bridge and logged thousands of lines, holding up the tick.
    clock = SimClock(10.0)
    port = FakePort(ROBOT, clock)
    port.clamp_half(Half.REAR)
    supervisor = Supervisor(port, clock)
    topic = EStopInput("/pirate/estop")
    supervisor.add_input(topic)
    for _ in range(5000):
        topic.push(True, 1)
    supervisor.tick()
    assert supervisor.mode is Mode.ESTOP
    assert port.estops == 1 and topic.received == 5000 and topic.estops == 1
    # later ones are not lost: the next message e-stops again at the next tick
    topic.push(False)
    supervisor.tick()
    assert port.estops == 1
    for _ in range(3):
        topic.push(True, 2)
    supervisor.tick()
    assert port.estops == 2 and topic.estops == 2 and topic.heard_ns == 2
