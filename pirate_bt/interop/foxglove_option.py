"""The ``--foxglove [HOST:PORT]`` option, without importing the server (fast ``--help``).

Shared by ``pirate-bt run``, ``mission``, ``teleop`` and ``sim``; the server is
:class:`pirate_bt.interop.foxglove_live.FoxgloveServer`.
"""

from __future__ import annotations

from typing import Any

from pirate_bt.errors import InputError

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "add_foxglove_option", "parse_address"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
"""foxglove-sdk's default port."""


def parse_address(text: str | None) -> tuple[str, int]:
    """``HOST:PORT``, ``HOST``, ``:PORT`` or ``PORT`` → ``(host, port)``; defaults fill gaps.

    Raises:
        InputError: a port that is not a number from 0 to 65535.
    """
    text = (text or "").strip()
    host, port_text = DEFAULT_HOST, ""
    if text.startswith("["):  # [::1]:8765
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
    if not (port_text.isascii() and port_text.isdigit()) or int(port_text) > 65535:
        raise InputError(f"--foxglove {text}: the port must be a number from 0 to 65535")
    return host, int(port_text)


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
