"""The live view's pipe: ticks never wait, a lagging server's process gets them merged."""

from __future__ import annotations

import fcntl
import json
import os
import threading
from typing import Any

from pirate_bt.interop.foxglove_backlog import KEEP_COMMANDS, Feed, merge_ticks
from pirate_bt.trace.sink import END, SETUP, TICK, TickEncoder, unframe

IDS = ["0", "0.0", "0.1"]


def _tick(n: int, **members: Any) -> tuple[Any, ...]:
    return (
        TICK,
        n,
        n * 0.05,
        members.get("status"),
        members.get("feedback"),
        members.get("bb"),
        members.get("keys"),
        members.get("raw"),
        members.get("commands"),
        members.get("link"),
        members.get("sim"),
        members.get("events"),
    )


def _ticks(count: int) -> list[tuple[Any, ...]]:
    """A run's tick messages: statuses, state, blackboard, commands and events moving."""
    keys = ("bend_1", None, None, None, None, None)
    out = []
    for n in range(1, count + 1):
        out.append(
            _tick(
                n,
                status=[(n % 3, "RSF"[n % 3])],
                feedback=[(1, f"step {n}")] if n % 5 == 0 else None,
                bb=f',"bb":{{"k{n % 4}":{n}}}' + (',"bb_unset":["k0"]' if n % 7 == 0 else ""),
                keys=keys if n == 1 else None,
                raw=(n * 0.001, None, None, None, None, None),
                commands=[json.dumps({"command": f"drive({n})", "verdict": "pass"})],
                link=[True] if n == 1 else None,
                sim={"distance_m": n * 0.01} if n % 2 else None,
                events=f',"events":[{{"kind":"note","message":"{n}"}}]' if n % 9 == 0 else None,
            )
        )
    return out


def _final(messages: list[tuple[Any, ...]]) -> dict[str, Any]:
    """What a client knows after the messages: every value as it ends up."""
    encoder = TickEncoder(IDS, link_fields=["connected"])
    known: dict[str, Any] = {"status": {}, "feedback": {}, "bb": {}, "state": {}, "sim": {}}
    for message in messages:
        line = encoder.encode(message)
        if line is None:
            continue
        record = json.loads(line)
        for member in ("status", "feedback", "bb", "state", "sim"):
            known[member].update(record.get(member) or {})
        for key in record.get("bb_unset") or ():
            known["bb"].pop(key, None)
        known["n"] = record["n"]
    return known


def test_merged_ticks_end_where_the_ticks_one_by_one_end() -> None:
    ticks = _ticks(40)
    merged = ticks[0]
    for tick in ticks[1:]:
        merged = merge_ticks(merged, tick)
    assert _final([merged]) == _final(ticks)
    assert len(merged[8]) == KEEP_COMMANDS if len(ticks) > KEEP_COMMANDS else 40
    assert json.loads("{" + merged[11][1:] + "}")["events"][-1]["message"] == "36"


def test_a_full_pipe_never_holds_a_tick_and_loses_no_value() -> None:
    """A pipe of one page nobody reads: ticks are merged, counted, and all arrive in the end."""
    read_fd, write_fd = os.pipe()
    fcntl.fcntl(write_fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), 4096)
    os.set_blocking(write_fd, False)
    gone: list[str] = []
    feed = Feed(write_fd, gone.append)
    ticks = _ticks(400)
    got: list[Any] = []
    buffer = bytearray()

    def drain() -> None:
        os.set_blocking(read_fd, False)
        try:
            while chunk := os.read(read_fd, 65536):
                buffer.extend(chunk)
        except BlockingIOError:
            pass
        got.extend(unframe(buffer))

    feed.hand_over(1, (SETUP, IDS, False, False, False, ["connected"]))
    for tick in ticks:
        feed.hand_over(1, tick)  # never blocks: the test would hang
    assert feed.dropped > 300  # the page took only the first few
    dropped = feed.dropped
    drain()
    end = (END, '{"type":"end"}\n')
    # The end waits for room: a reader empties the pipe meanwhile, as the server's process.
    stop = threading.Event()

    def read() -> None:
        while not stop.wait(0.01):
            drain()

    reading = threading.Thread(target=read)
    reading.start()
    try:
        assert feed.finish(1, end) == dropped
    finally:
        stop.set()
        reading.join()
    drain()
    os.close(write_fd)
    os.close(read_fd)
    assert not gone
    messages = [m[2] for m in got if m[0] == 20]
    assert ("DROPPED", [m for m in got if m[0] == 21]) == ("DROPPED", [(21, 1, dropped)])
    assert messages[-1] == end
    sent = [m for m in messages if m[0] == TICK]
    assert len(sent) == len(ticks) - dropped
    assert _final(sent) == _final(ticks)


def test_a_vanished_reader_stops_the_feed_and_says_so() -> None:
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    gone: list[str] = []
    feed = Feed(write_fd, gone.append)
    os.close(read_fd)
    feed.hand_over(1, _tick(1))
    feed.hand_over(1, _tick(2))
    os.close(write_fd)
    assert gone == ["its process has gone (exit {exit})"]
    assert not feed.enabled
