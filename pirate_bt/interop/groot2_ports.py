"""The Groot2 server's TCP ports, as the server holds them: the relay process
(:mod:`pirate_bt.interop.groot2_relay`) started, looked at and ended.

:class:`~pirate_bt.interop.groot2_server.Groot2Server` binds its own two sockets to
Unix sockets in a folder of the user's and starts the relay, which listens on the
TCP ports Groot2 connects to. The relay ends when its standard input closes: the
server closed it, or the run's process ended.
"""

from __future__ import annotations

import contextlib
import json
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

from pirate_bt.errors import ConfigurationError, InputError
from pirate_bt.interop import groot2_relay
from pirate_bt.trace.sink_formats import to_null

__all__ = [
    "RELAY_START_S",
    "RELAY_STOP_S",
    "end_relay",
    "relay_ended",
    "relay_to_null",
    "start_relay",
]

_RELAY = Path(groot2_relay.__file__).resolve()
RELAY_START_S = 30.0
"""The longest wait for the relay process to listen (a loaded machine's start-up)."""
RELAY_STOP_S = 5.0
"""The longest wait for the relay process to end once its standard input closed."""


def start_relay(
    host: str, port: int, sockets: dict[str, Any]
) -> tuple[subprocess.Popen[bytes], int]:
    """Start the relay on ``host:port`` for the server's ``sockets`` (the relay's
    configuration: the Unix sockets, the folder, the limits); return it and the port
    it listens on (``port``, or the one it picked for 0).

    Raises:
        ConfigurationError: the process cannot be started.
        InputError: it cannot listen there (the one line it said), or said nothing in
            :data:`RELAY_START_S`; it has been ended.
    """
    config = {"host": host, "port": port, "sys_path": list(sys.path), **sockets}
    try:
        relay = subprocess.Popen(
            [sys.executable, "-I", str(_RELAY), json.dumps(config)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            start_new_session=True,  # a signal to the run's process group spares it
        )
    except OSError as exc:
        raise ConfigurationError(f"--groot2: cannot start the relay process: {exc}") from None
    try:
        where = f"[{host}]" if ":" in host else host
        said = groot2_relay.first_line(relay.stdout, RELAY_START_S)
        if said is None:
            raise InputError(
                f"--groot2 {where}:{port}: cannot start the server: no answer in"
                f" {RELAY_START_S:g} s"
            )
        if "error" in said:
            raise InputError(str(said["error"]))
        return relay, int(said["port"])
    except BaseException:
        end_relay(relay)
        raise


def end_relay(relay: subprocess.Popen[bytes] | None) -> None:
    """End the relay: close its standard input (it ends then), wait, kill if it must."""
    if relay is None:
        return
    with contextlib.suppress(OSError):
        assert relay.stdin is not None and relay.stdout is not None
        relay.stdin.close()
        relay.stdout.close()
    try:
        relay.wait(RELAY_STOP_S)
    except subprocess.TimeoutExpired:
        relay.kill()
        relay.wait()


def relay_ended(relay: subprocess.Popen[bytes]) -> str | None:
    """How the relay ended (``"exit status 1"``, ``"signal 9 (SIGKILL)"``), or ``None``
    while it runs."""
    code = relay.poll()
    if code is None:
        return None
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"signal {-code} ({signal.Signals(-code).name})"
        return f"signal {-code}"
    return f"exit status {code}"


def relay_to_null(relay: subprocess.Popen[bytes] | None) -> None:
    """In a forked process: point its copies of the relay's pipes at ``/dev/null`` (the
    child's copy kept the relay listening after the server closed, for as long as the
    child lived)."""
    if relay is not None and relay.stdin is not None and relay.stdout is not None:
        to_null(relay.stdin.fileno(), relay.stdout.fileno())
