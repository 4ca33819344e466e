"""A bridge the test plays by hand, for the session's rule tests.

Shared by tests/test_link_session_rules.py and tests/test_link_session_resets.py: the
host's session on a :class:`~pirate_bt.clock.SimClock`, every frame it writes read
back, every answer written by the test (:class:`Wire`), and the frames to answer with.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from pirate_bt.clock import SimClock
from pirate_bt.errors import FrameError
from pirate_bt.link.codec import (
    BoardCounters,
    BridgeFlags,
    Counters,
    FrameCodec,
    FrameDecoder,
    Heartbeat,
    HelloReply,
    Message,
    Setpoint,
    State,
    encode_many,
)
from pirate_bt.link.requests import SessionConfig
from pirate_bt.link.session import Session
from pirate_bt.link.testing import memory_pair
from pirate_bt.robot import ControlMode, load_robot

ROBOT = load_robot()
CODEC = FrameCodec.for_robot(ROBOT)
LAYOUT = CODEC.layout
# Binary fractions, so that simulated times add up exactly and "exactly when due" means it.
ACK_S = 0.0625
EPS = 1 / 1024
CONFIG = SessionConfig(
    ack_timeout_s=ACK_S,
    max_retries=2,
    heartbeat_period_s=0.125,
    link_timeout_s=0.5,
    poll_step_s=0.005,
    loss_window=4,
)
LOG = "pirate_bt.link.session"


class Peer:
    """A bridge played by the test on a simulated clock that steps it: it answers each
    host frame with what ``answer(msg)`` returns, and keeps every frame it saw (shared
    by tests/test_link_leftovers.py and tests/test_link_probe10.py)."""

    def __init__(self, answer: Callable[[Message], list[Message]]) -> None:
        self.clock = SimClock(8.0)
        self.host, self.far = memory_pair()
        self.decoder = FrameDecoder(CODEC)
        self.seen: list[Message] = []
        self._answer = answer
        self.clock.add_listener(self.step)

    def step(self, _now: float) -> None:
        for msg in self.decoder.feed(self.far.read_available()):
            if not isinstance(msg, FrameError):
                self.seen.append(msg)
                self.far.write(encode_many(CODEC, self._answer(msg)))

    def session(self) -> Session:
        """The host's session with this bridge (its HELLO answered by :func:`reply`)."""
        return Session(self.host, CODEC, self.clock, CONFIG, hello_reply=reply())


def reply(seq: int = 1, **changes: object) -> HelloReply:
    fields: dict[str, object] = {
        "seq": seq,
        "layout_digest": LAYOUT.digest,
        "n_channels": LAYOUT.n_channels,
        "n_motors": LAYOUT.n_motors,
        "watchdog_ms": 250,
        "boot_id": 7,
        "minor": SessionConfig().protocol_minor,  # the session's (1.2 by default)
    }
    fields.update(changes)
    return HelloReply(**fields)  # type: ignore[arg-type]


def counters(seq: int, **fields: int) -> Counters:
    """A COUNTERS reply with one entry per board of the layout (as the protocol has it)."""
    boards = tuple(BoardCounters(20 + i) for i in range(LAYOUT.n_boards))
    return Counters(seq, **fields, boards=boards)


def state(seq: int, ack_seq: int = 0, flags: BridgeFlags = BridgeFlags.NONE) -> State:
    return State(seq, flags, ack_seq, 0, (1,) * LAYOUT.n_boards, (0,) * LAYOUT.n_channels)


class Wire:
    """A session whose bridge is the test: ``sent()`` decodes what the host wrote since the
    last call, ``answer()`` writes frames back, ``poll(dt)`` lets simulated time pass."""

    def __init__(
        self,
        config: SessionConfig = CONFIG,
        first_seq: int = 2,
        hello: HelloReply | None = None,
        start_s: float = 8.0,
    ) -> None:
        self.clock = SimClock(start_s)
        self.host, self.far = memory_pair()
        self.session = Session(
            self.host, CODEC, self.clock, config, first_seq=first_seq, hello_reply=hello
        )
        self.decoder = FrameDecoder(CODEC)

    def sent(self, *, heartbeats: bool = False) -> list[Message]:
        out = [
            m for m in self.decoder.feed(self.far.read_available()) if not isinstance(m, FrameError)
        ]
        return out if heartbeats else [m for m in out if not isinstance(m, Heartbeat)]

    def answer(self, *msgs: Message) -> None:
        self.far.write(encode_many(CODEC, msgs))

    def poll(self, dt: float = 0.0) -> None:
        if dt:
            self.clock.advance(dt)
        self.session.poll()


def setpoint(wire: Wire, value: int = 1) -> tuple[object, Setpoint]:
    req = wire.session.send_setpoint(22, 1, ControlMode.VELOCITY, value)
    msg = req.msg
    assert isinstance(msg, Setpoint)
    return req, msg


def messages(caplog: pytest.LogCaptureFixture) -> list[tuple[int, str]]:
    return [(r.levelno, r.getMessage()) for r in caplog.records if r.name == LOG]
