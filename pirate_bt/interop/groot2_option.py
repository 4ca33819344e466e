"""The ``--groot2 [HOST:]PORT`` option, without importing the server (fast ``--help``).

Shared by ``pirate-bt run``, ``mission`` and ``teleop --tree``; the server is
:class:`pirate_bt.interop.groot2_server.Groot2Server`.
"""

from __future__ import annotations

from typing import Any

from pirate_bt.interop.address import parse_host_port

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "add_groot2_option", "parse_groot2_address"]

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
