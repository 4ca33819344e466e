"""The ``--ros2 [ENDPOINT]`` options, without importing Zenoh (fast ``--help``).

Shared by ``pirate-bt run``, ``mission``, ``teleop`` and ``sim``; the node is
:class:`pirate_bt.interop.ros2_live.Ros2Node`.
"""

from __future__ import annotations

import math
import os
import re
import socket
from typing import Any

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, InputError, kind_of, shown

__all__ = [
    "DEFAULT_ENDPOINT",
    "DEFAULT_NAMESPACE",
    "MAX_DOMAIN_ID",
    "add_ros2_options",
    "check_endpoint_host",
    "check_names",
    "check_node_args",
    "domain_from_env",
    "parse_endpoint",
]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where rmw_zenoh's router (``ros2 run rmw_zenoh_cpp rmw_zenohd``) listens."""
DEFAULT_NAMESPACE = "/pirate"
MAX_DOMAIN_ID = 232
"""The largest ROS domain id (ROS 2's domain id table)."""
NAMESPACE_MAX = 255 - 8 - 2
"""rmw's longest namespace (``RMW_NAMESPACE_MAX_LENGTH``: a topic name's 247, less 2)."""
NODE_NAME_MAX = 255
"""rmw's longest node name (``RMW_NODE_NAME_MAX_NAME_LENGTH``)."""
TOPIC_MAX = 255 - 8
"""rmw's longest topic name (``RMW_TOPIC_MAX_NAME_LENGTH``)."""
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream")


def parse_endpoint(text: str | None) -> str:
    """A Zenoh endpoint from ``tcp/HOST:PORT``, ``HOST:PORT``, ``HOST``, ``:PORT`` or ``PORT``.

    Raises:
        InputError: an unknown protocol or a port that is not a number from 1 to 65535.
    """
    text = (text or "").strip()
    if not text:
        return DEFAULT_ENDPOINT
    given = _typed(text)
    protocol, slash, address = text.partition("/")
    if not slash:
        protocol, address = "tcp", text
    if protocol not in _PROTOCOLS:
        raise InputError(f"--ros2 {given}: unknown Zenoh protocol {protocol!r} (tcp/HOST:PORT)")
    if protocol == "unixsock-stream":
        if not address:
            raise InputError(f"--ros2 {given}: a unix socket needs a path (unixsock-stream/PATH)")
        return text
    if address.isascii() and address.isdigit():
        host, port = "127.0.0.1", address
    elif address.startswith("["):
        inside, closed, rest = address[1:].partition("]")
        if not closed or not inside or (rest and not rest[1:]) or rest[:1] not in ("", ":"):
            raise InputError(
                f"--ros2 {given}: write an IPv6 address in brackets, then its port:"
                f" {protocol}/[::1]:7447"
            )
        host, port = f"[{inside}]", rest[1:] or "7447"
    elif address.count(":") > 1:  # '::1' was host ':' and port 1: Zenoh waited there
        raise InputError(
            f"--ros2 {given}: write an IPv6 address in brackets:"
            f" {_typed(f'{protocol}/[{address}]:7447')}"
        )
    else:
        host, _, port = address.rpartition(":") if ":" in address else (address, "", "7447")
        host = host or "127.0.0.1"
    if not (port.isascii() and port.isdigit()) or not 0 < int(port) <= 65535:
        raise InputError(f"--ros2 {given}: the port must be a number from 1 to 65535")
    return f"{protocol}/{host}:{int(port)}"


def _typed(text: str) -> str:
    """An endpoint as typed, for a message: as it is when printable and short, else
    its ``repr`` cut (``--ros2 $'a\\nb:1'`` was a message of two lines)."""
    return text if text.isprintable() and len(text) <= 80 else shown(text, 80)


def check_endpoint_host(text: str | None) -> None:
    """Refuse an endpoint whose host does not resolve (``--ros2 bogus``,
    ``--ros2 routr.lan:7447``), as ``--foxglove`` and ``--groot2`` refuse theirs, before
    the node's process starts. Until the twenty-second session the run went on, its node
    trying for ever to reach a router at a name that does not exist: the graph never saw
    the run and its e-stop topic never reached it (the log said so 2 s in, once).

    A host that resolves but where no router listens yet is no error: the node joins
    the graph when the router starts (docs/ros2.md). A unix socket has no host.

    Raises:
        InputError: the endpoint does not parse (:func:`parse_endpoint`), or its host
            does not resolve.
    """
    endpoint = parse_endpoint(text)
    protocol, _, address = endpoint.partition("/")
    if protocol == "unixsock-stream":
        return
    host, _, port = address.rpartition(":")
    try:  # UnicodeError: IDNA's, for a name such as a..b or a label over 63 characters
        socket.getaddrinfo(host.removeprefix("[").removesuffix("]"), int(port))
    except (OSError, UnicodeError, ValueError) as exc:
        given = _typed((text or "").strip() or endpoint)
        raise InputError(f"--ros2 {given}: unknown host: {exc}") from None


