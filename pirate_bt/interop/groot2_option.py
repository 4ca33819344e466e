"""The ``--groot2 [HOST:]PORT`` option, without importing the server (fast ``--help``).

Shared by ``pirate-bt run``, ``mission`` and ``teleop --tree``; the server is
:class:`pirate_bt.interop.groot2_server.Groot2Server`.
"""

from __future__ import annotations

from typing import Any

from pirate_bt.errors import InputError

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "add_groot2_option", "parse_groot2_address"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 1667
"""BehaviorTree.CPP's ``Groot2Publisher`` default; the PUB socket is the next port."""


def parse_groot2_address(text: str | None) -> tuple[str, int]:
    """``HOST:PORT``, ``HOST``, ``:PORT`` or ``PORT`` -> ``(host, port)``; defaults fill gaps.

    Raises:
        InputError: a port that is not a number from 0 to 65534.
    """
    text = (text or "").strip()
    host, port_text = DEFAULT_HOST, ""
    if text.startswith("["):  # [::1]:1667
        inside, _, rest = text[1:].partition("]")
        host, port_text = inside or DEFAULT_HOST, rest.removeprefix(":")
    elif text.count(":") == 1:
        host, _, port_text = text.partition(":")
        host = host or DEFAULT_HOST
    elif text.isascii() and text.isdigit():
        port_text = text
    elif text:
        host = text
    if not port_text:
        return host, DEFAULT_PORT
    if not (port_text.isascii() and port_text.isdigit()) or int(port_text) > 65534:
        raise InputError(
            f"--groot2 {text}: the port must be a number from 0 to 65534 (the next one is"
            " the publisher's)"
        )
    return host, int(port_text)


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
