"""Probe 8, interop: what a hostile or careless peer of Groot2, ROS 2, MCAP and
Foxglove sends, and what pirate_bt must do with it (regressions of the bugs found)."""

from __future__ import annotations

from typing import Any

import py_trees
import pytest

from pirate_bt.clock import SimClock
from pirate_bt.interop import groot2_protocol as proto
from pirate_bt.interop import groot2_requests
from pirate_bt.interop.groot2_server import Groot2Server
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


# -- Groot2 ---------------------------------------------------------------------------------


def test_a_blackboard_request_naming_one_board_many_times_reads_it_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # B with a second part of a million ';' (a million empty names, each the main
    # tree's) copied the live blackboard a million times: 6 s of the server's thread,
    # holding the interpreter the tick runs in, for one request under 1 MiB.
    zmq = pytest.importorskip("zmq")
    msgpack = pytest.importorskip("msgpack")
    reads = []
    live = groot2_requests._live_blackboard

    def counted() -> dict[str, Any]:
        reads.append(1)
        return live()

    monkeypatch.setattr(groot2_requests, "_live_blackboard", counted)
    with Groot2Server(port=0) as server:
        server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
        context = zmq.Context()
        req = context.socket(zmq.REQ)
        req.setsockopt(zmq.RCVTIMEO, 20000)
        req.setsockopt(zmq.LINGER, 0)
        try:
            req.connect(f"tcp://127.0.0.1:{server.port}")
            req.send_multipart([proto.pack_request(ord("B")), b";" * 100_000 + b"ok;ok;nope"])
            reply = req.recv_multipart()
        finally:
            context.destroy(linger=0)
    assert len(reply) == 2 and reply[0][1:2] == b"B"
    assert set(msgpack.unpackb(reply[1])) == {"", "ok"}
    assert len(reads) == 1