def domain_from_env() -> int:
    """``ROS_DOMAIN_ID`` as ROS reads it (0 when unset or empty).

    rcl reads it with ``strtoul(text, &end, 0)``: ``010`` is octal (domain 8),
    ``0x1f`` hexadecimal (31), a leading ``+`` is allowed. We read it the same
    way, so that a run joins the domain every ROS node started with the same
    environment joins (until 2026-11-30 ``010`` was domain 10 here, 8 for ROS).
    What rcl would read only in part (``3abc``, ``08``) is refused.

    Raises:
        InputError: it is set to something that is not a domain id (a number from 0 to
            232), naming the variable (``--ros-domain-id`` was not given).
    """
    raw = os.environ.get("ROS_DOMAIN_ID", "")
    text = raw.strip()
    if not text:
        return 0
    digits = text.removeprefix("+")
    if digits[:2] in ("0x", "0X"):
        base, digits = 16, digits[2:]
    elif len(digits) > 1 and digits.startswith("0"):
        base, digits = 8, digits[1:]
    else:
        base = 10
    allowed = "0123456789abcdefABCDEF"[: 10 if base == 10 else 8 if base == 8 else 22]
    if not digits or any(c not in allowed for c in digits):
        raise InputError(f"ROS_DOMAIN_ID={raw!r} is not a number")
    value = int(digits, base)
    if value > MAX_DOMAIN_ID:
        raise InputError(
            f"ROS_DOMAIN_ID={raw!r} is domain {value}: ROS domain ids go from 0 to {MAX_DOMAIN_ID}"
        )
    return value


def check_names(namespace: str, name: str, longest_topic: str = "") -> str:
    """``namespace`` as rmw writes it (``/`` first, none last; ``""`` for the root), after
    checking it and the node's ``name`` against rmw's rules
    (``rmw_validate_namespace``, ``rmw_validate_node_name``), as rcl does when a node
    starts; ``longest_topic`` (relative) must fit in a topic name in the namespace.

    A namespace without its leading ``/`` is taken as absolute, as rcl takes it.

    Raises:
        InputError: one line naming the option, the value and the rule it breaks.
    """
    shown = f"--ros-namespace {namespace!r}"
    full = namespace if namespace.startswith("/") else "/" + namespace
    if full != "/":
        if full.endswith("/"):
            raise InputError(f"{shown}: a ROS namespace does not end with '/'")
        if "//" in full:
            raise InputError(f"{shown}: a ROS namespace has no repeated '/'")
        for part in full[1:].split("/"):
            if not _TOKEN.fullmatch(part):
                raise InputError(
                    f"{shown}: {part!r} is no ROS name (letters, digits and _, not starting"
                    " with a digit)"
                )
        if len(full) > NAMESPACE_MAX:
            raise InputError(f"{shown}: longer than ROS's {NAMESPACE_MAX} characters")
        if longest_topic and len(f"{full}/{longest_topic}") > TOPIC_MAX:
            raise InputError(
                f"{shown}: too long for the topic {longest_topic!r} in it (ROS topic names"
                f" have at most {TOPIC_MAX} characters)"
            )
    if not _TOKEN.fullmatch(name) or len(name) > NODE_NAME_MAX:
        raise InputError(
            f"ROS 2 node name {name!r}: one part of letters, digits and _, not starting with"
            f" a digit, at most {NODE_NAME_MAX} characters"
        )
    return "" if full == "/" else full


def check_node_args(
    endpoint: object, domain_id: object, namespace: object, name: object, rate_hz: object
) -> None:
    """Refuse, in one line, a ``Ros2Node`` argument of the wrong kind or out of range.

    Until 2026-11-30 ``rate_hz=nan`` ended the node's process with a traceback at its
    first wait (the run went on, unseen and its e-stop topic unheard), ``rate_hz=inf``
    made it poll without a rest (a third of a core where 20 Hz takes 3 %),
    ``domain_id=3.7`` joined domain 3 and ``True`` domain 1, and text where a number
    goes (or a number where text goes) raised ``TypeError`` or ``AttributeError``.

    Raises:
        ArgumentTypeError: a value of the wrong kind.
        ArgumentValueError: a rate that is not a positive, finite number.
        InputError: an endpoint that does not parse, or whose host does not resolve
            (:func:`check_endpoint_host`).
    """
    for label, value in (("endpoint", endpoint), ("namespace", namespace), ("name", name)):
        if not isinstance(value, str) and not (label == "endpoint" and value is None):
            raise ArgumentTypeError(f"ROS 2 node: {label}: give text, not {kind_of(value)}")
    if domain_id is not None and (isinstance(domain_id, bool) or not isinstance(domain_id, int)):
        raise ArgumentTypeError(
            f"ROS 2 node: domain_id: give a whole number from 0 to {MAX_DOMAIN_ID},"
            f" not {shown(domain_id)}"
        )
    if isinstance(rate_hz, bool) or not isinstance(rate_hz, int | float):
        raise ArgumentTypeError(f"ROS 2 node: rate_hz: give a number, not {kind_of(rate_hz)}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ArgumentValueError(
            f"ROS 2 node: rate_hz: give a positive, finite number of frames a second,"
            f" not {shown(rate_hz)}"
        )
    assert endpoint is None or isinstance(endpoint, str)  # checked above
    check_endpoint_host(endpoint)  # last: it may ask a name server


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
