"""Probe 18: other implementations of the live protocols, and the addresses they reach.

Found by acting as a peer of each protocol (a Groot2 client, a Foxglove client, a
ROS 2 node, MCAP and rosbag2 readers) and as the user who starts the servers.
"""

from __future__ import annotations

import pytest

from pirate_bt.errors import InputError

UNKNOWN_HOST = "nosuchhost.invalid"  # RFC 6761: never resolves
NOT_OURS = "192.0.2.1"  # RFC 5737 TEST-NET-1: an address of no machine here


@pytest.mark.parametrize("port", [0, 1667])
def test_a_groot2_host_that_does_not_resolve_is_named_unknown_not_no_such_device(
    port: int,
) -> None:
    """ZeroMQ refuses to bind a name it cannot resolve with ENODEV: the option said
    ``cannot listen: No such device (addr='tcp://nosuchhost.invalid:28394')``, a device
    nobody named and, for port 0, a port nobody asked for."""
    pytest.importorskip("zmq")
    from pirate_bt.interop.groot2_server import Groot2Server

    with pytest.raises(InputError) as caught:
        Groot2Server(UNKNOWN_HOST, port)
    message = str(caught.value)
    assert message.startswith(f"--groot2 {UNKNOWN_HOST}")
    assert "unknown host" in message
    assert "No such device" not in message and "addr=" not in message
    assert "\n" not in message


def test_a_groot2_address_not_of_this_machine_names_no_random_port() -> None:
    """Port 0 picks a port at random: the refusal named the one it happened to try."""
    pytest.importorskip("zmq")
    from pirate_bt.interop.groot2_server import Groot2Server

    with pytest.raises(InputError) as caught:
        Groot2Server(NOT_OURS, 0)
    assert (
        str(caught.value) == f"--groot2 {NOT_OURS}: cannot listen: Cannot assign requested address"
    )


@pytest.mark.parametrize(
    ("host", "says"), [(UNKNOWN_HOST, "unknown host: "), (NOT_OURS, "cannot listen: ")]
)
def test_a_foxglove_server_on_port_0_where_it_cannot_listen_is_one_clear_line(
    host: str, says: str
) -> None:
    """With a given port the host was checked before the server's process started;
    with port 0 it was not, and the SDK's error came back wrapped:
    ``cannot start the server: RuntimeError: FoxgloveError: Failed to bind port: ...``."""
    pytest.importorskip("foxglove")
    from pirate_bt.interop.foxglove_live import FoxgloveServer

    with pytest.raises(InputError) as caught:
        FoxgloveServer(host, 0)
    message = str(caught.value)
    assert message.startswith(f"--foxglove {host}:0: {says}")
    assert "RuntimeError" not in message and "FoxgloveError" not in message
