"""A small Foxglove WebSocket client for the tests (standard library only).

It speaks just enough RFC 6455 (client handshake with the
``foxglove.websocket.v1`` subprotocol, masked text frames out, text, binary,
ping and close frames in, fragments joined) and of the Foxglove WebSocket
protocol (``advertise`` → ``subscribe`` → binary ``messageData``, opcode 1:
subscription id u32, log time u64, payload) to check what a Foxglove app would
see. No third-party client is needed.

It offers both names of the protocol, as the Foxglove app and recent Lichtblick
do: ``foxglove.sdk.v1`` (what foxglove-sdk servers accept, the same protocol
renamed) and ``foxglove.websocket.v1`` (the older name).
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import socket
import struct
import time
from typing import Any

SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")


class FoxgloveClient:
    """A client connected to ``ws://host:port``.

    Attributes:
        channels: Advertised channels by topic (``id``, ``topic``, ``schemaName``...).
        messages: Received messages as ``(topic, log_time_ns, decoded JSON)``.
    """

    def __init__(
        self,
        host: str,
        port: int,
        timeout_s: float = 10.0,
        subprotocols: tuple[str, ...] = SUBPROTOCOLS,
    ) -> None:
        self.sock = socket.create_connection((host, port), timeout=timeout_s)
        key = base64.b64encode(os.urandom(16)).decode()
        offered = ", ".join(subprotocols)
        request = (
            f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: {offered}\r\n\r\n"
        )
        self.sock.sendall(request.encode())
        response = b""
        while b"\r\n\r\n" not in response:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise ConnectionError("closed during the handshake")
            response += chunk
        head, _, self._buffer = response.partition(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        if " 101 " not in lines[0]:
            raise ConnectionError(f"no upgrade: {lines[0]}")
        headers = {k.lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:])}
        self.subprotocol = headers.get("sec-websocket-protocol")
        self.server_info: dict[str, Any] | None = None
        self.channels: dict[str, dict[str, Any]] = {}
        self.messages: list[tuple[str, int, Any]] = []
        self._subscriptions: dict[int, str] = {}
        self._next_id = 1

    # -- frames

    def _read_exact(self, size: int) -> bytes:
        while len(self._buffer) < size:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("connection closed")
            self._buffer += chunk
        data, self._buffer = self._buffer[:size], self._buffer[size:]
        return data

    def _frame(self) -> tuple[int, bool, bytes]:
        first, second = self._read_exact(2)
        size = second & 0x7F
        if size == 126:
            (size,) = struct.unpack(">H", self._read_exact(2))
        elif size == 127:
            (size,) = struct.unpack(">Q", self._read_exact(8))
        mask = self._read_exact(4) if second & 0x80 else b""
        payload = self._read_exact(size)
        if mask:
            payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        return first & 0x0F, bool(first & 0x80), payload

    def _send(self, opcode: int, payload: bytes) -> None:
        mask = os.urandom(4)
        size = len(payload)
        head = bytes([0x80 | opcode])
        if size < 126:
            head += bytes([0x80 | size])
        elif size < 1 << 16:
            head += bytes([0x80 | 126]) + struct.pack(">H", size)
        else:
            head += bytes([0x80 | 127]) + struct.pack(">Q", size)
        masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        self.sock.sendall(head + mask + masked)

    def receive(self) -> tuple[int, bytes]:
        """The next whole message: ``(1, text)`` or ``(2, binary)``; answers pings."""
        opcode, data = -1, b""
        while True:
            op, final, payload = self._frame()
            if op == 9:  # ping
                self._send(10, payload)
                continue
            if op == 10:
                continue
            if op == 8:
                raise ConnectionError("server closed the connection")
            if op != 0:
                opcode, data = op, payload
            else:
                data += payload
            if final:
                return opcode, data

    # -- the Foxglove protocol

    def send_json(self, message: dict[str, Any]) -> None:
        self._send(1, json.dumps(message).encode())

    def pump(self, timeout_s: float) -> None:
        """Read and handle what arrives for up to ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.sock.settimeout(max(0.01, deadline - time.monotonic()))
            try:
                opcode, data = self.receive()
            except TimeoutError:
                return
            self._handle(opcode, data)

    def _handle(self, opcode: int, data: bytes) -> None:
        if opcode == 1:
            message = json.loads(data)
            if message.get("op") == "serverInfo":
                self.server_info = message
            elif message.get("op") == "advertise":
                for channel in message["channels"]:
                    self.channels[channel["topic"]] = channel
        elif opcode == 2 and data and data[0] == 1:  # messageData
            subscription, log_time = struct.unpack_from("<IQ", data, 1)
            topic = self._subscriptions.get(subscription, "?")
            self.messages.append((topic, log_time, json.loads(data[13:])))

    def subscribe(self, *topics: str) -> None:
        """Subscribe to advertised topics."""
        subscriptions = []
        for topic in topics:
            channel = self.channels[topic]
            self._subscriptions[self._next_id] = topic
            subscriptions.append({"id": self._next_id, "channelId": channel["id"]})
            self._next_id += 1
        self.send_json({"op": "subscribe", "subscriptions": subscriptions})

    def wait_for(self, predicate: Any, timeout_s: float = 10.0) -> bool:
        """Pump until ``predicate(self)`` holds or time is up."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if predicate(self):
                return True
            self.pump(0.05)
        return bool(predicate(self))

    def of(self, topic: str) -> list[Any]:
        """Messages received on ``topic``."""
        return [m for t, _, m in self.messages if t == topic]

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self._send(8, struct.pack(">H", 1000))
        self.sock.close()
