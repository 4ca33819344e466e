"""The ``--ros2 [ENDPOINT]`` options, without importing Zenoh (fast ``--help``).

Shared by ``pirate-bt run``, ``mission``, ``teleop`` and ``sim``; the node is
:class:`pirate_bt.interop.ros2_live.Ros2Node`.
"""

from __future__ import annotations

import os
from typing import Any

from pirate_bt.errors import InputError

__all__ = [
    "DEFAULT_ENDPOINT",
    "DEFAULT_NAMESPACE",
    "MAX_DOMAIN_ID",
    "add_ros2_options",
    "domain_from_env",
    "parse_endpoint",
]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where rmw_zenoh's router (``ros2 run rmw_zenoh_cpp rmw_zenohd``) listens."""
DEFAULT_NAMESPACE = "/pirate"
MAX_DOMAIN_ID = 232
"""The largest ROS domain id (ROS 2's domain id table)."""
_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream")


def parse_endpoint(text: str | None) -> str:
    """A Zenoh endpoint from ``tcp/HOST:PORT``, ``HOST:PORT``, ``HOST``, ``:PORT`` or ``PORT``.

    Raises:
        InputError: an unknown protocol or a port that is not a number from 1 to 65535.
    """
    text = (text or "").strip()
    if not text:
        return DEFAULT_ENDPOINT
    protocol, slash, address = text.partition("/")
    if not slash:
        protocol, address = "tcp", text
    if protocol not in _PROTOCOLS:
        raise InputError(f"--ros2 {text}: unknown Zenoh protocol {protocol!r} (tcp/HOST:PORT)")
    if protocol == "unixsock-stream":
        if not address:
            raise InputError(f"--ros2 {text}: a unix socket needs a path (unixsock-stream/PATH)")
        return text
    if address.isascii() and address.isdigit():
        host, port = "127.0.0.1", address
    elif address.startswith("["):
        inside, _, rest = address[1:].partition("]")
        host, port = f"[{inside}]", rest.removeprefix(":") or "7447"
    else:
        host, _, port = address.rpartition(":") if ":" in address else (address, "", "7447")
        host = host or "127.0.0.1"
    if not (port.isascii() and port.isdigit()) or not 0 < int(port) <= 65535:
        raise InputError(f"--ros2 {text}: the port must be a number from 1 to 65535")
    return f"{protocol}/{host}:{int(port)}"


def domain_from_env() -> int:
    """``ROS_DOMAIN_ID`` as ROS reads it (0 when unset).

    Raises:
        InputError: it is set to something that is not a domain id (a number from 0 to
            232), naming the variable (``--ros-domain-id`` was not given).
    """
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not (text.isascii() and text.isdigit()):
        raise InputError(f"ROS_DOMAIN_ID={text!r} is not a number")
    if int(text) > MAX_DOMAIN_ID:
        raise InputError(f"ROS_DOMAIN_ID={text}: ROS domain ids go from 0 to {MAX_DOMAIN_ID}")
    return int(text)


def add_ros2_options(parser: Any) -> None:
    """Add ``--ros2 [ENDPOINT]``, ``--ros-domain-id N`` and ``--ros-namespace NS``."""
    parser.add_argument(
        "--ros2",
        nargs="?",
        const=DEFAULT_ENDPOINT,
        metavar="ENDPOINT",
        help="show the run on a ROS 2 graph over Zenoh, as rmw_zenoh does, through the"
        f" Zenoh router or peer at ENDPOINT (default {DEFAULT_ENDPOINT}); subscribes to"
        " NS/estop (std_msgs/Bool) as an operator e-stop",
    )
    parser.add_argument(
        "--ros-domain-id",
        type=int,
        metavar="N",
        help="ROS domain id for --ros2 (default: ROS_DOMAIN_ID, else 0)",
    )
    parser.add_argument(
        "--ros-namespace",
        default=DEFAULT_NAMESPACE,
        metavar="NS",
        help=f"namespace of the node and its topics for --ros2 (default {DEFAULT_NAMESPACE})",
    )
