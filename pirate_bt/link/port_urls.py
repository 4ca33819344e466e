"""Which URL schemes a port may have here, and what is wrong with a URL's scheme.

pyserial opens ``scheme://...`` with the module ``protocol_<scheme>`` of the first
package of ``serial.protocol_handler_packages`` that has one (its own
``serial.urlhandler``: ``alt``, ``hwgrep``, ``loop``, ``rfc2217``, ``socket``, ``spy``,
and ``cp2110`` where ``hid`` is installed; the simulator adds ``sim`` and ``chain``).
A scheme none of them has, or a URL that names nothing after a scheme that needs a
device, is the user's input, not a link that failed: :func:`scheme_problem` says what
is wrong before anything opens (:class:`~pirate_bt.link.transport.PortURLError`, exit
2). Before 2026-11-30 ``--port bogus://x`` exited 3 with pyserial's *invalid URL,
protocol 'bogus' not known*, and ``hwgrep://`` (an empty pattern) opened whatever
serial port the machine listed first.
"""

from __future__ import annotations

import importlib
import pkgutil
import re

import serial

__all__ = ["scheme_problem", "url_schemes"]

_SCHEME = re.compile(r"[a-z0-9]+")
_DEVICE = "a device (/dev/ttyACM0, COM3)"
# schemes that wrap a device or a pattern: nothing after them names no port
_NEEDS_TARGET = {
    "spy": "spy://DEVICE",
    "alt": "alt://DEVICE?class=NAME",
    "hwgrep": "hwgrep://PATTERN",
    "cp2110": "cp2110://USB_PATH",
}


def _load(scheme: str) -> str | None:
    """Load ``scheme``'s handler as pyserial would: ``None`` when one loads, ``""``
    when no package has one, else why it does not load (a module it needs is missing)."""
    if not _SCHEME.fullmatch(scheme):
        return ""
    for package in serial.protocol_handler_packages:
        name = f"{package}.protocol_{scheme}"
        try:
            importlib.import_module(name)
        except ImportError as exc:
            if exc.name in (name, package):  # no such handler (or package): the next one
                continue
            return str(exc)  # the handler is there but needs what is not installed
        return None
    return ""


def url_schemes() -> tuple[str, ...]:
    """The schemes a port's URL may have here, sorted (only when an error names them):
    those whose handler loads, but the simulator's in-process ones (``sim://``,
    ``chain://``: a program reaches a simulator by ``connect("sim:NETWORK")``, and a
    command line by ``--sim``, never as a port)."""
    found: set[str] = set()
    for package in serial.protocol_handler_packages:
        if package.startswith("pirate_bt."):
            continue
        try:
            module = importlib.import_module(package)
        except ImportError:
            continue
        for info in pkgutil.iter_modules(getattr(module, "__path__", [])):
            scheme = info.name.removeprefix("protocol_")
            if scheme != info.name and _load(scheme) is None:
                found.add(scheme)
    return tuple(sorted(found))


def scheme_problem(url: str) -> str | None:
    """What is wrong with ``url``'s scheme, or ``None`` (a device path has none).

    Only the scheme, and for a scheme that wraps a device (``spy://``, ``alt://``,
    ``hwgrep://``), that something follows it; a network URL's host and port are
    :func:`~pirate_bt.link.transport.network_url_problem`'s.
    """
    if "://" not in url:  # pyserial's own test: a device path
        return None
    typed, _, rest = url.partition("://")
    scheme = typed.lower()
    why = _load(scheme)
    if why is None:
        if scheme in _NEEDS_TARGET and not rest.partition("?")[0]:
            return f"nothing after {typed}://; give {_NEEDS_TARGET[scheme]}"
        return None
    known = ", ".join(f"{s}://" for s in url_schemes())
    if why:
        return (
            f"the {typed}:// scheme's handler does not load here ({why}); a port is {_DEVICE}"
            f" or a URL of {known}"
        )
    return f"no URL scheme {typed!r} here: a port is {_DEVICE} or a URL of {known}"
