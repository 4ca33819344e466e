"""The ``--groot2 [HOST:]PORT`` option and the server's arguments checked, without
importing the server (fast ``--help``).

Shared by ``pirate-bt run``, ``mission`` and ``teleop --tree``; the server is
:class:`pirate_bt.interop.groot2_server.Groot2Server`.
"""

from __future__ import annotations

import math
from typing import Any

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, kind_of, shown
from pirate_bt.interop.address import parse_host_port

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "add_groot2_option",
    "check_server_args",
    "parse_groot2_address",
]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 1667
"""BehaviorTree.CPP's ``Groot2Publisher`` default; the PUB socket is the next port."""


def parse_groot2_address(text: str | None) -> tuple[str, int]:
    """``HOST:PORT``, ``HOST``, ``:PORT`` or ``PORT`` -> ``(host, port)``; defaults fill gaps.

    Raises:
        InputError: a port that is not a number from 0 to 65534, a ``:`` with no
            port after it, or an unclosed ``[``
            (:func:`~pirate_bt.interop.address.parse_host_port`).
    """
    return parse_host_port(
        text,
        option="--groot2",
        host=DEFAULT_HOST,
        port=DEFAULT_PORT,
        max_port=65534,
        note=" (the next one is the publisher's)",
    )


def add_groot2_option(parser: Any) -> None:
    """Add ``--groot2 [HOST:]PORT`` to an argparse parser."""
    parser.add_argument(
        "--groot2",
        nargs="?",
        const=f"{DEFAULT_HOST}:{DEFAULT_PORT}",
        metavar="[HOST:]PORT",
        help="serve the run live to Groot2 (BehaviorTree.CPP's protocol; default"
        f" {DEFAULT_HOST}:{DEFAULT_PORT} and the next port; 0.0.0.0:PORT opens it to the"
        " network, without authentication: anyone who reaches it may set breakpoints)",
    )


def check_server_args(host: object, port: object, heartbeat_s: object) -> None:
    """Refuse what the server cannot use, before anything binds. Until 2026-11-30 a port
    given as text (read from a file or the environment) was a ``TypeError`` traceback,
    ``port=1.5`` bound ports 1 and 2 (ZeroMQ reads the digits it can), and a heartbeat of
    ``nan``, 0 or less removed every hook as soon as it was set (against a robot, a held
    breakpoint then put it in its safe state), ``inf`` never (the fail-safe was off)."""
    if not isinstance(host, str):
        raise ArgumentTypeError(f"Groot2Server: host: give text, not {kind_of(host)}")
    if isinstance(port, bool) or not isinstance(port, int):
        raise ArgumentTypeError(
            f"Groot2Server: port: give a whole number from 0 to 65534, not {shown(port)}"
        )
    if isinstance(heartbeat_s, bool) or not isinstance(heartbeat_s, int | float):
        raise ArgumentTypeError(
            f"Groot2Server: heartbeat_s: give a number of seconds, not {kind_of(heartbeat_s)}"
        )
    if not (math.isfinite(heartbeat_s) and heartbeat_s > 0):
        raise ArgumentValueError(
            f"Groot2Server: heartbeat_s: give a positive, finite number of seconds (the"
            f" silence after which every hook is removed), not {shown(heartbeat_s)}"
        )
