"""``HOST:PORT`` as the live views' options take it (``--groot2``, ``--foxglove``).

One parser for both, strict where a typo would otherwise pick another host: an
unclosed ``[`` or text after ``]`` other than ``:PORT``, an IPv6 address without its
brackets (``::1:1700``: port 1700 of ``::1``, or ``::1:1700`` itself?), and a ``:``
with no port after it, are refused rather than read as a host name.
"""

from __future__ import annotations

from pirate_bt.errors import InputError

__all__ = ["parse_host_port"]


def parse_host_port(
    text: str | None, *, option: str, host: str, port: int, max_port: int, note: str = ""
) -> tuple[str, int]:
    """``HOST:PORT``, ``[IPv6]:PORT``, ``HOST``, ``:PORT`` or ``PORT`` -> ``(host, port)``.

    Args:
        text: What the user wrote (``None`` or empty: the defaults).
        option: The option's name, for messages (``--groot2``).
        host: The default host.
        port: The default port.
        max_port: The largest port allowed.
        note: Said after the port's range in its message.

    Raises:
        InputError: a port that is not a number from 0 to ``max_port``, a ``:`` with no
            port after it, or an IPv6 address without its brackets or whose ``[`` is not
            closed.
    """
    written = (text or "").strip()
    port_text: str | None = None
    if written.startswith("["):  # [::1]:1667
        inside, closed, rest = written[1:].partition("]")
        if not closed or (rest and not rest.startswith(":")):
            raise InputError(
                f"{option} {written}: write an IPv6 address in brackets, then its port: [::1]:PORT"
            )
        host = inside or host
        port_text = rest[1:] if rest else None
    elif written.count(":") > 1:
        # '::1:1700' is itself an IPv6 address: the user may have meant [::1]:1700, or
        # [::1:1700] on the default port; as --ros2 does, only brackets say which
        raise InputError(
            f"{option} {written}: write an IPv6 address in brackets, then its port: [::1]:PORT"
        )
    elif written.count(":") == 1:
        given_host, _, port_text = written.partition(":")
        host = given_host or host
    elif written.isascii() and written.isdigit():
        port_text = written
    elif written:
        host = written
    if port_text is None:
        return host, port
    if not (port_text.isascii() and port_text.isdigit()) or int(port_text) > max_port:
        raise InputError(
            f"{option} {written}: the port must be a number from 0 to {max_port}{note}"
        )
    return host, int(port_text)
