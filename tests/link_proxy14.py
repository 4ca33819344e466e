"""A man in the middle for probe 14: a TCP relay between a host and ``pirate-bt sim --tcp``.

It listens on 127.0.0.1 (a free port), accepts one host, connects to the upstream
bridge and pumps bytes both ways in one thread (``selectors``). Each direction passes
through a :class:`Mangler` (seeded random: drop, duplicate, flip bits, reorder, split at
every byte) and the test can, at any time:

- :meth:`LinkProxy.stall` the line (both directions held, nothing lost) for a while;
- :meth:`LinkProxy.cut` it for good (bytes swallowed both ways, sockets left open), or
  :meth:`LinkProxy.hang_up` (sockets closed);
- :meth:`LinkProxy.inject` bytes toward the host or the bridge;
- :meth:`LinkProxy.record` what went by (``seen[direction]``).

The simulator runs in process behind :class:`~pirate_bt.sim.server.SimServer`, so the
test reads its end state (counters, truth, the bridge's flags) directly.
"""

from __future__ import annotations

import contextlib
import random
import selectors
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

TO_HOST = "to_host"
TO_BRIDGE = "to_bridge"


@dataclass
class Mangler:
    """What one direction does to its bytes (all probabilities per byte, seeded)."""

    seed: int = 0
    drop: float = 0.0
    duplicate: float = 0.0
    flip: float = 0.0
    reorder: float = 0.0  # per chunk: swap it with the next one
    repeat: float = 0.0  # per chunk: send it twice (a whole frame, as the host writes one)
    split: bool = False  # forward one byte per write
    delay: float = 0.0  # seconds every byte is held (a slow line, order kept)
    limit: float = -1  # pass this many bytes, then nothing (a cut at a byte boundary)
    rng: random.Random = field(init=False)
    _held: bytes = b""

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)

    def __call__(self, data: bytes) -> list[bytes]:
        if self.limit >= 0:
            data = data[: int(self.limit)]
            self.limit -= len(data)
        out = bytearray()
        for b in data:
            r = self.rng.random()
            if r < self.drop:
                continue
            if self.flip and self.rng.random() < self.flip:
                b ^= 1 << self.rng.randrange(8)
            out.append(b)
            if self.duplicate and self.rng.random() < self.duplicate:
                out.append(b)
        chunk = bytes(out)
        if self.repeat and self.rng.random() < self.repeat:
            chunk += chunk
        if self.reorder and chunk and self.rng.random() < self.reorder and not self._held:
            self._held = chunk
            return []
        chunks = [chunk, self._held] if self._held else [chunk]
        self._held = b""
        if self.split:
            return [bytes([b]) for c in chunks for b in c]
        return [c for c in chunks if c]


class LinkProxy:
    """The relay; ``url`` is what the host opens."""

    def __init__(
        self,
        upstream: tuple[str, int],
        *,
        to_host: Callable[[bytes], list[bytes]] | None = None,
        to_bridge: Callable[[bytes], list[bytes]] | None = None,
    ) -> None:
        self.upstream = upstream
        self.mangle = {TO_HOST: to_host, TO_BRIDGE: to_bridge}
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._listener.bind(("127.0.0.1", 0))
        self._listener.listen(1)
        self.address = self._listener.getsockname()
        self.url = f"socket://{self.address[0]}:{self.address[1]}"
        self._lock = threading.Lock()
        self._stall_until = {TO_HOST: 0.0, TO_BRIDGE: 0.0}
        self._cut = False
        self._hung_up = False
        self._redial = False
        self._stop = threading.Event()
        self._pending: dict[str, list[tuple[float, bytes]]] = {TO_HOST: [], TO_BRIDGE: []}
        self.seen: dict[str, bytearray] = {TO_HOST: bytearray(), TO_BRIDGE: bytearray()}
        self.bytes_in: dict[str, int] = {TO_HOST: 0, TO_BRIDGE: 0}
        self.host: socket.socket | None = None
        self.bridge: socket.socket | None = None
        self.connected = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="proxy14", daemon=True)
        self._thread.start()

    # -- controls -----------------------------------------------------------------

    def stall(self, seconds: float, direction: str = "") -> None:
        """Hold every byte (one way, or both) for ``seconds`` (delivered afterwards)."""
        with self._lock:
            for way in (direction,) if direction else (TO_HOST, TO_BRIDGE):
                self._stall_until[way] = time.monotonic() + seconds

    def cut(self) -> None:
        """Swallow every byte both ways from now on (the sockets stay open)."""
        with self._lock:
            self._cut = True

    def hang_up(self) -> None:
        """Close both sockets (a bridge or cable pulled: the host reads EOF)."""
        with self._lock:
            self._hung_up = True

    def redial(self) -> None:
        """Close the connection to the bridge and connect again at once (an adapter that
        resets between the host and the bridge; the host's connection stays up)."""
        with self._lock:
            self._redial = True

    def inject(self, direction: str, data: bytes) -> None:
        """Queue ``data`` toward the host or the bridge (after what is queued)."""
        with self._lock:
            self._pending[direction].append((0.0, data))

    def set_mangler(self, direction: str, fn: Callable[[bytes], list[bytes]] | None) -> None:
        with self._lock:
            self.mangle[direction] = fn

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        for sock in (self.host, self.bridge, self._listener):
            if sock is not None:
                with contextlib.suppress(OSError):
                    sock.close()

    def __enter__(self) -> LinkProxy:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- pump ---------------------------------------------------------------------

    def _serve(self) -> None:
        self._listener.settimeout(0.1)
        while not self._stop.is_set():
            try:
                host, _ = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            break
        else:
            return
        bridge = socket.create_connection(self.upstream)
        for sock in (host, bridge):
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            sock.setblocking(False)
        self.host, self.bridge = host, bridge
        self.connected.set()
        peer = {TO_HOST: host, TO_BRIDGE: bridge}
        source = {host: TO_BRIDGE, bridge: TO_HOST}
        sel = selectors.DefaultSelector()
        sel.register(host, selectors.EVENT_READ)
        sel.register(bridge, selectors.EVENT_READ)
        try:
            while not self._stop.is_set():
                with self._lock:
                    if self._hung_up:
                        break
                    redial, self._redial = self._redial, False
                if redial:
                    sel.unregister(bridge)
                    bridge.close()
                    bridge = socket.create_connection(self.upstream)
                    bridge.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    bridge.setblocking(False)
                    sel.register(bridge, selectors.EVENT_READ)
                    self.bridge = bridge
                    peer[TO_BRIDGE] = bridge
                    source = {host: TO_BRIDGE, bridge: TO_HOST}
                for key, _ in sel.select(0.002):
                    sock = key.fileobj
                    assert isinstance(sock, socket.socket)
                    try:
                        data = sock.recv(4096)
                    except BlockingIOError:
                        continue
                    except OSError:
                        data = b""
                    if not data:
                        return
                    direction = source[sock]
                    self.bytes_in[direction] += len(data)
                    with self._lock:
                        if self._cut:
                            continue
                        fn = self.mangle[direction]
                        due = time.monotonic() + getattr(fn, "delay", 0.0)
                        chunks = fn(data) if fn else [data]
                        self._pending[direction].extend((due, c) for c in chunks)
                self._flush(peer)
        finally:
            sel.close()
            for sock in (host, self.bridge):
                if sock is not None:
                    with contextlib.suppress(OSError):
                        sock.close()

    def _flush(self, peer: dict[str, socket.socket]) -> None:
        now = time.monotonic()
        with self._lock:
            todo: dict[str, list[bytes]] = {}
            for direction, pending in self._pending.items():
                if now < self._stall_until[direction]:
                    continue
                ready = 0
                while ready < len(pending) and pending[ready][0] <= now:
                    ready += 1
                todo[direction] = [c for _, c in pending[:ready]]
                del pending[:ready]
        for direction, chunks in todo.items():
            for chunk in chunks:
                self.seen[direction] += chunk
                with contextlib.suppress(OSError):
                    peer[direction].setblocking(True)
                    peer[direction].sendall(chunk)
                    peer[direction].setblocking(False)


