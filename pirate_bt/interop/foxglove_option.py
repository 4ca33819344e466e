"""The ``--foxglove [HOST:PORT]`` option, without importing the server (fast ``--help``).

Shared by ``pirate-bt run``, ``mission``, ``teleop`` and ``sim``; the server is
:class:`pirate_bt.interop.foxglove_live.FoxgloveServer`.
"""

from __future__ import annotations

from typing import Any

from pirate_bt.errors import ArgumentTypeError, ArgumentValueError, kind_of, shown
from pirate_bt.interop.address import parse_host_port

__all__ = [
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "add_foxglove_option",
    "check_server_args",
    "parse_address",
]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
"""foxglove-sdk's default port."""


def parse_address(text: str | None) -> tuple[str, int]:
    """``HOST:PORT``, ``HOST``, ``:PORT`` or ``PORT`` -> ``(host, port)``; defaults fill gaps.

    Raises:
        InputError: a port that is not a number from 0 to 65535, a ``:`` with no
            port after it, or an unclosed ``[``
            (:func:`~pirate_bt.interop.address.parse_host_port`).
    """
    return parse_host_port(
        text, option="--foxglove", host=DEFAULT_HOST, port=DEFAULT_PORT, max_port=65535
    )


def check_server_args(host: object, port: object) -> None:
    """Refuse a ``FoxgloveServer`` host or port it cannot use, before anything starts.

    Until 2026-11-30 ``FoxgloveServer(host, 70000)`` started the server's process and
    returned a server that never listened (``failure``: ``OverflowError: number too large
    to fit in target type``), with no error; ``-1`` and ``True`` were called an unknown
    host, and ``None`` for the host was a ``TypeError`` traceback.

    Raises:
        ArgumentTypeError: a host that is not text, a port that is not a whole number.
        ArgumentValueError: a port outside 0 to 65535.
    """
    if not isinstance(host, str):
        raise ArgumentTypeError(f"FoxgloveServer: host: give text, not {kind_of(host)}")
    if isinstance(port, bool) or not isinstance(port, int):
        raise ArgumentTypeError(
            f"FoxgloveServer: port: give a whole number from 0 to 65535, not {shown(port)}"
        )
    if not 0 <= port <= 65535:
        raise ArgumentValueError(
            f"FoxgloveServer: port: give a whole number from 0 to 65535, not {shown(port)}"
        )


def add_foxglove_option(parser: Any) -> None:
    """Add ``--foxglove [HOST:PORT]`` to an argparse parser."""
    parser.add_argument(
        "--foxglove",
        nargs="?",
        const=f"{DEFAULT_HOST}:{DEFAULT_PORT}",
        metavar="HOST:PORT",
        help="serve the run live to Foxglove/Lichtblick over WebSocket"
        f" (default {DEFAULT_HOST}:{DEFAULT_PORT}; 0.0.0.0:PORT opens it to the network,"
        " without authentication)",
    )
