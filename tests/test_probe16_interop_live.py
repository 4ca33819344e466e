"""Probe 16: live interop servers (Groot2's ZeroMQ ports) asked by a client of our own.

Real-time (live sockets): kept apart from the pure tests of
``tests/test_probe16_interop.py``.
"""

from __future__ import annotations

import logging
import os

import py_trees
import pytest

from pirate_bt.interop import groot2_protocol as proto
from pirate_bt.interop.groot2_server import Groot2Server


def test_a_blackboard_holding_a_file_name_that_is_no_utf8_is_served_to_groot2(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # os.fsdecode makes a file name whose bytes are no UTF-8 (a camera's b"pipe_\xe9.jpg")
    # a str with a lone surrogate; with one on the blackboard, every blackboard request
    # of Groot2 was an error reply ("Unknown error while processing request: 'utf-8'
    # codec can't encode ...") and a traceback in the run's log, poll after poll
    zmq = pytest.importorskip("zmq")
    msgpack = pytest.importorskip("msgpack")
    py_trees.blackboard.Blackboard.clear()
    storage = py_trees.blackboard.Blackboard.storage
    storage["/photo"] = os.fsdecode(b"pipe_\xe9.jpg")
    storage["/" + os.fsdecode(b"k\xff")] = [os.fsdecode(b"\xfe"), 1.5]
    try:
        with Groot2Server(port=0) as server, caplog.at_level(logging.WARNING):
            server.serve(py_trees.trees.BehaviourTree(py_trees.behaviours.Success("ok")))
            context = zmq.Context()
            req = context.socket(zmq.REQ)
            req.setsockopt(zmq.RCVTIMEO, 20000)
            req.setsockopt(zmq.LINGER, 0)
            try:
                req.connect(f"tcp://127.0.0.1:{server.port}")
                req.send_multipart([proto.pack_request(ord("B")), b"ok"])
                reply = req.recv_multipart()
            finally:
                context.destroy(linger=0)
    finally:
        py_trees.blackboard.Blackboard.clear()
    assert len(reply) == 2 and reply[0][1:2] == b"B", reply
    board = msgpack.unpackb(reply[1])["ok"]
    assert board["photo"] == "pipe_\ufffd.jpg"
    assert board["k\ufffd"] == ["\ufffd", 1.5]
    assert not [r for r in caplog.records if r.levelno >= logging.ERROR]
