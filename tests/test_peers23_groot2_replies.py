"""Every request a Groot2 client reads the reply of gets its reply, however fast it asks.

The relay's ROUTER dropped one reply now and then, as if its client held 4 unread ones
while it held none: ZeroMQ counted them from a command the socket had not read yet
(read at most once a millisecond on a send, never while the relay waited for the
server). A client asking back to back lost a reply in a few hundred (the Groot2 probe's
REQ socket, ``test_every_request_type_and_protocol_id_is_answered_as_bt_cpp_answers``,
waited 30 s for one in CI, and here); a client sending 8 requests before reading lost
some of the 8 in most rounds, where BT.CPP's server answers every one.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import py_trees
import pytest

zmq = pytest.importorskip("zmq")
pytest.importorskip("msgpack")

from pirate_bt.interop.groot2_protocol import pack_request  # noqa: E402
from pirate_bt.interop.groot2_server import Groot2Server  # noqa: E402

# the real-time group (tests/conftest.py): a live server, replies awaited on the wall clock
pytestmark = pytest.mark.xdist_group("real-time")

REPLY_WAIT_MS = 10_000
"""A reply takes well under a millisecond: only a lost one waits this long."""


@pytest.fixture
def server() -> Iterator[Groot2Server]:
    root = py_trees.composites.Sequence("root", memory=False)
    root.add_children([py_trees.behaviours.Running("leaf")])
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup()
    made = Groot2Server(port=0)
    made.serve(tree, name="replies")
    try:
        yield made
    finally:
        made.close()


def _client(context: Any, kind: int, port: int) -> Any:
    sock = context.socket(kind)
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(f"tcp://127.0.0.1:{port}")
    return sock


def test_a_client_sending_8_requests_before_reading_gets_8_replies(server: Groot2Server) -> None:
    context = zmq.Context()
    try:
        sock = _client(context, zmq.DEALER, server.port)
        for round_ in range(12):
            requests = [pack_request(ord("S"), unique_id=round_ << 8 | i) for i in range(8)]
            for request in requests:
                sock.send_multipart([b"", request])
            heard = []
            while len(heard) < len(requests) and sock.poll(REPLY_WAIT_MS):
                reply = sock.recv_multipart()
                heard.append(reply[1][2:6])  # the request's unique id, echoed
            assert heard == [request[2:6] for request in requests], f"round {round_}"
    finally:
        context.destroy(linger=0)
