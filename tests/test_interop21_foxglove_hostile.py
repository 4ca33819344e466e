"""The live Foxglove server against a client written from RFC 6455 and the Foxglove
WebSocket spec that sends what no client should: frames no client may send, bytes no
message holds, a frame announced far longer than it is, a connection dropped mid-frame.
The server (its own process) drops that client and goes on serving the others."""

from __future__ import annotations

import json
import os
import socket
import struct
from collections.abc import Callable

import pytest
from foxglove_ws import SUBPROTOCOLS, FoxgloveClient

pytest.importorskip("foxglove")

from pirate_bt.interop.foxglove_live import FoxgloveServer


def _frame(opcode: int, payload: bytes, masked: bool = True, length: int | None = None) -> bytes:
    size = len(payload) if length is None else length
    mask_bit = 0x80 if masked else 0
    head = bytes([0x80 | opcode])
    if size < 126:
        head += bytes([mask_bit | size])
    elif size < 1 << 16:
        head += bytes([mask_bit | 126]) + struct.pack(">H", size)
    else:
        head += bytes([mask_bit | 127]) + struct.pack(">Q", size)
    if not masked:
        return head + payload
    key = os.urandom(4)
    return head + key + bytes(b ^ key[i % 4] for i, b in enumerate(payload))


def _text(message: object) -> bytes:
    return _frame(1, json.dumps(message).encode())


HOSTILE: dict[str, Callable[[], bytes]] = {
    "text that is no UTF-8": lambda: _frame(1, b"\xff\xfe\xfd"),
    "text that is no JSON": lambda: _frame(1, b"{not json"),
    "an unknown op": lambda: _text({"op": "nope"}),
    "a subscription to no channel": lambda: _text(
        {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 99999}]}
    ),
    "one subscription id twice": lambda: _text(
        {"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 1}] * 2}
    ),
    "an unsubscription of nothing": lambda: _text(
        {"op": "unsubscribe", "subscriptionIds": [5, -1, "x"]}
    ),
    "client message data unadvertised": lambda: _frame(2, b"\x01\x01\x00\x00\x00{}"),
    "an unmasked frame": lambda: _frame(1, b'{"op": "nope"}', masked=False),
    "a frame of 2**62 bytes, cut": lambda: _frame(2, b"abc", length=1 << 62),
    "half a frame": lambda: _text({"op": "subscribe", "subscriptions": []})[:9],
    "a reserved opcode": lambda: _frame(3, b"x"),
}


def _has_tick(n: int) -> Callable[[FoxgloveClient], bool]:
    return lambda client: any(m.get("n") == n for m in client.of("/pirate/tree"))


def _raw(port: int) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    key = "dGhlIHNhbXBsZSBub25jZQ=="
    sock.sendall(
        (
            f"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13"
            f"\r\nSec-WebSocket-Protocol: {', '.join(SUBPROTOCOLS)}\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = sock.recv(4096)
        assert chunk, "closed during the handshake"
        head += chunk
    assert b" 101 " in head.split(b"\r\n", 1)[0], head[:80]
    return sock


def test_a_client_sending_what_no_client_should_is_dropped_and_the_others_are_served() -> None:
    with FoxgloveServer(port=0) as server:
        watcher = FoxgloveClient("127.0.0.1", server.port)
        try:
            assert watcher.wait_for(lambda c: "/pirate/tree" in c.channels, 20)
            watcher.subscribe("/pirate/tree")
            assert watcher.wait_for(lambda _: server.subscriptions >= 1, 20)
            for n, (name, hostile) in enumerate(HOSTILE.items(), start=1):
                sock = _raw(server.port)
                try:
                    sock.sendall(hostile())
                finally:
                    sock.close()  # mid-frame, for some
                record = {"type": "tick", "n": n, "t_s": n * 0.1, "status": {"0": "R"}}
                server.publish_record(record)
                assert watcher.wait_for(_has_tick(n), 20), f"after {name}: nothing more served"
            assert server.enabled and server.failure is None
        finally:
            watcher.close()
