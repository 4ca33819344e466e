"""Probe 18: other implementations of the live protocols, and the addresses they reach.

Found by acting as a peer of each protocol (a Groot2 client, a Foxglove client, a
ROS 2 node, MCAP and rosbag2 readers) and as the user who starts the servers.
"""

from __future__ import annotations

import json
import logging
import socket
import time
from typing import Any

import pytest

from pirate_bt.errors import InputError

UNKNOWN_HOST = "nosuchhost.invalid"  # RFC 6761: never resolves
NOT_OURS = "192.0.2.1"  # RFC 5737 TEST-NET-1: an address of no machine here

# the real-time group (tests/conftest.py): a ROS 2 node awaited on the wall clock
pytestmark = pytest.mark.xdist_group("real-time")


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


def _wait(predicate: Any, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return bool(predicate())


def test_a_ros2_node_that_reaches_no_router_says_so_and_says_when_it_does(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A run whose Zenoh router was not there said ``ROS 2 node /pirate/pirate_bt on
    Zenoh tcp/...`` and nothing more: nobody saw it, nobody's e-stop reached it, and the
    log had no word of it. It now says so, and says when a router is reached at last."""
    zenoh = pytest.importorskip("zenoh")
    from pirate_bt.interop.ros2_node import Ros2Node

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = int(probe.getsockname()[1])
    caplog.set_level(logging.WARNING, logger="pirate_bt.interop.ros2_node")
    node = Ros2Node(f"tcp/127.0.0.1:{port}")
    router = None
    try:
        assert node.wait_ready(10.0)
        assert _wait(lambda: not node.reached, 10.0)
        lost = [r.getMessage() for r in caplog.records if "no Zenoh router" in r.getMessage()]
        assert lost == [
            f"ROS 2: no Zenoh router or peer reached at tcp/127.0.0.1:{port} (still trying):"
            " the graph does not see this run, and /pirate/estop does not reach it"
        ]
        config = zenoh.Config()
        for key, value in (
            ("mode", "router"),
            ("listen/endpoints", [f"tcp/127.0.0.1:{port}"]),
            ("scouting/multicast/enabled", False),
        ):
            config.insert_json5(key, json.dumps(value))
        router = zenoh.open(config)
        assert _wait(lambda: node.reached, 20.0)
        assert any("reached a Zenoh router" in r.getMessage() for r in caplog.records)
    finally:
        node.close()
        if router is not None:
            router.close()


@pytest.mark.parametrize("request_kind", ["insert", "remove", "unlock"])
def test_a_hook_request_with_a_number_of_thousands_of_digits_gets_no_python_advice(
    request_kind: str,
) -> None:
    """Valid JSON whose number has more digits than Python converts was answered
    ``not JSON: Exceeds the limit (4300 digits) for integer string conversion: ... use
    sys.set_int_max_str_digits() to increase the limit``: called not JSON, and advice
    for Python given to a Groot2 client's user."""
    from pirate_bt.interop.groot2_protocol import (
        HookError,
        parse_hooks,
        parse_remove,
        parse_unlock,
    )

    parse = {"insert": parse_hooks, "remove": parse_remove, "unlock": parse_unlock}[request_kind]
    text = b'{"uid": ' + b"9" * 5000 + b', "position": 0}'
    with pytest.raises(HookError) as caught:
        parse(text)
    assert str(caught.value) == "hook: a number of 5000 digits is no UID, position or mode"


def test_a_foxglove_host_name_idna_refuses_is_an_unknown_host_not_an_internal_error() -> None:
    """``--foxglove robot..lan:8765`` (a doubled dot) or a label over 63 characters:
    the name lookup's IDNA codec raised UnicodeError, which no one caught: ``internal
    error: UnicodeError: encoding with 'idna' codec failed``, exit 1."""
    pytest.importorskip("foxglove")
    from pirate_bt.interop.foxglove_live import FoxgloveServer

    for host in ("robot..lan", "x" * 70):
        with pytest.raises(InputError) as caught:
            FoxgloveServer(host, 8765)
        assert str(caught.value).startswith(f"--foxglove {host}:8765: unknown host: ")


def test_a_groot2_host_name_idna_refuses_is_an_unknown_host() -> None:
    pytest.importorskip("zmq")
    from pirate_bt.interop.groot2_server import Groot2Server

    with pytest.raises(InputError) as caught:
        Groot2Server("robot..lan", 1667)
    assert str(caught.value).startswith("--groot2 robot..lan:1667: unknown host: ")


def test_a_foxglove_address_family_the_machine_lacks_is_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The probe socket of an IPv6 address was made outside the ``try``: on a machine
    without IPv6, ``--foxglove [::1]:8765`` was an internal error (OSError)."""
    pytest.importorskip("foxglove")
    import errno

    from pirate_bt.interop import foxglove_live, foxglove_server

    def no_family(*args: Any, **kwargs: Any) -> Any:
        raise OSError(errno.EAFNOSUPPORT, "Address family not supported by protocol")

    monkeypatch.setattr(foxglove_server.socket, "socket", no_family)
    with pytest.raises(InputError) as caught:
        foxglove_live.FoxgloveServer("::1", 8765)
    assert str(caught.value) == (
        "--foxglove [::1]:8765: cannot listen: Address family not supported by protocol"
    )


@pytest.mark.parametrize("option", ["--foxglove", "--groot2"])
def test_an_ipv6_host_read_with_the_default_port_is_named_in_brackets(option: str) -> None:
    """``::1:1700`` is an IPv6 address (the user meant ``[::1]:1700``): refused with
    ``--groot2 ::1:1700:1667: cannot listen``, which hid how it had been read."""
    if option == "--foxglove":
        pytest.importorskip("foxglove")
        from pirate_bt.interop.foxglove_live import FoxgloveServer as server
    else:
        pytest.importorskip("zmq")
        from pirate_bt.interop.groot2_server import Groot2Server as server  # type: ignore[assignment]
    port = 8765 if option == "--foxglove" else 1667
    with pytest.raises(InputError) as caught:
        server("::1:1700", port)
    assert str(caught.value).startswith(f"{option} [::1:1700]:{port}: ")