# -- in a process of its own ---------------------------------------------------------------


def _mangler(text: str) -> Mangler | None:
    """``seed=1,drop=0.01,split=1`` -> a :class:`Mangler` (``-`` for none)."""
    if text in ("", "-"):
        return None
    fields: dict[str, float] = {}
    for item in text.split(","):
        key, _, value = item.partition("=")
        fields[key] = float(value)
    seed = int(fields.pop("seed", 0))
    split = bool(fields.pop("split", 0))
    return Mangler(seed, split=split, **fields)


class ProxyProcess:
    """A :class:`LinkProxy` in a child process (so the test's own threads, the host's
    and the simulator's, do not share its interpreter lock), driven by lines on its
    stdin: ``stall S``, ``cut``, ``hangup``, ``inject DIRECTION HEX``,
    ``mangle DIRECTION SPEC``, ``quit``."""

    def __init__(
        self, upstream: tuple[str, int], *, to_host: str = "-", to_bridge: str = "-"
    ) -> None:
        import subprocess
        import sys

        self._proc = subprocess.Popen(
            [sys.executable, __file__, upstream[0], str(upstream[1]), to_host, to_bridge],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        assert self._proc.stdout is not None
        line = self._proc.stdout.readline()
        self.url = line.strip()
        assert self.url.startswith("socket://"), line

    def send(self, line: str) -> None:
        assert self._proc.stdin is not None
        self._proc.stdin.write(line + "\n")
        self._proc.stdin.flush()

    def stall(self, seconds: float, direction: str = "") -> None:
        self.send(f"stall {seconds} {direction}".strip())

    def cut(self) -> None:
        self.send("cut")

    def hang_up(self) -> None:
        self.send("hangup")

    def redial(self) -> None:
        self.send("redial")

    def inject(self, direction: str, data: bytes) -> None:
        self.send(f"inject {direction} {data.hex()}")

    def mangle(self, direction: str, spec: str) -> None:
        self.send(f"mangle {direction} {spec}")

    def close(self) -> None:
        with contextlib.suppress(OSError, ValueError):
            self.send("quit")
        try:
            self._proc.wait(timeout=3)
        except Exception:
            self._proc.kill()
            self._proc.wait()

    def __enter__(self) -> ProxyProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _main(argv: list[str]) -> None:
    import sys

    proxy = LinkProxy(
        (argv[0], int(argv[1])), to_host=_mangler(argv[2]), to_bridge=_mangler(argv[3])
    )
    print(proxy.url, flush=True)
    for line in sys.stdin:
        word, *rest = line.split()
        if word == "stall":
            proxy.stall(float(rest[0]), *rest[1:])
        elif word == "cut":
            proxy.cut()
        elif word == "hangup":
            proxy.hang_up()
        elif word == "redial":
            proxy.redial()
        elif word == "inject":
            proxy.inject(rest[0], bytes.fromhex(rest[1]))
        elif word == "mangle":
            proxy.set_mangler(rest[0], _mangler(rest[1]))
        elif word == "quit":
            break
    proxy.close()


if __name__ == "__main__":
    import sys

    _main(sys.argv[1:])
